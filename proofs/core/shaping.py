"""Problem shaping before z3 (trusted: each step is an equivalence or a strengthening).

z3's nonlinear procedure (nlsat) is complete, but its cost depends on the shape of what it is
given; the same obligation can take 0.1 s or exhaust any budget. Three steps, each with the
reason it helps and why it is sound:

  clear_denominators  a comparison `p ⋈ q` whose divisors have a sign fixed by a hypothesis
      (`B > 0`, `2*B`, `B^2` with `B != 0`) becomes `N ⋈' 0`, N the numerator of p - q over its
      common denominator D (⋈' flipped when D < 0). EQUIVALENT: where the sign facts hold,
      every divisor is nonzero, so p - q = N/D there and N/D ⋈ 0 ⟺ N ⋈' 0; where a sign fact
      fails, the hypotheses (which keep it) are false on both sides. Helps because z3 reads a
      division by a variable as a fresh symbol tied to it by `B * d = 1` style axioms, which
      nlsat handles poorly: users' `p + v^2/(2*B) < q` stays unknown at 10x the budget while
      `2*B*p + v^2 < 2*B*q` proves in under a second.
  drop_stale  hypotheses about superseded values (SSA symbols `x` or `x@k` with a later
      `x@j` in the formula, none in the goal) that touch the rest only through symbols the
      program never writes are dropped. A STRENGTHENING (fewer hypotheses), so a proof of
      the result proves the obligation. Helps because a loop step keeps the facts about the
      values before the loop (the dL loop rule drops them); they double nlsat's variables,
      and its variable order, which depends on them, decided whether the adaptive cruise
      control's step took 0.1 s or ran out of budget.
  goal_parts  `H -> G1 ∧ ... ∧ Gn` is valid iff every `H -> Gi` is (EQUIVALENT). Helps because
      nlsat searches for one model of `H ∧ ¬G1 ∨ ... ∨ ¬Gn` at once, and one hard part makes
      the easy ones wait behind it.

Only quantifier-free formulas over reals are shaped (the sign facts are read about free
symbols; a quantifier could bind one).
"""

from __future__ import annotations

from fractions import Fraction

import sympy

from certiloop.models.lang.terms import (
    BOOL,
    REAL,
    And,
    Implies,
    Node,
    cmp,
    const,
    free_vars,
    rebuild,
)
from certiloop.proofs.core.symbolic import SympyTable, from_sympy, to_sympy

_FLIP = {"<": ">", "<=": ">=", ">": "<", ">=": "<=", "==": "==", "!=": "!="}
_ARITH = ("const", "var", "+", "*", "neg", "/", "^")


# --------------------------------------------------------------------------- shapes


def hypotheses_and_goal(f: Node) -> tuple[list[Node], Node] | None:
    """`H1 ∧ ... ∧ Hn -> G` with nested implications `H -> (P -> G)` read as `H ∧ P -> G`
    (an equivalence), or None for a formula that is not an implication."""
    if f.op != "implies":
        return None
    hyps: list[Node] = []
    while f.op == "implies":
        hyp, f = f.args
        hyps.extend(hyp.args if hyp.op == "and" else (hyp,))
    return hyps, f


def shapeable(f: Node) -> bool:
    """Quantifier- and modality-free, every symbol real (or a truth value)."""
    def ok(n: Node) -> bool:
        if n.op in ("forall", "exists", "box", "diamond", "select", "store", "ite"):
            return False
        return all(ok(a) for a in n.args)

    return ok(f) and all(v.sort == REAL or v.sort == BOOL for v in free_vars(f).values())


# --------------------------------------------------------------------------- denominators


