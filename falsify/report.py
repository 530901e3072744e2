"""Terminal rendering of a falsification: the violating run, step by step."""

from __future__ import annotations

from fractions import Fraction
from typing import Any

from rich.console import Console
from rich.markup import escape

from certiloop.cli import ui
from certiloop.falsify.search import UNCONFIRMED, Falsification


def show_falsification(console: Console, result: Falsification, level: int = ui.NORMAL) -> None:
    """One model's search: a line when no run violates the guarantee (none with --quiet), else
    the violating run step by step (--verbose: every margin at the end, not the 3 smallest)."""
    name = escape(result.model)
    if result.skipped:
        console.print(f"[bold]{name}[/]: [yellow]not run[/]: {escape(result.skipped)}", highlight=False)
        return
    if not result.found and result.note:
        console.print(f"[bold]{name}[/]: [yellow]no run[/]: {escape(result.note)} ({result.seconds:.2f} s)",
                      highlight=False)
        return
    if result.candidate:
        console.print(f"[bold]{name}[/]: [yellow]{UNCONFIRMED}[/] (not a counterexample) after "
                      f"{result.examples} examples ({result.seconds:.2f} s): {escape(result.check)}",
                      highlight=False)
        if level > ui.QUIET:
            _show_run(console, result, level)
        return
    if not result.found:
        if level > ui.QUIET:
            console.print(f"[bold]{name}[/]: [green]no counterexample[/] in {result.examples} examples "
                          f"({result.seconds:.2f} s)", highlight=False)
        return
    console.print(f"[bold]{name}[/]: [red]counterexample[/] after {result.examples} examples "
                  f"({result.seconds:.2f} s); re-checked: {escape(result.check)}"
                  f"{'; numbers shrunk' if result.shrunk else ''}", highlight=False)
    _show_run(console, result, level)


def _show_run(console: Console, result: Falsification, level: int) -> None:
    run = result.run
    last = run.checkpoints[-1]
    ui.say(console, f"  violated after control step {last.step} (t = {last.time:.6g}): {run.violated}")
    previous: dict[str, Any] = {}
    for c in run.checkpoints:
        changed = {k: v for k, v in c.state.items() if previous.get(k) != v}
        previous = c.state
        where = f"step {c.step}, t = {c.time:.6g}"
        choices = f" [{' / '.join(c.choices)}]" if c.choices else ""
        values = ", ".join(f"{k} = {_show(v)}" for k, v in changed.items()) or "no change"
        ui.say(console, f"  {where}{choices}: {values}")
    margins = sorted(last.margins.items(), key=lambda kv: kv[1])
    shown = margins if level == ui.VERBOSE else margins[:3]
    what = "margins" if level == ui.VERBOSE else "smallest margins"
    ui.say(console, f"  {what} at the end: " + ", ".join(f"{k}: {v:.6g}" for k, v in shown))


def _show(v: Any) -> str:
    if isinstance(v, dict):
        return "[" + ", ".join(f"{k}: {_show(x)}" for k, x in v.items()) + "]"
    if isinstance(v, float):
        return f"{v:.6g}"
    if isinstance(v, Fraction):
        return str(v) if len(str(v)) <= 12 else f"{float(v):.6g}"
    return str(v)
