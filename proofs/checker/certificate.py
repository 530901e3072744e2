"""Certificate format v1 (README.md): read one, re-derive its proof, compare, re-decide.

Checks, in order (the first failure is reported): the format; the theorem's text (a canonical
theorem, its hash); the fragment (what the checker covers); the rule at every program node
and its hints; the obligations re-derived from the theorem with those hints; the proof tree
and the leaves, each exactly (id, path, SMT-LIB text) the obligation the checker derived
there; each leaf decided `unsat` by z3 under a deterministic resource limit.
"""

from __future__ import annotations

import hashlib
import multiprocessing
import re
from dataclasses import dataclass
from multiprocessing.connection import wait

try:
    import z3
except ImportError as exc:  # the command's one-line error, as for the prover
    raise ImportError("z3 is not installed: pip install z3-solver") from exc

from certiloop.models.lang.programs import ODE, Assign, Choice, Havoc, Loop, Program, Seq, Test
from certiloop.models.lang.terms import Node
from certiloop.models.lang.theorem import Theorem
from certiloop.proofs.arith.smtlib import script
from certiloop.proofs.checker import keys
from certiloop.proofs.checker.cases import case_formulas
from certiloop.proofs.checker.derive import FLOW_TIME, Derivation, Leaf, Rejected
from certiloop.proofs.checker.keys import Malformed
from certiloop.proofs.checker.keys import fields as _fields
from certiloop.proofs.checker.ode_facts import NotCheckable
from certiloop.proofs.checker.weakening import weakened

FORMAT = "certiloop-certificate/1"
FORMAT_V2 = "certiloop-certificate/2"  # v1 and leaves proved through a weakening (weakening.py)
DECIDED = "z3 unsat"  # the one decision procedure of format v1
WEAKENED = "z3 unsat of a weakening"  # v2: z3 on the leaf's recorded weakening, checked to imply it
CASES = "z3 unsat by cases"  # v2: z3 on each case the checker builds from the leaf (cases.py)
RLIMIT = 20_000_000  # z3's resource limit per leaf: a count of its steps, not a clock
# z3 does not count every step of its quantifier engine: a net against a leaf it never leaves.
# Reaching it only rejects (never accepts), and no leaf of an accepted library model comes near.
WALL_NET_MS = 60_000
# z3 does not always honour its own timeout either: the leaves are decided in a child process,
# killed when a leaf takes this long (the net's own answer arrives first when z3 honours it)
KILL_AFTER_S = 75
ODE_METHODS = ("dI", "dbx", "barrier", "progress", "nonzero")
TOP = {"format", "theorem", "rules", "tree", "leaves"}


@dataclass(frozen=True)
class Outcome:
    status: str  # accepted | rejected | malformed
    message: str
    leaves: tuple[tuple[str, str], ...] = ()  # (id, SMT-LIB text) decided, when it got that far

    @property
    def exit_code(self) -> int:
        return {"accepted": 0, "rejected": 1, "malformed": 2}[self.status]


def check(doc: object, rlimit: int = RLIMIT) -> Outcome:
    """Accept, reject (naming the first failing step) or call malformed one certificate."""
    derived: list[Leaf] = []
    try:
        theorem, odes = _read(doc)
        derived = Derivation(theorem, odes).run()
        texts = judge_all(doc, derived, rlimit)
    except Malformed as exc:
        return Outcome("malformed", f"malformed certificate: {exc}")
    except NotCheckable as exc:
        text = str(exc) if "not checkable yet" in str(exc) else f"{exc}: not checkable yet"
        return Outcome("rejected", f"rejected: {text}")
    except Rejected as exc:
        return Outcome("rejected", f"rejected: {exc}", _texts(derived))
    except (ValueError, TypeError, KeyError, AttributeError, RecursionError, AssertionError) as exc:
        # never an acceptance
        return Outcome("rejected", f"rejected: the checker could not follow the certificate ({exc!r:.200})")
    name, digest = doc["theorem"]["name"], doc["theorem"]["hash"]
    # the safety claim, as `prove` reports it; a theorem's non-blocking check is a separate proof
    besides = "; its non-blocking check is not in the certificate" * theorem.check_nonblocking
    return Outcome("accepted", f"accepted: {name} ({digest}): assumptions -> [program] guarantee, "
                   f"{len(derived)} leaves{besides}",
                   tuple((f"{leaf.id}.{k}" if len(decided) > 1 else leaf.id, text)
                         for leaf, decided in zip(derived, texts) for k, text in enumerate(decided, 1)))


