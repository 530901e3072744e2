"""Terminal rendering of proof results (rich tables; plain text when piped)."""

from __future__ import annotations

from rich.console import Console
from rich.markup import escape
from rich.table import Table

from certiloop.proofs.engine.prover import TheoremResult

STYLE = {"proved": "green", "refuted": "red", "unknown": "yellow"}


def verdict_text(verdict: str) -> str:
    return f"[{STYLE.get(verdict, 'white')}]{verdict}[/]"


def obligations_table(result: TheoremResult) -> Table:
    table = Table(title=None, show_lines=False, expand=False)
    table.add_column("id", no_wrap=True)
    table.add_column("path in the proof tree")
    table.add_column("verdict", no_wrap=True)
    table.add_column("backend", no_wrap=True)
    table.add_column("s", justify="right", no_wrap=True)
    for o in result.obligations:
        table.add_row(o.id, o.path, verdict_text(o.verdict), o.backend, f"{o.seconds:.3f}")
    return table


def show_result(console: Console, result: TheoremResult, verbose: bool = False) -> None:
    n = len(result.obligations)
    proved = sum(o.verdict == "proved" for o in result.obligations)
    console.print(
        f"[bold]{result.model}[/]: {verdict_text(result.verdict)} "
        f"({proved}/{n} obligations proved, {result.seconds:.2f} s; expected {result.expected})"
    )
    failing = [o for o in result.obligations if o.verdict != "proved"]
    if verbose or n <= 40:
        console.print(obligations_table(result))
    elif failing:
        console.print(f"  {n - len(failing)} obligations proved; not proved:")
    for o in failing:
        line = f"  {o.id} {o.path}: {verdict_text(o.verdict)}"
        if o.reason:
            line += f" — {o.reason}"
        console.print(escape(line).replace(escape(verdict_text(o.verdict)), verdict_text(o.verdict)),
                      highlight=False)
        if o.counterexample and o.verdict == "refuted":
            values = ", ".join(f"{k} = {v}" for k, v in o.counterexample.items())
            console.print(f"    obligation counterexample ({o.check}): {values}", highlight=False,
                          markup=False)
    if result.nonblocking is not None:
        show_nonblocking(console, result)
    if "cross_check" in result.extra:
        show_cross_check(console, result.extra["cross_check"])
    if result.reason:
        console.print(f"  {result.reason}", highlight=False, markup=False)
    if result.refutation is not None:
        show_refutation(console, result)


def show_nonblocking(console: Console, result: TheoremResult) -> None:
    obs = result.nonblocking
    seconds = sum(o.seconds for o in obs)
    console.print(f"  vacuity: the control step has a run from every state it can start in: "
                  f"{verdict_text(result.nonblocking_verdict)} ({len(obs)} obligations, {seconds:.2f} s)")
    for o in obs:
        if o.verdict != "proved":
            console.print(f"    {o.id} {o.path}: {o.verdict} — {o.reason}", highlight=False, markup=False)
    if result.witness:
        mark = "witness" if result.witness_replayed else "no witness"
        console.print(f"    {mark}: {result.witness}", highlight=False, markup=False)


def show_cross_check(console: Console, check: dict) -> None:
    style = "bold red" if check["disagreements"] else "green" if not check["unconfirmed"] else "yellow"
    console.print(f"  second opinion: [{style}]{escape(check['summary'])}[/] "
                  f"({check['resources']:,} cvc5 units, {check['seconds']:.2f} s)", highlight=False)
    for d in check["disagreements"]:
        console.print(f"    {d['id']}: cvc5 finds the proved form false at: "
                      + d["cvc5_model"].replace("\n", ", "), highlight=False, markup=False)
    for u in check["unconfirmed"]:
        console.print(f"    {u['id']}: not confirmed ({u['why']})", highlight=False, markup=False)


def show_refutation(console: Console, result: TheoremResult) -> None:
    ref = result.refutation
    console.print(f"  [bold red]counterexample run[/] (checked with {ref.check}):")
    console.print("    start: " + ", ".join(f"{k} = {v}" for k, v in ref.initial.items()), highlight=False,
                  markup=False)
    if ref.frame:
        console.print("    at the start: " + ", ".join(f"{k} is {v}" for k, v in ref.frame.items()),
                      highlight=False, markup=False)
    previous = dict(ref.initial)
    for step in ref.shown:
        target = step.target.split("[")[0]  # a family's cell shows as the whole family
        changed = {k: v for k, v in step.state.items() if previous.get(k, v) != v or k == target}
        previous = step.state
        where = f"[{step.path}] " if step.path else ""
        after = ", ".join(f"{k} = {v}" for k, v in changed.items()) or "no change"
        console.print(f"    {where}{step.what}  →  {after}", highlight=False, markup=False)
    console.print(f"    violated: {ref.violated}", highlight=False, markup=False)
    if result.run is not None:
        console.print(f"    independent checks: {result.run.detail}", highlight=False, markup=False)
