"""Read a theorem and hint formulas back from their text: `repr` of a node's or program's key.

A key is a nested tuple of strings, numbers, None, booleans and `Fraction(n, d)` calls; it is
parsed by a literal evaluator that admits nothing else (no names, no other calls), and each
node is rebuilt as written. The rebuilt theorem is then checked by `Theorem` itself (sorts,
names) and must print back to exactly the text it came from.
"""

from __future__ import annotations

import functools
import re
from fractions import Fraction

from certiloop.models.lang.programs import ODE, Assign, Choice, Count, Each, Havoc, Loop, Program, Seq, Test
from certiloop.models.lang.roles import Roles
from certiloop.models.lang.terms import BOOL, INT, REAL, ModelError, Node, Sort
from certiloop.models.lang.theorem import Theorem

THEOREM_FORMAT = "certiloop-theorem/1"


class Malformed(ValueError):
    """The certificate cannot be read: exit 2."""


def fields(obj: object, names: set[str], where: str) -> dict:
    if not isinstance(obj, dict) or set(obj) != names:
        got = sorted(obj) if isinstance(obj, dict) else type(obj).__name__
        raise Malformed(f"{where} must have exactly the fields {sorted(names)}, got {got}")
    return obj


# a key's text: tuples of strings (without escapes), integers, None, booleans and Fraction(n, d)
TOKEN = re.compile(r"\s*(?:(\()|(\))|,|'([^'\\]*)'|\"([^\"\\]*)\"|(-?\d+)|(None|True|False)"
                   r"|Fraction\((-?\d+), ([1-9]\d*)\))")
WORDS = {"None": None, "True": True, "False": False}
OPS = {"var", "const", "+", "*", "neg", "/", "^", "select", "store", "ite", "cmp", "and", "or", "not",
       "implies", "iff", "forall", "exists", "true", "false", "box", "diamond"}
COMPARISONS = {"==", "!=", "<", "<=", ">", ">="}


def literal(text: str):
    """The value of a key's text; Malformed for anything but tuples, constants and Fraction(n, d).
    Lenient about commas: the node it makes must print back to exactly this text."""
    if not isinstance(text, str):
        raise Malformed(f"expected a key's text, got {type(text).__name__}")
    stack, pos = [[]], 0
    while pos < len(text):
        m = TOKEN.match(text, pos)
        if m is None or m.end() == pos:
            raise Malformed(f"unexpected {text[pos:pos + 30]!r} in a key's text")
        pos, (opened, closed, single, double, number, word, num, den) = m.end(), m.groups()
        if opened or closed:
            if closed and len(stack) < 2:
                raise Malformed("unbalanced parentheses in a key's text")
            stack.append([]) if opened else stack[-2].append(tuple(stack.pop()))
        elif m.lastindex is not None:
            stack[-1].append(single if single is not None else double if double is not None else
                             int(number) if number else WORDS[word] if word else Fraction(int(num), int(den)))
    if len(stack) != 1 or len(stack[0]) != 1:
        raise Malformed("a key's text must be one value")
    return stack[0][0]


def sort(text) -> Sort:
    if not isinstance(text, str) or not text:
        raise Malformed(f"bad sort {text!r}")
    if "→" in text:
        domain, rng = text.rsplit("→", 1)
        return Sort("Array", tuple(sort(d) for d in domain.split("×")), sort(rng))
    return {"Real": REAL, "Int": INT, "Bool": BOOL}.get(text) or Sort(text)


def node(key) -> Node:
    try:
        op, sort_text, payload, args = key
    except (TypeError, ValueError):
        raise Malformed(f"a node's key must be (op, sort, payload, args), got {key!r:.80}") from None
    if op not in OPS or not isinstance(args, tuple) or op == "cmp" and payload not in COMPARISONS:
        raise Malformed(f"bad node key {key!r:.80}")
    if op in ("forall", "exists"):
        payload = tuple(node(v) for v in payload)
    elif op in ("box", "diamond"):
        payload = program(payload)
    elif op == "const" and not isinstance(payload, Fraction):
        raise Malformed(f"a constant's value must be Fraction(n, d), got {payload!r}")
    n = Node(op, tuple(node(a) for a in args), sort(sort_text), payload)
    if n.sort != _wanted(n):  # one spelling: a node's sort is the one its constructor gives it
        raise Malformed(f"the node {key!r:.60} is not of sort {_wanted(n)}")
    return n