def _texts(leaves: list[Leaf]) -> tuple[tuple[str, str], ...]:
    return tuple((leaf.id, script(leaf.formula)) for leaf in leaves)


WORKERS = 2  # forked children comparing and deciding the leaves, each every WORKERS-th one
FAILURES = {"Rejected": Rejected, "NotCheckable": NotCheckable, "Malformed": Malformed}


def judge_all(doc: dict, derived: list[Leaf], rlimit: int) -> list[tuple[str, ...]]:
    """The texts decided for each leaf (_leaf_text), each decided unsat by z3 in forked children
    (a z3 that ignores its limits is killed); the first failing leaf's failure is raised here."""
    _tree(doc, derived)
    context, pipes, children = multiprocessing.get_context("fork"), [], []
    for k in range(WORKERS):
        mine, theirs = context.Pipe(duplex=False)
        share = range(k, len(derived), WORKERS)
        children.append(context.Process(target=_judge_each, args=(doc, derived, share, rlimit, theirs),
                                        daemon=True))
        children[-1].start()
        theirs.close()
        pipes.append(mine)
    texts: dict[int, tuple[str, ...]] = {}
    failures: list[tuple[int, str, str]] = []
    try:
        while pipes:
            ready = wait(pipes, KILL_AFTER_S)
            if not ready:  # the next leaf of each child still deciding
                i = min(set(range(len(derived))) - set(texts) - {f[0] for f in failures}, default=0)
                failures.append((i, "Rejected", f"{_where(derived[i])}: no answer in {KILL_AFTER_S} s"))
                break
            for pipe in ready:
                try:
                    i, kind, value = pipe.recv()
                except EOFError:  # its share is done, or it died (a missing leaf is caught below)
                    pipes.remove(pipe)
                    continue
                if kind == "ok":
                    texts[i] = value
                else:
                    failures.append((i, kind, value))
                    pipes.remove(pipe)
    finally:
        for child in children:
            child.kill()
            child.join()
    failed = {f[0]: f for f in failures}
    for i in range(len(derived)):  # in leaf order: the first leaf not decided unsat
        if i in failed:
            raise FAILURES.get(failed[i][1], ValueError)(failed[i][2])
        if i not in texts:
            raise Rejected(f"{_where(derived[i])}: the process deciding it ended without an answer")
    return [texts[i] for i in range(len(derived))]


def _judge_each(doc: dict, derived: list[Leaf], share: range, rlimit: int, out) -> None:
    for i in share:
        try:
            texts = _leaf_text(doc, derived[i], i)
            for k, text in enumerate(texts, 1):
                if (why := decide(text, rlimit)) is not None:
                    case = f" (case {k} of {len(texts)})" if len(texts) > 1 else ""
                    raise Rejected(f"{_where(derived[i])}{case}: {why}")
            out.send((i, "ok", texts))
        except Exception as exc:  # noqa: BLE001 - sent as it is: the parent rejects, never accepts
            out.send((i, type(exc).__name__, str(exc) if type(exc).__name__ in FAILURES else repr(exc)))
            return


def decide(smtlib: str, rlimit: int) -> str | None:
    """None when z3 finds the script's assertions (the negated leaf) unsatisfiable."""
    logic = re.search(r"^\(set-logic (\w+)\)", smtlib, re.M)
    # the script's own logic picks z3's solver for it (QF_NRA: nlsat, complete for real arithmetic)
    solver = z3.SolverFor(logic.group(1)) if logic and logic.group(1) == "QF_NRA" else z3.Solver()
    solver.set("rlimit", rlimit)
    solver.set("timeout", WALL_NET_MS)
    try:
        solver.from_string(smtlib)
    except z3.Z3Exception as exc:
        return f"z3 cannot read it ({exc})"
    answer = solver.check()
    if answer == z3.unsat:
        return None
    why = f" (rlimit {rlimit:,}: {solver.reason_unknown()})" if answer == z3.unknown else ""
    return f"z3 says {answer}, not unsat{why}"


# --------------------------------------------------------------------------- reading


