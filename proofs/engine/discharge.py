"""Discharging one obligation: its weakenings first (only trusted for `proved`), then as stated."""

from __future__ import annotations

import time
from dataclasses import replace
from fractions import Fraction

from certiloop.models.lang.terms import And, Implies, Node
from certiloop.proofs.arith.projection import abbreviation_instances
from certiloop.proofs.checker.cases import case_formulas
from certiloop.proofs.core import boxes
from certiloop.proofs.core.shaping import shaped_parts
from certiloop.proofs.core.simplify import simplify
from certiloop.proofs.core.solver import SolverAnswer, check_valid
from certiloop.proofs.core.vcgen import Obligation
from certiloop.proofs.core.verdicts import ObligationResult, judge
from certiloop.proofs.core.weaken import weakenings
from certiloop.proofs.engine.budget import PROJECTED_CEX_SHARE, Budget
from certiloop.proofs.engine.polysize import nonlinear_size


def discharge_one(ob: Obligation, budget: Budget | None = None, quick: bool = False,
                  keep_model: bool = False, shaping: bool = True) -> ObligationResult:
    """Prove one obligation: first its weakenings (instantiated, lowered, abstracted; a
    generalisation is only trusted for `proved`), then as stated, which alone can give a
    counterexample. Every form gets the same deterministic budget; once the abstracted form
    has a counterexample the obligation is probably false, and the raw forms get a share.
    quick: the report beside a refutation, where the verdict is already decided by the run.
    keep_model keeps the raw solver model, which may hold live z3 handles.
    shaping: an obligation left unknown is tried shaped (_shaped); off for the trials of an
    ODE planner, which are many, each with a small budget, and only choose a chain."""
    res = _discharge(ob, budget, quick, keep_model, shaping)
    res.rule = ob.rule
    return res


def _discharge(ob: Obligation, budget: Budget | None, quick: bool, keep_model: bool,
               shaping: bool) -> ObligationResult:
    budget = budget or Budget()
    start = time.perf_counter()
    projected_cex = False
    for backend, weaker in weakenings(ob.formula, ob.abbreviations, abbreviation_instances, ob.stronger):
        if projected_cex and quick and "abstracted" not in backend:
            continue  # quick mode: raw forms of a projected-false obligation never finish in a share
        share = budget.share(PROJECTED_CEX_SHARE) if projected_cex else budget
        answer = _check(weaker, share)
        if answer.status == "unsat":
            res = judge(ob.id, ob.path, weaker, answer, time.perf_counter() - start)
            res.backend, res.kind, res.proved_formula = backend.replace("z3", answer.backend), ob.kind, weaker
            return res
        if answer.status == "sat" and "abstracted" in backend:
            projected_cex = True
    if projected_cex and quick:
        return ObligationResult(ob.id, ob.path, "unknown", time.perf_counter() - start, kind=ob.kind,
                                reason="not proved: its projected form (abstracted) has a counterexample")
    share = budget.share(PROJECTED_CEX_SHARE) if projected_cex else budget
    answer = _check(ob.formula, share)
    if answer.status == "unknown" and not quick and not projected_cex and answer.spent >= 0:
        split = _by_cases(ob, share, start)
        if split is not None:
            return split
        shaped = _shaped(ob, share, start) if shaping else None
        if shaped is not None:
            return shaped
    res = judge(ob.id, ob.path, ob.formula, answer, time.perf_counter() - start)
    res.kind, res.backend = ob.kind, answer.backend
    if res.verdict == "proved":
        res.proved_formula = ob.formula
    if res.verdict == "unknown" and projected_cex:
        res.reason = (f"{res.reason}; its projected form (abstracted) has a counterexample, "
                      "so it is probably false")
    if not keep_model and res.raw_model is not None:  # keep the exact plain values (no z3 handles)
        res.raw_model = {k: v for k, v in res.raw_model.items() if isinstance(v, (bool, int, Fraction))}
    return res


