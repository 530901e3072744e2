"""Assumed formulas with their loops bounded (trusted).

The sequent rules of vcgen.establish assume some parts of a goal: the left of `->`, and the
disjuncts other than the one proved. wp.py cannot expand a modality there whose program
holds a loop (or a flow without a polynomial solution), so such a part is replaced by a
formula without them that it implies: the obligations then assume less than the claim
gives, never more, and a proof stays a proof.

  assumed (weaker):        [a*]P  becomes  [a^{<=k}]P   (runs with at most k iterations
                                                          are among a*'s runs)
                           <a*>P, [flow]P, <flow>P  become  true
  under a negation         <a*>P  becomes  <a^{<=k}>P   (fewer runs: it implies <a*>P)
  (stronger):              [a*]P, [flow]P, <flow>P  become  false
An unrolling with more than MAX_PATHS paths is not built: the modality becomes true (assumed)
or false (under a negation), which only weakens what a proof may use.
"""

from __future__ import annotations

from typing import Callable

from certiloop.models.lang.nesting import has_loop_modality
from certiloop.models.lang.programs import ODE, Program, children, is_loop_free
from certiloop.models.lang.terms import BOOL, FALSE, TRUE, Box, Diamond, Node, Not
from certiloop.proofs.core.wp import unroll, unrolled_paths

Solvable = Callable[[ODE], bool]
ITERATIONS = 3  # a loop's runs kept: those with at most this many iterations
MAX_PATHS = 512  # nested loops' unrollings multiply: past this many paths, keep none


def unrollable(p: Program, iterations: int = ITERATIONS) -> bool:
    """Is p's unrolling small enough to expand (a 3-deep nest of two-way loops has 10^10 paths)?"""
    return unrolled_paths(p, iterations) <= MAX_PATHS


def bounded(f: Node, iterations: int, solvable: Solvable, assumed: bool = True) -> Node:
    """A formula without loops in its modalities that f implies (assumed) or that implies f
    (assumed=False); f itself when it has none to bound."""
    if not _needs(f, solvable):
        return f
    op = f.op
    if op == "not":
        return Not(bounded(f.args[0], iterations, solvable, not assumed))
    if op in ("and", "or", "forall", "exists"):
        return Node(op, tuple(bounded(a, iterations, solvable, assumed) for a in f.args), BOOL, f.payload)
    if op == "implies":
        left, right = f.args
        return Node(op, (bounded(left, iterations, solvable, not assumed),
                         bounded(right, iterations, solvable, assumed)), BOOL)
    if op in ("box", "diamond"):
        return _modality(f, iterations, solvable, assumed)
    return TRUE if assumed else FALSE  # an equivalence: each side is read both ways


def _modality(f: Node, iterations: int, solvable: Solvable, assumed: bool) -> Node:
    box = f.op == "box"
    program = f.payload
    if is_loop_free(program) and _flows_solvable(program, solvable):
        post = bounded(f.args[0], iterations, solvable, assumed)
        return Box(program, post) if box else Diamond(program, post)
    # [a*]P keeps its first runs when assumed; <a*>P keeps them when it must imply the claim
    keeps_runs = assumed if box else not assumed
    if not keeps_runs or not unrollable(program, iterations):
        return TRUE if assumed else FALSE
    runs = unroll(program, iterations)
    if not _flows_solvable(runs, solvable):
        return TRUE if assumed else FALSE
    post = bounded(f.args[0], iterations, solvable, assumed)
    return Box(runs, post) if box else Diamond(runs, post)


def _needs(f: Node, solvable: Solvable) -> bool:
    if f.op in ("box", "diamond") and not _flows_solvable(f.payload, solvable):
        return True
    return has_loop_modality(f) or any(_needs(a, solvable) for a in f.args)


def _flows_solvable(p: Program, solvable: Solvable) -> bool:
    if isinstance(p, ODE):
        return solvable(p)
    return all(_flows_solvable(q, solvable) for q in children(p))
