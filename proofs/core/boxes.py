"""Proving a nonlinear obligation over a box by exact interval arithmetic, without a solver.

z3's nonlinear procedure can spend tens of seconds on a quadratic claim in six variables
while its resource count barely moves ("the start ball lies inside the invariant", "the
invariant keeps out of the unsafe ball": KeYmaera X's Yang Wu Lin benchmarks). Such claims
are about a small region, where the region's bounds and a centred Taylor form decide at once.

Why it is sound. An obligation F is valid iff not-F has no model. not-F is put into
disjunctive normal form over its comparisons, every other subformula read as `true` (an
over-approximation: a case with fewer literals has more models). A case has no model when
its bound literals (`x >= c`, `x = c`, an axis-parallel ellipsoid `sum a_i (x_i - c_i)^2 <= s`
with every a_i > 0) put all its variables in a box, and every piece of a finite partition of
that box has a literal whose enclosure over the piece shows the literal false there. Terms
other than +, -, *, natural powers and division of a real by a nonzero constant are read as
independent variables (each has some value; the same term, the same value). All arithmetic is
exact (Fractions), and the partition is bounded by a count, so the answer never depends on
the clock.
"""

from __future__ import annotations

from fractions import Fraction
from math import comb

from certiloop.models.lang.terms import REAL, Node

MAX_CASES = 32  # disjunctive cases of not-F: more, and the formula is left to z3
MAX_TERMS = 600  # monomials of one literal's polynomial (expanded, or around a box's centre)
MAX_DEGREE = 24  # a literal of higher total degree is not used (nor higher powers expanded)
MAX_BOXES = 16  # pieces examined per case: the partition's deterministic budget
MAX_WORK = 2_000  # centred-form monomials computed per case (a quadratic in 6 variables: ~150 a piece)

Monomial = tuple[tuple[int, int], ...]  # (atom index, exponent), sorted by index
Poly = dict[Monomial, Fraction]
Box = dict[int, tuple[Fraction, Fraction]]
_FLIP = {">=": "<", ">": "<=", "<=": ">", "<": ">=", "==": "!=", "!=": "=="}


class _Unusable(Exception):
    """A literal this method cannot read (too large, or not a polynomial)."""


def proves(formula: Node) -> bool:
    """True only if the formula is valid by the box argument above; False says nothing."""
    try:
        if not _nonlinear(formula):
            return False  # linear arithmetic: z3 is complete and fast there
        cases = _dnf(formula, positive=False)
        if cases is None:
            return False
        atoms: dict[tuple, int] = {}
        return all(_case_empty(case, atoms) for case in cases)  # no case at all: not-F is false
    except RecursionError:
        return False


# --------------------------------------------------------------------------- reading not-F


def _nonlinear(n: Node) -> bool:
    if n.op == "*":
        return sum(1 for a in n.args if a.op != "const") >= 2 or any(map(_nonlinear, n.args))
    if n.op == "^":
        return isinstance(n.payload, int) and n.payload >= 2 or _nonlinear(n.args[0])
    return any(_nonlinear(a) for a in n.args if isinstance(a, Node))


def _dnf(n: Node, positive: bool) -> list[list[Node]] | None:
    """The cases (conjunctions of comparisons) of n, or of not-n; None when there are too many."""
    op = n.op
    if op == "not":
        return _dnf(n.args[0], not positive)
    if op == "implies":
        a, b = n.args
        return _either(_dnf(a, False), _dnf(b, True)) if positive else _both(_dnf(a, True), _dnf(b, False))
    if (op == "and") == positive and op in ("and", "or"):
        out: list[list[Node]] | None = [[]]
        for a in n.args:
            out = _both(out, _dnf(a, positive))
        return out
    if op in ("and", "or"):
        out = []
        for a in n.args:
            out = _either(out, _dnf(a, positive))
        return out
    if op in ("true", "false"):
        return [[]] if (op == "true") == positive else []
    if op == "cmp" and n.payload in _FLIP and n.args[0].sort.is_numeric and n.args[1].sort.is_numeric:
        return [[n if positive else Node("cmp", n.args, n.sort, _FLIP[n.payload])]]
    return [[]]  # anything else is read as `true`: an over-approximation