def _check(formula: Node, budget: Budget) -> SolverAnswer:
    """z3 on the formula, unless its nonlinear size passes the budget's bound even once its
    constants are folded: then `unknown` at once (spent -1), since z3's resource count would
    not cover most of that work. Exact interval arithmetic over a box (proofs/core/boxes.py)
    is tried first: z3's nonlinear procedure can take half a minute on a claim about a small
    ball that the box decides in milliseconds."""
    size = nonlinear_size(formula)
    if size > budget.max_nonlinear_size:
        size = nonlinear_size(simplify(formula))  # rare: only above the bound
    if size > budget.max_nonlinear_size:
        return SolverAnswer("unknown", f"not given to z3: its nonlinear arithmetic is too large for the "
                            f"deterministic budget (size {size:,} > {budget.max_nonlinear_size:,}: mixed "
                            "monomials x degree x coefficient bits)", spent=-1)
    if boxes.proves(formula):
        return SolverAnswer("unsat", backend="intervals")
    return check_valid(formula, budget.rlimit, budget.wall_s)


def _by_cases(ob: Obligation, budget: Budget, start: float) -> ObligationResult | None:
    """The obligation proved case by case on its guards (proofs/checker/cases.py), the cases
    sharing one more budget of z3 units; None unless every case is proved."""
    cases = case_formulas(ob.formula)
    if cases is None:
        return None
    for case in cases:
        if _check(case, budget.share(len(cases))).status != "unsat":
            return None
    res = ObligationResult(ob.id, ob.path, "proved", time.perf_counter() - start,
                           backend=f"z3 ({len(cases)} cases)", kind=ob.kind)
    res.proved_formula = And(*cases)
    return res


# The parts of a shaped obligation (proofs/core/shaping.py): first each with this share of the
# budget, then those not proved with the whole budget; all of them together at most SHAPED_CAP
# budgets (a hopeless obligation with many parts must not cost many budgets).
FIRST_PASS_SHARE = 2
SHAPED_CAP = 2
MAX_PARTS = 8


def _shaped(ob: Obligation, budget: Budget, start: float) -> ObligationResult | None:
    """The obligation with its denominators cleared, its stale facts dropped and its goal
    split into parts (shaping.py), each part proved; None unless every part is proved.

    A part may assume the parts proved before it (each is a consequence of the hypotheses),
    and the largest parts go first: the adaptive cruise control's distance `xf < xl` at the
    flow's end follows from its stopping-distance part, which z3 proves alone, far sooner than
    from the hypotheses (1.4 million units against more than 4 million)."""
    parts = shaped_parts(ob.formula)
    if parts is None or len(parts) > MAX_PARTS:
        return None
    order = sorted(range(len(parts)), key=lambda k: -len(str(parts[k])))  # stable: ties as written
    proved: dict[int, Node] = {}
    left = budget.rlimit * SHAPED_CAP
    for share in (budget.share(FIRST_PASS_SHARE), budget):
        for k in order:
            if k in proved:
                continue
            if left <= 0:
                return None
            lemmas = [_goal(proved[j]) for j in sorted(proved)]
            with_lemmas = Implies(And(_hypotheses(parts[k]), *lemmas), _goal(parts[k]))
            answer = _check(with_lemmas, replace(share, rlimit=min(share.rlimit, left)))
            left -= max(answer.spent, 0)
            if answer.status == "unsat":
                proved[k] = with_lemmas
    if len(proved) < len(parts):
        return None
    res = ObligationResult(ob.id, ob.path, "proved", time.perf_counter() - start,
                           backend=f"z3 (shaped, {len(parts)} parts)", kind=ob.kind)
    res.proved_formula = And(*(proved[k] for k in sorted(proved)))
    return res


def _hypotheses(part: Node) -> Node:
    return part.args[0] if part.op == "implies" else And()


def _goal(part: Node) -> Node:
    return part.args[1] if part.op == "implies" else part
