"""`certiloop extract`: the controller of a proved model as Python or C, or its monitors."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from certiloop.cli import options
from certiloop.cli.errors import EXIT_FAILED, EXIT_OK, BadInput


def add_parser(sub) -> None:
    extract = sub.add_parser(
        "extract", help="generate runtime code from a verified model's controller",
        description="Generate a numpy module computing the controller of MODEL (vectorised over "
        "its family of boundaries) from the model's syntax tree, or with --lang c a C99 source and "
        "header. The code carries the model's content hash; the kernel refuses to run with a model "
        "that changed since.")
    extract.add_argument("model", metavar="MODEL", help="library name (sbs.ctrl2) or path/to/file.py:theorem")
    extract.add_argument("-o", "--output", metavar="FILE|DIR", help="write the module to FILE (default: "
                         "stdout); with --lang c, the folder DIR gets MODEL.c and MODEL.h")
    extract.add_argument("--lang", choices=("python", "c"), default="python",
                         help="python (default): a numpy module; c: C99 source and header, no allocation, "
                         "libm only")
    extract.add_argument("--cache", metavar="DIR", help="proof cache folder (default .certiloop/cache, "
                         "or $CERTILOOP_CACHE): a model proved there under this exact claim is not re-proved")
    extract.add_argument("--no-cache", action="store_true", help="prove the model afresh")
    extract.add_argument("--monitors", action="store_true",
                         help="write the model's ModelPlex-style monitors (controller_monitor, "
                         "plant_monitor) instead of its controller")
    options.budget_flags(extract)
    extract.add_argument("--jobs", metavar="N", type=int, default=None,
                         help="worker processes for the proof (default: number of cores)")
    options.verbosity_flags(extract, "the proof's obligations (on stderr)")


def run(args: argparse.Namespace) -> int:
    """Extract only what is proved: the model must prove now, or have a cache entry for its
    exact claim (canonical text, certiloop source, z3 and sympy versions)."""
    options.check_common(args)
    if args.lang == "c" and args.monitors:
        raise BadInput("--monitors writes the Python monitors; leave out --lang c")
    if args.lang == "c" and not args.output:
        raise BadInput("--lang c writes two files (MODEL.c and MODEL.h); give the folder with -o DIR")
    options.check_outputs(("--output", args.output, "folder" if args.lang == "c" else "file"),
                   ("--cache", args.cache, "folder"))
    from certiloop import api
    from certiloop.api.loading import load
    from certiloop.cli import ui
    from certiloop.cli.proof_table import show_result
    from certiloop.kernel.extract import extract
    from certiloop.kernel.extract.c.emit import extract_c
    from certiloop.proofs.engine.cache import Cache
    from certiloop.proofs.engine.prover import Prover

    theorem = load(args.model)
    level, err = ui.verbosity(args), options.console(stderr=True)
    cache = None if args.no_cache else Cache(Path(args.cache) if args.cache else None)
    key = cache.key("proof", theorem.canonical) if cache else None
    cached = cache.get(key) if cache else None
    if cached is not None and cached.get("verdict") == "proved":
        verdict, reason = "proved", ""
        if level == ui.VERBOSE:
            ui.say(err, f"{theorem.name}: proved (from the proof cache)")
    else:
        with Prover(jobs=args.jobs, budget=options.budget(args)) as prover:
            result = api.prove(theorem, prover=prover)
        if level == ui.VERBOSE:
            show_result(err, result, level)
        verdict, reason = result.verdict, result.reason
        if cache and verdict == "proved":
            cache.put(key, {"model": theorem.name, "verdict": verdict})
    if verdict != "proved":
        why = f": {reason}" if reason else ""
        print(f"certiloop: error: refusing to extract {theorem.name}: it is {verdict}, not proved{why}",
              file=sys.stderr)
        return EXIT_FAILED
    if args.lang == "c":
        from certiloop.kernel.extract.c.emit import compile_error

        files = extract_c(theorem)
        problem = compile_error(files)
        if problem is not None:
            print(f"certiloop: error: the C generated for {theorem.name} does not compile ({problem}); "
                  "nothing was written: please report it with the model", file=sys.stderr)
            return EXIT_FAILED
        folder = Path(args.output)
        folder.mkdir(parents=True, exist_ok=True)
        for name, text in files.items():
            (folder / name).write_text(text)
        if level > ui.QUIET:
            ui.say(err, f"wrote {', '.join(str(folder / n) for n in files)} (from the proved model "
                   f"{theorem.name})")
        return EXIT_OK
    if args.monitors:
        from certiloop.kernel.extract.modelplex import monitors

        source = monitors(theorem)
    else:
        source = extract(theorem)
    if args.output:
        Path(args.output).write_text(source)
        if level > ui.QUIET:
            ui.say(err, f"wrote {args.output} (from the proved model {theorem.name})")
    else:
        sys.stdout.write(source)
    return EXIT_OK