def _either(a, b):
    if a is None or b is None or len(a) + len(b) > MAX_CASES:
        return None
    return a + b


def _both(a, b):
    if a is None or b is None or len(a) * len(b) > MAX_CASES:
        return None
    return [x + y for x in a for y in b]


def _literal(atom: Node, atoms: dict[tuple, int]) -> tuple[Poly, str]:
    """`a op b` as (p, rel) with p = a - b or b - a and rel one of >=, >, ==, !=."""
    a, b = (_expand(x, atoms) for x in atom.args)
    op = atom.payload
    if op in ("<=", "<"):
        a, b, op = b, a, {"<=": ">=", "<": ">"}[op]
    p = dict(a)
    for m, c in b.items():
        _add(p, m, -c)
    if _degree(p) > MAX_DEGREE:
        raise _Unusable
    return p, op


def _expand(n: Node, atoms: dict[tuple, int]) -> Poly:
    op = n.op
    if op == "const":
        return {(): Fraction(n.payload)} if n.payload else {}
    if op == "+":
        out: Poly = {}
        for a in n.args:
            for m, c in _expand(a, atoms).items():
                _add(out, m, c)
        return out
    if op == "neg":
        return {m: -c for m, c in _expand(n.args[0], atoms).items()}
    if op == "*":
        out = {(): Fraction(1)}
        for a in n.args:
            out = _times(out, _expand(a, atoms))
        return out
    if op == "^" and isinstance(n.payload, int) and 0 <= n.payload <= MAX_DEGREE:
        base, out = _expand(n.args[0], atoms), {(): Fraction(1)}
        for _ in range(n.payload):
            out = _times(out, base)
        return out
    if op == "/" and n.sort == REAL and n.args[1].op == "const" and n.args[1].payload:
        return {m: c / Fraction(n.args[1].payload) for m, c in _expand(n.args[0], atoms).items()}
    index = atoms.setdefault(n.key, len(atoms))  # a variable, or any other term read as one
    return {((index, 1),): Fraction(1)}


def _add(p: Poly, m: Monomial, c: Fraction) -> None:
    total = p.get(m, 0) + c
    if total:
        p[m] = total
        if len(p) > MAX_TERMS:
            raise _Unusable
    else:
        p.pop(m, None)


def _times(p: Poly, q: Poly) -> Poly:
    if len(p) * len(q) > MAX_TERMS * 8:
        raise _Unusable
    out: Poly = {}
    for m1, c1 in p.items():
        for m2, c2 in q.items():
            merged = dict(m1)
            for v, k in m2:
                merged[v] = merged.get(v, 0) + k
            _add(out, tuple(sorted(merged.items())), c1 * c2)
    return out


# --------------------------------------------------------------------------- one case


def _case_empty(case: list[Node], atoms: dict[tuple, int]) -> bool:
    """Whether the conjunction of the case's comparisons has no model. Only literals that
    can bound variables are expanded first; the others only once all their variables are
    bounded (most obligations stop here, cheaply)."""
    shaped = [a for a in case if _bound_shaped(a)]
    shaped_literals = _read(shaped, atoms)
    box = _bounds(shaped_literals)
    if box is None:
        return True  # the bound literals alone contradict each other
    if not box:
        return False
    ids = {id(a) for a in shaped}
    rest = [a for a in case if id(a) not in ids and all(atoms.get(k) in box for k in _unknowns(a))]
    usable = [(p, rel) for p, rel in _read(rest, atoms) + [x for x in shaped_literals if _degree(x[0]) > 1]
              if all(v in box for m in p for v, _ in m)]
    if all(_degree(p) <= 1 for p, _ in usable):
        return False  # linear over a box: z3 decides it at once, and no bound is curved
    pieces, examined, work = [box], 0, [0]
    while pieces:
        piece = pieces.pop()
        examined += 1
        if examined > MAX_BOXES or work[0] > MAX_WORK:
            return False
        try:
            if any(_false_on(p, rel, piece, work) for p, rel in usable):
                continue
        except _Unusable:
            return False
        split = _widest(piece, usable)
        if split is None:
            return False  # a point no literal excludes
        v, (lo, hi) = split, piece[split]
        mid = (lo + hi) / 2
        pieces.extend(({**piece, v: (mid, hi)}, {**piece, v: (lo, mid)}))
    return True


