"""The CLI reference page, generated from the argument parser itself
(`certiloop.cli.parser.build_parser()`): every command, argument and flag with its help text, so
the page cannot drift from the code."""

from __future__ import annotations

import argparse


def _subparsers(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    for action in parser._actions:  # argparse keeps the subcommands only here
        if isinstance(action, argparse._SubParsersAction):
            return dict(action.choices)
    return {}


def _helps(parser: argparse.ArgumentParser) -> dict[str, str]:
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return {a.dest: a.help or "" for a in action._choices_actions}
    return {}


def _name(action: argparse.Action) -> str:
    if action.option_strings:
        flags = ", ".join(f"`{s}`" for s in action.option_strings)
        takes = action.nargs != 0
        return f"{flags} `{action.metavar or action.dest.upper()}`" if takes else flags
    metavar = action.metavar or action.dest
    return f"`{metavar}`" + ("..." if action.nargs in ("*", "+") else "")


def _detail(action: argparse.Action) -> str:
    text = (action.help or "").replace("%(default)s", str(action.default)).replace("|", "\\|")
    extras = []
    if action.choices and not isinstance(action, argparse._SubParsersAction):
        extras.append("one of " + ", ".join(f"`{c}`" for c in action.choices))
    if action.required and action.option_strings:
        extras.append("required")
    if not action.option_strings:
        extras.append(
            {"*": "zero or more", "+": "one or more", "?": "optional"}.get(action.nargs, "required")
        )
    return text + (f" ({'; '.join(extras)})" if extras else "")


def _usage(parser: argparse.ArgumentParser) -> str:
    text = parser.format_usage().strip()
    return text[len("usage: ") :] if text.startswith("usage: ") else text


def command_section(name: str, parser: argparse.ArgumentParser, summary: str) -> list[str]:
    out = [f"## certiloop {name}", "", summary[:1].upper() + summary[1:] + ".", ""]
    if parser.description and parser.description != summary:
        out += [parser.description, ""]
    out += ["```text", _usage(parser), "```", "", "| argument | what it does |", "|---|---|"]
    for action in parser._actions:
        if isinstance(action, argparse._HelpAction) or action.help == argparse.SUPPRESS:
            continue
        out.append(f"| {_name(action)} | {_detail(action)} |")
    return out + [""]


def page() -> str:
    import os

    saved = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = "100"  # argparse wraps usage lines to the terminal: the same page everywhere
    try:
        return _page()
    finally:
        if saved is None:
            del os.environ["COLUMNS"]
        else:
            os.environ["COLUMNS"] = saved


def _page() -> str:
    from certiloop.cli.parser import build_parser

    parser = build_parser()
    helps = _helps(parser)
    out = [
        "# CLI reference",
        "",
        "Generated from certiloop's argument parser when the docs are built: every command, "
        "argument and flag, as `certiloop COMMAND --help` shows them. Exit codes, budgets and "
        "report formats are in [Reports, exit codes and budgets](outputs.md).",
        "",
        "```text",
        _usage(parser),
        "```",
        "",
        "| flag | what it does |",
        "|---|---|",
        "| `-h`, `--help` | show the help and exit |",
        "| `--version` | print certiloop's version and exit |",
        "",
    ]
    for name, sub in _subparsers(parser).items():
        out += command_section(name, sub, helps.get(name, ""))
    return "\n".join(out)


if __name__ == "__main__":
    print(page())