def _read(doc: object) -> tuple[Theorem, dict[str, tuple[str, object]]]:
    doc = _fields(doc, TOP, "the certificate")
    if doc["format"] not in (FORMAT, FORMAT_V2):
        raise Malformed(f"format {doc['format']!r} is not {FORMAT!r} or {FORMAT_V2!r}")
    head = _fields(doc["theorem"], {"name", "hash", "canonical"}, "theorem")
    theorem = keys.theorem(head["canonical"])
    if theorem.name != head["name"]:
        raise Rejected(f"theorem: the name {head['name']!r} is not the text's {theorem.name!r}")
    if hashlib.sha256(head["canonical"].encode()).hexdigest()[:16] != head["hash"]:
        raise Rejected("theorem: the hash is not the hash of its text")
    _in_fragment(theorem)
    if not isinstance(doc["rules"], list):
        raise Malformed("rules must be a list")
    return theorem, _rules(theorem.program, doc["rules"])


def _in_fragment(t: Theorem) -> None:
    for what, present in (("witness", t.witnesses), ("well-defined", t.well_defined),
                          ("defined-if", t.defined_if)):
        if present:
            raise NotCheckable(f"rule {what} not checkable yet")
    for n in _formulas(t):
        if bad := _outside(n):
            raise NotCheckable(f"rule {bad} not checkable yet (in `{n}`)")


def _formulas(t: Theorem) -> list[Node]:
    out = [t.assumptions, t.guarantee]

    def walk(p: Program) -> None:
        if isinstance(p, Assign):
            out.extend((p.target, p.value))
        elif isinstance(p, Havoc):
            out.append(p.target)
        elif isinstance(p, Test):
            out.append(p.cond)
        elif isinstance(p, Loop) and p.invariant is not None:
            out.append(p.invariant)
        elif isinstance(p, ODE):
            out.extend((p.domain, *(f for _, f in p.eqs), *p.invariants))
        for q in p.parts if isinstance(p, Seq) else p.alternatives if isinstance(p, Choice) else \
                (p.body,) if isinstance(p, Loop) else ():
            walk(q)

    walk(t.program)
    return out


def _outside(n: Node) -> str | None:
    """The name of a construct the checker does not cover, if n holds one."""
    if n.op in ("box", "diamond"):
        return "modality in a formula"
    if n.op == "ite":
        return "if-then-else term"
    return next((bad for a in n.args if (bad := _outside(a))), None)


def _rules(p: Program, entries: list) -> dict[str, tuple[str, object]]:
    """The ODE rules by program address, after checking that entry i names the rule at the
    i-th program node (pre-order) and its hints."""
    odes: dict[str, tuple[str, object]] = {}
    nodes = _nodes(p, "0")
    if len(entries) != len(nodes):
        raise Rejected(f"rules: {len(entries)} entries for a program of {len(nodes)} nodes")
    for entry, (at, q) in zip(entries, nodes):
        if not isinstance(entry, dict) or "at" not in entry or "rule" not in entry:
            raise Malformed(f"rules: each entry needs `at` and `rule`, got {entry!r:.80}")
        if entry["at"] != at:
            raise Rejected(f"rules: entry at {entry['at']!r} where the program's node {at} comes")
        kind = type(q).__name__.lower()
        if isinstance(q, ODE):
            odes[at] = _ode_rule(entry, q, at)
        elif isinstance(q, Loop):
            _fields(entry, {"at", "rule", "invariant"}, f"rule at {at}")
            shown = None if q.invariant is None else repr(q.invariant.key)
            if entry["rule"] != "loop" or entry["invariant"] != shown:
                raise Rejected(f"rules: at {at} the rule is loop with the program's invariant")
        elif _fields(entry, {"at", "rule"}, f"rule at {at}")["rule"] != kind:
            raise Rejected(f"rules: at {at} the rule is {kind}, not {entry['rule']!r}")
    return odes


def _nodes(p: Program, at: str) -> list[tuple[str, Program]]:
    subs = p.parts if isinstance(p, Seq) else p.alternatives if isinstance(p, Choice) else \
        (p.body,) if isinstance(p, Loop) else ()
    return [(at, p)] + [x for n, q in enumerate(subs) for x in _nodes(q, f"{at}.{n}")]


