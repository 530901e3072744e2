"""Terminal rendering of a falsification: the violating run, step by step."""

from __future__ import annotations

from typing import Any

from rich.console import Console

from certiloop.falsify.search import Falsification


def show_falsification(console: Console, result: Falsification) -> None:
    head = f"{result.model}: "
    if not result.found and result.note:
        console.print(f"[bold]{result.model}[/]: [yellow]no run[/]: {result.note} ({result.seconds:.2f} s)",
                      highlight=False)
        return
    if not result.found:
        console.print(f"[bold]{result.model}[/]: [green]no counterexample[/] in {result.examples} examples "
                      f"({result.seconds:.2f} s)")
        return
    run = result.run
    last = run.checkpoints[-1]
    console.print(f"[bold]{head}[/][red]counterexample[/] after {result.examples} examples "
                  f"({result.seconds:.2f} s); re-checked: {result.check}", highlight=False)
    console.print(f"  violated after control step {last.step} (t = {last.time:.6g}): {run.violated}",
                  highlight=False, markup=False)
    previous: dict[str, Any] = {}
    for c in run.checkpoints:
        changed = {k: v for k, v in c.state.items() if previous.get(k) != v}
        previous = c.state
        where = f"step {c.step}, t = {c.time:.6g}"
        choices = f" [{' / '.join(c.choices)}]" if c.choices else ""
        values = ", ".join(f"{k} = {_show(v)}" for k, v in changed.items()) or "no change"
        console.print(f"  {where}{choices}: {values}", highlight=False, markup=False, soft_wrap=False)
    worst = sorted(last.margins.items(), key=lambda kv: kv[1])[:3]
    console.print("  smallest margins at the end: " + ", ".join(f"{k}: {v:.6g}" for k, v in worst),
                  highlight=False, markup=False)


def _show(v: Any) -> str:
    if isinstance(v, dict):
        return "[" + ", ".join(f"{k}: {_show(x)}" for k, x in v.items()) + "]"
    if isinstance(v, float):
        return f"{v:.6g}"
    return str(v)