class _Signs:
    """Signs of polynomials fixed by top-level hypotheses `e ⋈ 0` (e = lhs - rhs, division-free)."""

    def __init__(self, hyps: list[Node], table: SympyTable) -> None:
        self.table = table
        self.facts: list[tuple[sympy.Expr, str]] = []
        for h in hyps:
            if h.op == "cmp" and h.payload in (">", ">=", "<", "<=", "!=") and not _divides(h):
                e = sympy.expand(to_sympy(h.args[0], table) - to_sympy(h.args[1], table))
                self.facts.append((e, h.payload))

    def sign(self, d: sympy.Expr) -> int:
        """+1 or -1 if the hypotheses fix d's sign, 2 if they only make it nonzero, else 0."""
        d = sympy.expand(d)
        if d.is_Rational:
            return 0 if d == 0 else (1 if d > 0 else -1)
        best = 0
        for e, op in self.facts:
            s = _sign_from(e, op, d)
            if s in (1, -1):
                return s
            best = best or s
        return best

    def factors_sign(self, d: sympy.Expr) -> int:
        """d's sign from its factors (a positive constant, powers of factors of known sign,
        even powers of nonzero factors): +1, -1, or 0 if not fixed."""
        coeff, factors = sympy.factor_list(sympy.expand(d))
        if coeff == 0:
            return 0
        total = 1 if coeff > 0 else -1
        for base, k in factors:
            s = self.sign(base)
            if s == 0:
                return 0
            if s == 2:
                if k % 2:
                    return 0
                continue
            total *= s ** k
        return total


def _sign_from(e: sympy.Expr, op: str, d: sympy.Expr) -> int:
    """What the fact `e op 0` says about d's sign when e = c*d + k (c, k rational, c != 0)."""
    k, rest = e.as_coeff_Add()  # e = k + rest, k the constant term
    c = sympy.cancel(rest / d)
    if not (c.is_Rational and c != 0):
        return 0
    # e op 0  ⟺  c*d + k op 0  ⟺  d op' -k/c
    bound = Fraction(int(sympy.Rational(-k / c).p), int(sympy.Rational(-k / c).q))
    op = op if c > 0 else _FLIP[op]
    if op == "!=":
        return 2 if bound == 0 else 0
    if op in (">", ">="):
        return 1 if bound > 0 or (bound == 0 and op == ">") else 0
    return -1 if bound < 0 or (bound == 0 and op == "<") else 0


def _divides(n: Node) -> bool:
    """A division by a non-constant term inside n."""
    if n.op == "/" and n.args[1].op != "const":
        return True
    return any(_divides(a) for a in n.args)


def _divisors(n: Node, out: list[Node]) -> bool:
    """Collect the non-constant divisors of an arithmetic term; False if one divides itself
    (a nested division is left alone)."""
    if n.op == "/":
        if n.args[1].op != "const":
            if _divides(n.args[1]):
                return False
            out.append(n.args[1])
        return _divisors(n.args[0], out) and _divisors(n.args[1], out)
    if n.op not in _ARITH:
        return False
    return all(_divisors(a, out) for a in n.args)


def _cleared(atom: Node, signs: _Signs) -> Node | None:
    """`atom` without division (an equivalent comparison where the sign facts hold), or None."""
    divisors: list[Node] = []
    if not all(_divisors(side, divisors) for side in atom.args) or not divisors:
        return None
    if any(signs.factors_sign(to_sympy(d, signs.table)) == 0 for d in divisors):
        return None  # a divisor the hypotheses do not keep away from 0 (of fixed sign)
    diff = to_sympy(atom.args[0], signs.table) - to_sympy(atom.args[1], signs.table)
    num, den = sympy.fraction(sympy.cancel(sympy.together(diff)))
    sign = signs.factors_sign(den)
    if sign == 0:
        return None
    num = sympy.expand(num)
    op = atom.payload if sign > 0 else _FLIP[atom.payload]
    return cmp(op, from_sympy(num, signs.table), const(0))


