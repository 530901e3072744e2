"""The `certiloop` command line: parse, dispatch to the command's module, map errors to exit codes.

Exit codes: 0 claims hold, 1 a claim failed, 2 bad input, 3 an internal inconsistency, 130
interrupted. The commands are `cli/commands/*` and the case studies' own (`campaign`, `plan`,
`check-path`), registered through `certiloop.models.library.registry`."""

from __future__ import annotations

import os
import sys

from certiloop.cli.errors import EXIT_BAD_INPUT, EXIT_FAILED, EXIT_INTERRUPTED, BadInput
from certiloop.cli.parser import build_parser, command_module


def run() -> None:
    """The `certiloop` command: main(), and after Ctrl-C an exit at once. The reports are
    written by then, and the interpreter's exit would only wait for the worker pool's thread,
    sometimes printing "Exception ignored ... Bad file descriptor" after "interrupted"."""
    code = main()
    if code == EXIT_INTERRUPTED:
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
    sys.exit(code)


def main(argv: list[str] | None = None) -> int:
    from certiloop.cli import guards

    restore = guards.on_interrupt_exit_quietly()
    restore_gc = guards.collect_garbage_less_often()
    try:
        from certiloop.proofs.engine.deepstack import call_with_deep_stack

        return call_with_deep_stack(lambda: _main(argv))  # deeply nested models: no recursion limit
    except (BadInput, guards.OutputPathError) as exc:
        print(f"certiloop: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print("certiloop: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except BrokenPipeError:
        return EXIT_FAILED
    except ImportError as exc:
        print(f"certiloop: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except Exception as exc:  # never a traceback for users; CERTILOOP_DEBUG=1 shows it
        if os.environ.get("CERTILOOP_DEBUG"):
            raise
        from certiloop.models.lang.terms import ModelError

        if isinstance(exc, ModelError):
            print(f"certiloop: error: {exc}", file=sys.stderr)
            return EXIT_BAD_INPUT
        if isinstance(exc, RecursionError):  # past the deep stack's limit
            from certiloop.proofs.engine.deepstack import RECURSION_LIMIT

            print("certiloop: error: the model is nested too deeply (more than "
                  f"{RECURSION_LIMIT:,} levels): split deep formulas or sequences "
                  "into named parts", file=sys.stderr)
            return EXIT_BAD_INPUT
        print(f"certiloop: internal error: {type(exc).__name__}: {exc} "
              "(set CERTILOOP_DEBUG=1 for the traceback)", file=sys.stderr)
        return EXIT_BAD_INPUT
    finally:
        restore_gc()
        restore()


def _main(argv: list[str] | None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return EXIT_BAD_INPUT
    return command_module(args.command).run(args)