def _degree(p: Poly) -> int:
    return max((sum(k for _, k in m) for m in p), default=0)


def _bound_shaped(atom: Node) -> bool:
    """A comparison of one unknown (a variable, or a term read as one), or of a sum of
    one-unknown terms with a constant."""
    if len(_unknowns(atom)) <= 1:
        return True
    for side, other in (atom.args, atom.args[::-1]):
        if side.op == "+" and not _unknowns(other) and all(len(_unknowns(t)) <= 1 for t in side.args):
            return True
    return False


def _unknowns(n: Node, out: set | None = None) -> set:
    """The keys of the terms _expand reads as variables, without expanding anything."""
    out = set() if out is None else out
    op = n.op
    if op == "const":
        return out
    power = op == "^" and isinstance(n.payload, int) and 0 <= n.payload <= MAX_DEGREE
    if op in ("+", "*", "neg", "cmp") or power:
        for a in n.args:
            _unknowns(a, out)
    elif op == "/" and n.sort == REAL and n.args[1].op == "const" and n.args[1].payload:
        _unknowns(n.args[0], out)
    else:
        out.add(n.key)
    return out


def _read(case: list[Node], atoms: dict[tuple, int]) -> list[tuple[Poly, str]]:
    out = []
    for atom in case:
        try:
            out.append(_literal(atom, atoms))
        except (_Unusable, RecursionError, ZeroDivisionError):
            continue  # dropped: the case gets more models, never fewer
    return out


def _bounds(literals: list[tuple[Poly, str]]) -> Box | None:
    """The box the bound literals give (None: empty); variables they do not bound are absent."""
    box: Box = {}

    def narrow(v: int, lo: Fraction | None, hi: Fraction | None) -> bool:
        old_lo, old_hi = box.get(v, (None, None))
        lo = lo if old_lo is None else old_lo if lo is None else max(lo, old_lo)
        hi = hi if old_hi is None else old_hi if hi is None else min(hi, old_hi)
        box[v] = (lo, hi)
        return lo is None or hi is None or lo <= hi

    for p, rel in literals:
        if rel == "!=":
            continue
        for q in ([p] if rel != "==" else [p, _negated(p)]):  # p = 0 gives p >= 0 and -p >= 0
            for v, lo, hi in _literal_bounds(q):
                if lo is not None and hi is not None and lo > hi:
                    return None
                if not narrow(v, lo, hi):
                    return None
    return {v: (lo, hi) for v, (lo, hi) in box.items() if lo is not None and hi is not None}


def _negated(p: Poly) -> Poly:
    return {m: -c for m, c in p.items()}


