"""Weakenings: formulas that imply an obligation and are easier for z3 (trusted rules).

Each step only weakens, so `unsat` for the result proves the obligation:
  instantiate   ∀-hypotheses replaced by some of their instances, ∀-goals skolemised;
  lower         array reads over writes split, reads Ackermannised, index sorts as reals;
  abstract      atoms projected onto abbreviation symbols (any fresh instances will do).
Which abbreviation instances to try is a search outside the core (`find_instances`); the
core keeps only fresh ones and states congruences only where they are congruences.
"""

from __future__ import annotations

from typing import Callable, Iterator

from certiloop.models.lang.memos import NodeMemo
from certiloop.models.lang.terms import INT, Node
from certiloop.proofs.core.abstraction import Instance, abstract, congruences, fresh_instances, lower_term
from certiloop.proofs.core.instantiate import instantiate
from certiloop.proofs.core.lowering import lower

FindInstances = Callable[[dict[str, Node], Node], list[Instance]]


def weakenings(formula: Node, abbreviations: dict[str, Node],
               find_instances: FindInstances, stronger: tuple[tuple[str, Node], ...] = ()
               ) -> Iterator[tuple[str, Node]]:
    """(how it was weakened, the weaker formula), most promising first. `stronger` are
    formulas the obligation generator built to imply the obligation (a strengthened claim)."""
    for how, strong in stronger:
        for label, weaker in _all_weakened(strong, abbreviations, find_instances):
            yield label.replace("z3 (", f"z3 ({how}, ", 1), weaker
        yield f"z3 ({how})", strong
    yield from _all_weakened(formula, abbreviations, find_instances)


def _all_weakened(formula: Node, abbreviations: dict[str, Node], find_instances: FindInstances):
    if _quantifies_integers(formula):
        return  # z3's own quantifier engine handles integer-indexed arrays (builtDR) best
    yield from _weakened(formula, abbreviations, find_instances, wide=False)
    if instantiate(formula) is not None:
        yield from _weakened(formula, abbreviations, find_instances, wide=True)


_INTEGER_QUANTIFIERS = NodeMemo()


def _quantifies_integers(n: Node) -> bool:
    if n.op in ("forall", "exists") and any(v.sort == INT for v in n.payload):
        return True
    if not n.args:
        return False
    got = _INTEGER_QUANTIFIERS.get(n)
    if got is None:
        got = _INTEGER_QUANTIFIERS.put(n, any(_quantifies_integers(a) for a in n.args))
    return got


def _weakened(formula: Node, abbreviations: dict[str, Node], find_instances: FindInstances, wide: bool):
    base, steps = formula, []
    instantiated = instantiate(base, wide, keep_goal_exists=True)
    if instantiated is not None:
        base, steps = instantiated, ["instantiated more" if wide else "instantiated"]
    lowered = lower(base) if _has_arrays(base) else None
    instances = fresh_instances(base, find_instances(abbreviations, base)) if abbreviations else []
    # congruences are checked on the definitions as written, then stated over lowered indices
    facts = congruences(instances, lower_term if lowered is not None else (lambda t: t))
    if lowered is not None:
        base, steps = lowered, steps + ["lowered"]
        instances = fresh_instances(base, [i.with_definition(lower_term(i.definition)) for i in instances])
    abstracted = abstract(base, instances, facts)
    if abstracted is not None:
        yield f"z3 ({', '.join(steps + ['abstracted'])})", abstracted
    if steps:
        yield f"z3 ({', '.join(steps)})", base


_ARRAYS = NodeMemo()


def _has_arrays(n: Node) -> bool:
    if n.op in ("select", "store"):
        return True
    if not n.args:
        return False
    got = _ARRAYS.get(n)
    if got is None:
        got = _ARRAYS.put(n, any(_has_arrays(a) for a in n.args))
    return got