def clear_denominators(f: Node) -> Node:
    """f with every comparison whose divisors have a sign its top-level hypotheses fix
    multiplied out (module docstring). f itself when nothing changes."""
    split = hypotheses_and_goal(f)
    if split is None or not shapeable(f) or not _divides(f):
        return f
    hyps, goal = split
    table = SympyTable()
    signs = _Signs(hyps, table)
    if not signs.facts:
        return f
    done: dict[tuple, Node] = {}

    def walk(n: Node) -> Node:
        if n.op == "cmp":
            if n.key not in done:
                try:
                    cleared = _cleared(n, signs)
                except (TypeError, ValueError, sympy.PolynomialError):
                    cleared = None  # sympy cannot take it apart: left as it is
                done[n.key] = n if cleared is None else cleared
            return done[n.key]
        if n.sort != BOOL or not n.args:
            return n
        return rebuild(n, tuple(walk(a) for a in n.args))

    shaped = Implies(And(*(walk(h) for h in hyps)), walk(goal))
    return f if shaped.same(f) else shaped


# --------------------------------------------------------------------------- stale facts


def _version(name: str) -> tuple[str, int] | None:
    """(program variable, SSA version) of a symbol: `x` is version 0, `x@3` version 3; None
    for other generated names (`s@flow`)."""
    root, _, tail = name.partition("@")
    if not tail:
        return root, 0
    return (root, int(tail)) if tail.isdigit() else None


def drop_stale(f: Node) -> Node | None:
    """f without its hypotheses about superseded values (module docstring), or None if it
    has none. A group of hypotheses linked by stale symbols is dropped only when everything
    else it mentions is a symbol that has a single version (a constant of the program)."""
    split = hypotheses_and_goal(f)
    if split is None:
        return None
    hyps, goal = split
    names = set(free_vars(f))
    latest: dict[str, int] = {}
    versions: dict[str, int] = {}
    for name in names:
        v = _version(name)
        if v is not None:
            versions[v[0]] = versions.get(v[0], 0) + 1
            latest[v[0]] = max(latest.get(v[0], 0), v[1])
    in_goal = set(free_vars(goal))

    def stale(name: str) -> bool:
        v = _version(name)
        return v is not None and v[1] < latest[v[0]] and name not in in_goal

    def constant(name: str) -> bool:  # never written: one version, the initial one
        v = _version(name)
        return v is not None and v[1] == 0 and versions[v[0]] == 1

    # groups of hypotheses linked by shared stale symbols (union-find over hypothesis indices)
    parent = list(range(len(hyps)))

    def find(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    owner: dict[str, int] = {}
    for i, h in enumerate(hyps):
        for name in free_vars(h):
            if stale(name):
                if name in owner:
                    parent[find(i)] = find(owner[name])
                else:
                    owner[name] = i
    groups: dict[int, list[int]] = {}
    for i in range(len(hyps)):
        groups.setdefault(find(i), []).append(i)
    dropped: set[int] = set()
    for members in groups.values():
        mentioned = {nm for i in members for nm in free_vars(hyps[i])}
        if not any(stale(nm) for nm in mentioned):
            continue
        if all(stale(nm) or constant(nm) for nm in mentioned):
            dropped.update(members)
    if not dropped:
        return None
    return Implies(And(*(h for i, h in enumerate(hyps) if i not in dropped)), goal)


# --------------------------------------------------------------------------- goal parts


def goal_parts(f: Node) -> list[Node]:
    """`H -> Gi` for each conjunct Gi of the goal (at least one formula: f itself)."""
    split = hypotheses_and_goal(f)
    if split is None:
        return [f]
    hyps, goal = split
    if goal.op != "and":
        return [f]
    return [Implies(And(*hyps), g) for g in goal.args]


def shaped_parts(f: Node) -> list[Node] | None:
    """Formulas whose joint validity implies f's: denominators cleared, stale facts dropped,
    the goal split; None if shaping changes nothing or f is not shapeable."""
    if not shapeable(f) or hypotheses_and_goal(f) is None:
        return None
    g = clear_denominators(f)
    fresher = drop_stale(g)
    g = g if fresher is None else fresher
    parts = goal_parts(g)
    if len(parts) == 1 and parts[0].same(f):
        return None
    return parts