def _literal_bounds(p: Poly):
    """Bounds (v, lo, hi) that `p >= 0` implies: p linear in one variable, or p of the form
    `s - sum a_i (x_i - c_i)^(n_i)` with every a_i > 0 and n_i even (a ball, an axis-parallel
    ellipsoid, `(x-9)^2 + (y-20)^20 <= 4`): then each |x_i - c_i| <= (s/a_i)^(1/n_i).
    A pair lo > hi says p >= 0 has no solution at all."""
    k = p.get((), Fraction(0))
    rest = {m: c for m, c in p.items() if m}
    if len(rest) == 1:
        ((m, a),) = rest.items()
        if len(m) == 1 and m[0][1] == 1:
            v, root = m[0][0], -k / a
            return [(v, root, None) if a > 0 else (v, None, root)]
    parts: dict[int, dict[int, Fraction]] = {}  # variable -> exponent -> coefficient in -p
    for m, c in rest.items():
        if len(m) != 1:
            return []
        ((v, e),) = m
        parts.setdefault(v, {})[e] = -c
    shapes, s = {}, k
    for v, f in parts.items():
        n = max(f)
        a = f[n]
        if n % 2 or a <= 0:
            return []
        c = -f.get(n - 1, Fraction(0)) / (n * a)
        if any(f.get(j, 0) != a * comb(n, j) * (-c) ** (n - j) for j in range(1, n + 1)):
            return []  # not a*(x - c)^n once its constant a*c^n is moved to s
        shapes[v] = (a, c, n)
        s += a * c**n
    if not shapes:
        return []
    if s < 0:
        return [(next(iter(shapes)), Fraction(1), Fraction(0))]  # no solution
    out = []
    for v, (a, c, n) in shapes.items():
        r = _root_up(s / a, n)
        out.append((v, c - r, c + r))
    return out


def _root_up(q: Fraction, n: int) -> Fraction:
    """A rational upper bound of q^(1/n) (q >= 0), within 2^-40 relative to q's scale; the
    root itself when it is a rational with such a denominator."""
    scale = 1 << 40
    m = q.numerator * q.denominator ** (n - 1) * scale**n
    r = _iroot(m, n)
    return Fraction(r if r**n == m else r + 1, q.denominator * scale)  # exact when the root is


def _iroot(m: int, n: int) -> int:
    """The largest r with r^n <= m (Newton's method from above, then checked)."""
    if m < 2:
        return m
    x = 1 << -(-m.bit_length() // n)
    while True:
        y = ((n - 1) * x + m // x ** (n - 1)) // n
        if y >= x:
            break
        x = y
    while x**n > m:
        x -= 1
    while (x + 1) ** n <= m:
        x += 1
    return x


def _widest(piece: Box, usable) -> int | None:
    seen = {v for p, _ in usable for m in p for v, _ in m}
    best, width = None, Fraction(0)
    for v in sorted(seen):
        lo, hi = piece[v]
        if hi - lo > width:
            best, width = v, hi - lo
    return best


def _false_on(p: Poly, rel: str, piece: Box, work: list[int]) -> bool:
    lo, hi = _enclosure(p, piece, work)
    if rel == ">=":
        return hi < 0
    if rel == ">":
        return hi <= 0
    if rel == "==":
        return lo > 0 or hi < 0
    return lo == hi == 0  # "!=": p is 0 on the whole piece


def _enclosure(p: Poly, piece: Box, work: list[int]) -> tuple[Fraction, Fraction]:
    """[lo, hi] containing p over the piece: p re-expanded around the piece's centre
    (x = c + d, |d| <= r), each monomial in d bounded by its coefficient times r's powers."""
    centred: Poly = {}
    for m, c in p.items():
        term: Poly = {(): c}
        for v, k in m:
            lo, hi = piece[v]
            mid, r = (lo + hi) / 2, (hi - lo) / 2
            binomial: Poly = {}
            for j in range(k + 1):
                coeff = comb(k, j) * mid ** (k - j)
                if coeff and (j == 0 or r):
                    binomial[((v, j),) if j else ()] = Fraction(coeff)
            term = _times(term, binomial)
        work[0] += len(term)
        for mono, coeff in term.items():
            _add(centred, mono, coeff)
    lo = hi = centred.pop((), Fraction(0))
    for m, c in centred.items():
        size = abs(c)
        even = True
        for v, j in m:
            a, b = piece[v]
            size *= ((b - a) / 2) ** j
            even = even and j % 2 == 0
        if even:
            lo, hi = (lo, hi + size) if c > 0 else (lo - size, hi)
        else:
            lo, hi = lo - size, hi + size
    return lo, hi
