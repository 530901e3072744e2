"""The argument parser of `certiloop`: one subcommand per module of `cli/commands`, then the case
studies' commands from the registry."""

from __future__ import annotations

import importlib

from certiloop.cli.errors import Parser

# the order `certiloop --help` lists them in
COMMANDS = {"list": "listing", "prove": "prove", "falsify": "falsify", "extract": "extract", "gate": "gate",
            "export": "export", "init": "init", "check-proof": "check_proof"}


def version() -> str:
    from importlib.metadata import PackageNotFoundError
    from importlib.metadata import version as installed

    try:
        return installed("certiloop")
    except PackageNotFoundError:  # pragma: no cover - only when run from an uninstalled tree
        return "unknown"


def build_parser() -> Parser:
    parser = Parser(
        prog="certiloop",
        description="Prove hybrid-program models of robot controllers safe, or show why they are not.",
    )
    parser.add_argument("--version", action="version", version=f"certiloop {version()}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=Parser)
    for name in COMMANDS:
        command_module(name).add_parser(sub)
    for command in study_commands().values():
        command.add_parser(sub)
    return parser


def study_commands() -> dict:
    from certiloop.models.library.registry import resolve, studies

    return {name: resolve(target) for study in studies() for name, target in study.commands.items()}


def command_module(name: str):
    """The module (or a study's command object) that has `add_parser(sub)` and `run(args)`."""
    if name in COMMANDS:
        return importlib.import_module(f"certiloop.cli.commands.{COMMANDS[name]}")
    return study_commands()[name]