def _wanted(n: Node) -> Sort:
    if n.op in ("+", "*", "neg", "^"):
        return INT if all(a.sort == INT for a in n.args) else REAL
    if n.op in ("cmp", "and", "or", "not", "implies", "iff", "forall", "exists", "true", "false", "box",
                "diamond"):
        return BOOL
    if n.op in ("/", "const"):
        return n.sort if n.op == "const" and n.sort == INT else REAL
    return n.args[0].sort if n.op == "store" else n.sort


@functools.lru_cache(maxsize=65536)  # a weakening's instance terms recur in every leaf
def from_text(text: str, want_formula: bool = False) -> Node:
    """The node whose key's text this is, exactly (another text for the same node is malformed:
    a certificate holds one spelling of each thing, so any change to it is seen)."""
    n = formula(literal(text)) if want_formula else node(literal(text))
    if repr(n.key) != text:
        raise Malformed(f"the key text {text[:60]!r} is not in canonical form")
    return n


def formula(key) -> Node:
    n = node(key)
    if n.sort != BOOL:
        raise Malformed(f"expected a formula, got the term `{n}`")
    return n


def program(key) -> Program:
    if not isinstance(key, tuple) or not key or not isinstance(key[0], str):
        raise Malformed(f"bad program key {key!r:.80}")
    kind, rest = key[0], key[1:]
    try:
        if kind == "assign":
            return Assign(node(rest[0]), node(rest[1]))
        if kind == "havoc":
            return Havoc(node(rest[0]))
        if kind == "test":
            return Test(formula(rest[0]))
        if kind == "seq":
            return Seq(tuple(program(p) for p in rest[0]))
        if kind == "choice":
            return Choice(tuple(program(p) for p in rest[0]), tuple(str(label) for label in rest[1]))
        if kind == "loop":
            body, inv, label, each, count = rest
            return Loop(program(body), None if inv is None else formula(inv), label,
                        None if each is None else Each(*(node(k) for k in each)),
                        None if count is None else Count(*(node(k) for k in count)))
        if kind == "ode":
            eqs, domain, invariants = rest
            return ODE(tuple((node(v), node(f)) for v, f in eqs), formula(domain),
                       tuple(formula(i) for i in invariants))
    except (TypeError, ValueError, IndexError) as exc:
        if isinstance(exc, Malformed):
            raise
        raise Malformed(f"bad {kind} key ({exc})") from None
    raise Malformed(f"unknown program kind {kind!r}")


def theorem(canonical: str) -> Theorem:
    """The theorem whose canonical text this is, checked well-formed and printing back the same."""
    parts = literal(canonical)
    if not isinstance(parts, tuple) or len(parts) < 11 or parts[0] != THEOREM_FORMAT:
        raise Malformed(f"the theorem's text is not a {THEOREM_FORMAT} canonical text")
    _, name, expected, assumptions, prog, guarantee, abbrevs, constants, scenarios, unroll, once = parts[:11]
    extra = {}
    for item in parts[11:]:
        if not (isinstance(item, tuple) and len(item) == 2 and item[0] in
                ("well_defined", "defined_if", "witnesses", "ghosts", "roles")):
            raise Malformed(f"unknown part {item!r:.60} in the theorem's text")
        if item[0] == "roles":
            extra["roles"] = _roles(item[1])
            continue
        build = node if item[0] == "witnesses" else formula
        extra[item[0]] = tuple((str(w), build(f)) for w, f in item[1])
    try:
        t = Theorem(name=name, assumptions=formula(assumptions), program=program(prog),
                    guarantee=formula(guarantee), expected=expected,
                    abbreviations={str(k): node(v) for k, v in abbrevs},
                    constants=tuple(node(c) for c in constants),
                    scenarios=tuple(formula(s) for s in scenarios),
                    unroll=unroll[1], check_nonblocking=once[1], **extra)
    except (ModelError, TypeError, ValueError, IndexError) as exc:
        if isinstance(exc, Malformed):
            raise
        raise Malformed(f"the theorem's text does not make a theorem: {exc}") from None
    if t.canonical != canonical:
        raise Malformed("the theorem's text is not in canonical form (it does not print back the same)")
    return t


def _roles(value) -> Roles:
    """The roles part: (environment symbols' keys, control symbols' keys)."""
    if not (isinstance(value, tuple) and len(value) == 2 and all(isinstance(v, tuple) for v in value)):
        raise Malformed(f"bad roles part {value!r:.60}")
    return Roles(environment=tuple(node(k) for k in value[0]), controls=tuple(node(k) for k in value[1]))
