"""Terminal rendering of proof results (rich tables; plain text when piped)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from rich.console import Console
from rich.markup import escape
from rich.table import Table

from certiloop.cli import ui

if TYPE_CHECKING:  # annotations only: a warm gate's table must not load z3 and sympy
    from certiloop.proofs.engine.prover import TheoremResult

STYLE = {"proved": "green", "refuted": "red", "unknown": "yellow", "rule failed": "yellow",
         "not supported": "magenta"}

# an obligation that is false past an incomplete rule shows the rule failing, not the claim
# each names the annotation in the Python DSL and, after "kyx:", in a KeYmaera X archive
RULE_HINTS = {
    "dW": "this ODE has no polynomial solution, so after it only its domain is known: add "
          "differential invariants that give what is needed (ode(..., invariants=[...]); "
          "kyx: `{x' = ...}@invariant(...)`)",
    "dI": "this differential invariant is not preserved by the flow (its derivative condition "
          "fails): choose another one, or cut in a helper invariant before it",
    "dI-init": "this differential invariant does not hold when the ODE starts: fix it "
               "(ode(..., invariants=[...]); kyx: `{x' = ...}@invariant(...)`)",
    "dC": "the ODE's differential invariants do not give what is needed after it: add a stronger one "
          "(ode(..., invariants=[...]); kyx: `{x' = ...}@invariant(...)`)",
    "guarantee-as-invariant": "this loop has no invariant, so the guarantee is used and it is not "
                              "inductive: give one (loop(..., invariant=J); kyx: `{...}*@invariant(J)`)",
    "loop-invariant": "the loop invariant is not strong enough here: strengthen loop(..., invariant=J) "
                      "(kyx: `{...}*@invariant(J)`)",
    "loop-init": "the loop invariant does not hold when the loop starts: fix loop(..., invariant=J) "
                 "(kyx: `{...}*@invariant(J)`)",
}


def label(verdict: str, rule: str = "") -> str:
    """An obligation's verdict as shown: `rule failed` when it is false only because an
    incomplete rule (dW, dI, a loop invariant) did not apply; the verdict itself is unchanged."""
    return "rule failed" if verdict == "refuted" and rule else verdict


def hint(verdict: str, rule: str = "") -> str:
    return RULE_HINTS.get(rule, "") if label(verdict, rule) == "rule failed" else ""


def verdict_text(verdict: str) -> str:
    return f"[{STYLE.get(verdict, 'white')}]{verdict}[/]"


def obligations_table(result: TheoremResult, out: Console | None = None) -> Table:
    table = ui.table(out) if out is not None else Table()
    table.add_column("id", no_wrap=True)
    table.add_column("path in the proof tree", overflow="fold")
    table.add_column("verdict", no_wrap=True)
    table.add_column("backend", overflow="fold")
    table.add_column("s", justify="right", no_wrap=True)
    for o in result.obligations:
        table.add_row(o.id, escape(o.path), verdict_text(label(o.verdict, o.rule)), escape(o.backend),
                      f"{o.seconds:.3f}")
    return table


def show_unsupported(console: Console, name: str, reason: str) -> None:
    """An archive entry certiloop cannot read or prove: its row, with the one-line reason."""
    console.print(f"[bold]{escape(name)}[/]: {verdict_text('not supported')}", highlight=False)
    ui.say(console, f"  {reason}")


def show_result(console: Console, result: TheoremResult, level: int = ui.NORMAL) -> None:
    """One model's proof: a header line, the obligations (a table unless there are many, or
    --quiet), what was not proved and why, and the counterexample run if there is one.
    --quiet shows nothing for a model that is proved."""
    level = int(level)  # a bool `verbose` is accepted too
    n = len(result.obligations)
    proved = sum(o.verdict == "proved" for o in result.obligations)
    fine = result.verdict == "proved" and result.nonblocking_verdict in (None, "proved")
    if level == ui.QUIET and fine:
        return
    checked = " (checked)" if result.verdict == "proved" and "checked" in result.extra else ""
    console.print(f"[bold]{escape(result.model)}[/]: {verdict_text(result.verdict)}{checked} "
                  f"({proved}/{n} obligations proved, {result.seconds:.2f} s; expected {result.expected})",
                  highlight=False)
    failing = [o for o in result.obligations if o.verdict != "proved"]
    if level == ui.VERBOSE or (level == ui.NORMAL and n <= 40):
        console.print(obligations_table(result, console))
    elif failing and level == ui.NORMAL:
        console.print(f"  {n - len(failing)} obligations proved; not proved:")
    for o in result.obligations if level == ui.VERBOSE else failing:
        show_obligation(console, o, hints=result.verdict != "refuted")
    if result.nonblocking is not None:
        show_nonblocking(console, result)
    if "cross_check" in result.extra:
        show_cross_check(console, result.extra["cross_check"])
    if result.reason:
        ui.say(console, f"  {result.reason}")
    if result.extra.get("tactic_hints") and (level == ui.VERBOSE or not fine):
        ui.say(console, "  the entry's Tactic (its invariants read as hints):")
        for note in result.extra["tactic_hints"]:
            ui.say(console, f"    {note}", indent="      ")
    if result.refutation is not None:
        show_refutation(console, result)


def show_obligation(console: Console, o, hints: bool = True) -> None:
    """An obligation's verdict, why, where it fails and, for a failed rule, the fix (not
    when a violating run shows the design itself is unsafe: hints=False)."""
    shown = label(o.verdict, o.rule)
    detail = o.reason or (f"by {o.backend}" if o.verdict == "proved" else "")
    ui.say(console, f"  {o.id} {o.path}: {shown}" + (f" — {detail}" if detail else ""), indent="    ")
    if o.counterexample and o.verdict == "refuted":
        values = ", ".join(f"{k} = {v}" for k, v in o.counterexample.items())
        where = "the rule fails at" if shown == "rule failed" else "obligation counterexample"
        ui.say(console, f"    {where} ({o.check}): {values}")
    if hints and hint(o.verdict, o.rule):
        ui.say(console, f"    hint: {hint(o.verdict, o.rule)}")


def show_nonblocking(console: Console, result: TheoremResult) -> None:
    obs = result.nonblocking
    seconds = sum(o.seconds for o in obs)
    console.print(f"  vacuity: the control step has a run from every state it can start in: "
                  f"{verdict_text(result.nonblocking_verdict)} ({len(obs)} obligations, {seconds:.2f} s)",
                  highlight=False)
    for o in obs:
        if o.verdict != "proved":
            ui.say(console, f"    {o.id} {o.path}: {o.verdict} — {o.reason}")
    if result.witness:
        mark = "witness" if result.witness_replayed else "no witness"
        ui.say(console, f"    {mark}: {result.witness}")


def show_cross_check(console: Console, check: dict) -> None:
    style = "bold red" if check["disagreements"] else "green" if not check["unconfirmed"] else "yellow"
    console.print(f"  second opinion: [{style}]{escape(check['summary'])}[/] "
                  f"({check['resources']:,} cvc5 units, {check['seconds']:.2f} s)", highlight=False)
    for d in check["disagreements"]:
        ui.say(console, f"    {d['id']}: cvc5 finds the proved form false at: "
               + d["cvc5_model"].replace("\n", ", "))
    for u in check["unconfirmed"]:
        ui.say(console, f"    {u['id']}: not confirmed ({u['why']})")


def show_refutation(console: Console, result: TheoremResult) -> None:
    ref = result.refutation
    what = "state" if ref.depth == 0 and not ref.trace else "run"
    console.print(f"  [bold red]counterexample {what}[/] (checked with {ref.check}):")
    ui.say(console, "    start: " + ", ".join(f"{k} = {v}" for k, v in ref.initial.items()))
    if ref.frame:
        ui.say(console, "    at the start: " + ", ".join(f"{k} is {v}" for k, v in ref.frame.items()))
    previous = dict(ref.initial)
    for step in ref.shown:
        target = step.target.split("[")[0]  # a family's cell shows as the whole family
        changed = {k: v for k, v in step.state.items() if previous.get(k, v) != v or k == target}
        previous = step.state
        where = f"[{step.path}] " if step.path else ""
        after = ", ".join(f"{k} = {v}" for k, v in changed.items()) or "no change"
        ui.say(console, f"    {where}{step.what}  →  {after}")
    ui.say(console, f"    violated: {ref.violated}")
    if result.run is not None:
        ui.say(console, f"    independent checks: {result.run.detail}")