def _ode_rule(entry: dict, ode: ODE, at: str) -> tuple[str, object]:
    rule = entry["rule"]
    if rule == "dW":
        _fields(entry, {"at", "rule"}, f"rule at {at}")
        return "dW", None
    if rule == "solve":
        solution = _fields(entry, {"at", "rule", "solution"}, f"rule at {at}")["solution"]
        if not isinstance(solution, dict):
            raise Malformed(f"rule at {at}: the solution must map each variable to a term's key")
        terms = {str(v): keys.from_text(text) for v, text in solution.items()}
        if any(t.sort.name not in ("Real", "Int") or _outside(t) for t in terms.values()):
            raise Rejected(f"rules: at {at} the solution holds something other than a polynomial term")
        return "solve", terms
    if rule == "dC":
        chain = _fields(entry, {"at", "rule", "chain"}, f"rule at {at}")["chain"]
        if not isinstance(chain, list):
            raise Malformed(f"rule at {at}: the chain must be a list")
        links = []
        for link in chain:
            link = _fields(link, {"atom", "method", "cofactor"}, f"a link at {at}")
            atom = keys.from_text(link["atom"], want_formula=True)
            cofactor = None if link["cofactor"] is None else keys.from_text(link["cofactor"])
            if link["method"] not in ODE_METHODS:
                raise NotCheckable(f"rule {link['method']!r} not checkable yet")
            if bad := _outside(atom) or (cofactor is not None and _outside(cofactor)):
                raise NotCheckable(f"rule {bad} not checkable yet (in the chain at {at})")
            links.append((atom, link["method"], cofactor))
        return "dC", tuple(links)
    raise NotCheckable(f"rule ODE {rule!r} not checkable yet")


# --------------------------------------------------------------------------- comparing


def tree(paths: list[tuple[str, str]]) -> dict:
    """The proof tree of (leaf id, path) pairs: each step label a node, in order of first use."""
    root: dict = {"step": "proof", "children": []}
    for leaf, path in paths:
        *steps, last = path.split(" / ")
        node = root
        for step in steps:
            found = [c for c in node["children"] if c["step"] == step and "children" in c]
            if not found:
                found = [{"step": step, "children": []}]
                node["children"].append(found[0])
            node = found[0]
        node["children"].append({"step": last, "leaf": leaf})
    return root


def _where(leaf: Leaf) -> str:
    return f"leaf {leaf.id} ({' / '.join(leaf.path)})"


def _tree(doc: dict, derived: list[Leaf]) -> None:
    """The recorded tree and leaf count are those of the derived proof."""
    if not isinstance(doc["leaves"], list):
        raise Malformed("leaves must be a list")
    mine = [(leaf.id, " / ".join(leaf.path)) for leaf in derived]
    if doc["tree"] != tree(mine):
        raise Rejected(f"tree: not the proof tree of the theorem with these rules ({len(mine)} leaves)")
    if len(doc["leaves"]) != len(derived):
        raise Rejected(f"leaves: {len(doc['leaves'])} recorded, the proof has {len(derived)}")


def _leaf_text(doc: dict, leaf: Leaf, i: int) -> tuple[str, ...]:
    """The SMT-LIB texts to decide for the i-th leaf: its own, its checked weakening's, or
    its cases' (v2)."""
    v2 = doc["format"] == FORMAT_V2
    got = _fields(doc["leaves"][i], {"id", "path", "smtlib", "decided", *["weakening"] * v2}, "a leaf")
    where = _where(leaf)
    if got["id"] != leaf.id or got["path"] != " / ".join(leaf.path):
        raise Rejected(f"{where}: recorded as {got['id']!r} at {got['path']!r}")
    if got["smtlib"] != script(leaf.formula):
        raise Rejected(f"{where}: the recorded formula is not the one this step produces")
    weak = got.get("weakening")
    if got["decided"] == CASES and v2 and weak is None:
        if (cases := case_formulas(leaf.formula)) is None:
            raise Rejected(f"{where}: decided by cases, but it has no guard to split on")
        return tuple(script(case) for case in cases)
    if got["decided"] != (DECIDED if weak is None else WEAKENED):
        raise NotCheckable(f"decision {got['decided']!r} not checkable yet")
    if weak is not None:
        weakened(leaf.formula, weak, where)  # checked to imply the leaf, its text compared
    return (got["smtlib"] if weak is None else weak["smtlib"],)


__all__ = ["FLOW_TIME", "Outcome", "check", "decide", "tree"]
