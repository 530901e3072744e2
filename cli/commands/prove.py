"""`certiloop prove`: split models into obligations, discharge them, report."""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from certiloop.cli import options
from certiloop.cli.errors import EXIT_BAD_INPUT, EXIT_FAILED, EXIT_INCONSISTENT, EXIT_OK


def add_parser(sub) -> None:
    prove = sub.add_parser(
        "prove", help="generate and discharge proof obligations",
        description="Prove MODEL(s): split each into proof obligations, discharge them with z3, "
        "and, if any is not proved, search for a run that violates the guarantee. "
        "Exit 0 if every obligation of every model is proved, 1 otherwise.")
    prove.add_argument("models", nargs="+", metavar="MODEL",
                       help="library name (sbs.ctrl1) or path/to/file.py:theorem")
    prove.add_argument("--json", metavar="F", help="write results as JSON to F ('-' for stdout)")
    prove.add_argument("--smtlib", metavar="DIR", help="write every obligation as an SMT-LIB 2.6 file")
    prove.add_argument("--certificate", metavar="DIR", help="write a proof certificate (JSON, checked by "
                       "`certiloop check-proof`) for each proved model into DIR")
    prove.add_argument("--check", action="store_true",
                       help="re-check every proof with the separate proof checker (as `check-proof` does): "
                       "'proved (checked)' when it accepts; if it rejects, unknown with its reason")
    options.budget_flags(prove)
    options.cross_check_flag(prove)
    prove.add_argument("--allow-vacuous", action="store_true",
                       help="accept a proof that says nothing (unsatisfiable assumptions, or a first control "
                       "step no run gets through); without it such a model is 'vacuous' and fails (exit 1)")
    prove.add_argument("--jobs", metavar="N", type=int, default=None,
                       help="worker processes (default: number of cores)")
    prove.add_argument("--executor", metavar="URL", help="discharge obligations on a Dask scheduler "
                       "(tcp://host:8786; needs certiloop[distributed])")
    options.verbosity_flags(prove, "every obligation with its backend or reason")


def run(args: argparse.Namespace) -> int:
    options.check_common(args)
    options.check_outputs(("--json", args.json, "file or -"), ("--smtlib", args.smtlib, "folder"),
                          ("--certificate", args.certificate, "folder"))
    from certiloop import api
    from certiloop.api.loading import Unsupported, hint_notes, load_all

    theorems = load_all(args.models, keep_unsupported=True)  # all bad names fail before any work

    from certiloop.cli import ui
    from certiloop.cli.proof_table import show_result, show_unsupported
    from certiloop.models.lang.terms import ModelError
    from certiloop.proofs.engine.prover import Prover

    out, level = options.console(stderr=args.json == "-"), ui.verbosity(args)
    smt_dir = Path(args.smtlib) if args.smtlib else None
    start, results, docs, unsupported = time.perf_counter(), [], [], []
    try:
        with Prover(jobs=args.jobs, budget=options.budget(args), executor=args.executor) as prover, \
                ui.ModelProgress("proving", len(theorems), level > ui.QUIET) as progress:
            for theorem in theorems:
                progress.model(theorem.name)
                try:
                    with options.naming(theorem.name):
                        if isinstance(theorem, Unsupported):
                            raise ModelError(theorem.reason)
                        result = api.prove(theorem, prover=prover, on_start=progress.steps,
                                           on_result=progress.step, smtlib_dir=smt_dir)
                except Exception as exc:  # one of several models: its row, and the others run
                    if len(theorems) == 1 or not options.own_row(exc):
                        raise
                    unsupported.append(Unsupported(theorem.name, options.row_reason(theorem.name, exc)))
                    show_unsupported(out, theorem.name, unsupported[-1].reason)
                    docs.append(unsupported[-1].to_json())
                    continue
                if notes := hint_notes(theorem):
                    result.extra["tactic_hints"] = list(notes)
                if args.cross_check:
                    cross_check(result)
                if args.check:
                    check_proof(result)
                show_result(out, result, level)
                if args.certificate and result.proof is not None:
                    from certiloop.proofs.engine.certificate_writer import write_certificate

                    write_certificate(*result.proof, Path(args.certificate), result.obligations)
                results.append(result)
                docs.append(result.to_json())
    except KeyboardInterrupt:
        options.write_json(args.json, options.json_payload(docs, len(theorems)))
        raise
    proved = sum(r.verdict == "proved" for r in results)
    missing = f", {len(unsupported)} not supported" if unsupported else ""
    ui.say(out, f"{proved} of {len(theorems)} model{'s' * (len(theorems) != 1)} proved{missing} "
                f"({time.perf_counter() - start:.1f} s)")
    options.write_json(args.json, options.json_payload(docs, len(theorems)))
    return prove_exit(results, unsupported, allow_vacuous=args.allow_vacuous)



def prove_exit(results: list, unsupported: list = (), allow_vacuous: bool = False) -> int:
    alarms = [r for r in results if r.extra.get("cross_check", {}).get("disagreements")]
    for r in alarms:
        print(f"certiloop: SOUNDNESS ALARM: cvc5 disagrees with z3 on {r.model}: "
              f"{r.extra['cross_check']['summary']}; please report this certiloop bug", file=sys.stderr)
    if alarms or any(r.inconsistent for r in results):
        return EXIT_INCONSISTENT
    for r in results:
        if r.ill_defined:
            print(f"certiloop: error: {r.model} is {r.reason}", file=sys.stderr)
    options.name_unsupported(unsupported)
    if any(r.ill_defined for r in results) or unsupported:
        return EXIT_BAD_INPUT
    vacuous = [r for r in results if r.vacuous]
    for r in vacuous:
        what = "accepted (--allow-vacuous)" if allow_vacuous else "pass --allow-vacuous to accept it"
        print(f"certiloop: {'warning' if allow_vacuous else 'error'}: {r.model} is vacuous: {r.vacuous}; "
              f"the proof holds for any guarantee ({what})", file=sys.stderr)
    all_proved = all(r.verdict == "proved" and r.nonblocking_verdict in (None, "proved") for r in results)
    return EXIT_OK if all_proved and (allow_vacuous or not vacuous) else EXIT_FAILED



def check_proof(result) -> None:
    """A proved model's certificate re-checked by the separate checker (proofs/checker), from
    its JSON text as `check-proof` reads it: kept as extra["checked"] when accepted; otherwise
    the verdict becomes unknown, with the checker's message as the reason."""
    if result.verdict != "proved":
        return
    from certiloop.proofs.engine.checked import check_proof as checked
    from certiloop.proofs.engine.checked import rejected_reason

    outcome = checked(result.proof, result.obligations)
    if outcome.accepted:
        result.extra["checked"] = outcome.message
    else:
        result.verdict = "unknown"
        result.reason = rejected_reason(outcome.message)


def cross_check(result) -> None:
    """cvc5's opinion on every form z3 proved, kept in the result (shown, and in --json)."""
    from certiloop.proofs.engine.second_opinion import second_opinion

    opinion = second_opinion(result.obligations + (result.nonblocking or []))
    result.extra["cross_check"] = {**opinion.to_json(), "summary": opinion.summary}

