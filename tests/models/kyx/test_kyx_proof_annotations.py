"""`certiloop export --kyx --with-proof` (api/proof_annotations.py): the archive carries the
proof's loop invariants and differential-cut chains as `@invariant` annotations.

Checked three ways: the archive read back by certiloop's own .kyx reader proves each entry
(`certiloop prove FILE.kyx`); the annotations read back are the formulas of the proof's
certificate (both parsed, compared as nodes); and, independently of any prover, the exported
loop invariants are kept by the loop body on sampled states (the exact interpreter) and the
exported cuts hold along flows scipy integrates from sampled states. Each witness is shown to
have teeth: a formula that is not invariant fails it. KeYmaera X itself is not run here."""

from __future__ import annotations

import json
import os
import random
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from certiloop.api import load, prove
from certiloop.api.proof_annotations import annotate
from certiloop.falsify.choosers import RandomChooser
from certiloop.falsify.evaluate import Blocked, Compiler
from certiloop.falsify.interpreter import Interpreter
from certiloop.falsify.store import Rejected
from certiloop.models import library
from certiloop.models.kyx import NotExpressible, read_entries, write_archive
from certiloop.models.lang.programs import ODE, Choice, Loop, Program, Seq, ode, written
from certiloop.models.lang.terms import And, Node, Not, Or, Reals, free_vars
from certiloop.models.lang.theorem import Theorem
from certiloop.proofs.checker.keys import from_text
from certiloop.proofs.engine.certificate_writer import certificate

# Models without annotations of their own: whatever the archive carries, the proof found.
# GROWS: x' = 1 + y^2 only grows x, y' = -y keeps y's sign (a Darboux cut), so x > -1 and y > 0.
# LOOPED: the same flow in a loop with no invariant (the proof uses the guarantee).
MODELS = '''
from certiloop.models import And, Not, Or, Reals, Theorem, assign, choice, loop, ode, seq
x, y = Reals("x y")
GROWS = Theorem("grows", And(x == 0, y == 1), ode({x: 1 + y**2, y: -y}), Not(Or(x <= -1, y <= 0)))
LOOPED = Theorem("looped", And(x >= 0, y > 0),
                 loop(seq(choice(assign(y, y + 1), assign(x, x + y)), ode({x: 1 + y**2, y: -y}))),
                 And(x >= 0, y > 0))
'''


def _inexpressible(t: Theorem) -> bool:
    try:
        write_archive([t])
    except NotExpressible:
        return True
    return False


def run(*args):
    proc = subprocess.run([sys.executable, "-m", "certiloop.cli", *args], capture_output=True,
                          text=True, timeout=300, env={**os.environ, "COLUMNS": "200"})
    return proc.returncode, proc.stdout, proc.stderr


@pytest.fixture(scope="module")
def models(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("models") / "unannotated.py"
    path.write_text(MODELS)
    return path


@pytest.fixture(scope="module")
def exported(models, tmp_path_factory) -> dict:
    """The archive `export --with-proof` writes for these models, read back, by entry name."""
    target = tmp_path_factory.mktemp("kyx") / "proved.kyx"
    specs = [f"{models}:GROWS", f"{models}:LOOPED", "textbook.bouncing_ball", "textbook.train",
             "textbook.water_tank"]
    code, _, err = run("export", "--kyx", "--with-proof", *specs, "--jobs", "1", "-o", str(target))
    assert code == 0, err
    return {"path": target, "text": target.read_text(),
            "entries": {e.name: e for e in read_entries(target.read_text(), str(target))}}


def nodes(p: Program, at: str = "0"):
    """(address, node) in pre-order, addressed as the certificate addresses them."""
    yield at, p
    subs = p.parts if isinstance(p, Seq) else p.alternatives if isinstance(p, Choice) else \
        (p.body,) if isinstance(p, Loop) else ()
    for n, q in enumerate(subs):
        yield from nodes(q, f"{at}.{n}")


def proof_of(theorem: Theorem) -> dict:
    """The certificate of the theorem's proof, as `prove --certificate` writes it."""
    result = prove(theorem)
    assert result.verdict == "proved", result.reason
    return json.loads(json.dumps(certificate(*result.proof, result.obligations)))


def certified(theorem: Theorem, doc: dict) -> dict:
    """address -> the formulas the proof's certificate records there (parsed by the checker's
    reader): a loop's invariant (the guarantee where it records none), an ODE's cut chain."""
    out = {}
    for rule in doc["rules"]:
        if rule["rule"] == "loop":
            inv = rule["invariant"]
            out[rule["at"]] = [theorem.guarantee if inv is None else from_text(inv, want_formula=True)]
        elif rule["rule"] == "dC":
            out[rule["at"]] = [from_text(link["atom"], want_formula=True) for link in rule["chain"]]
        elif rule["rule"] in ("solve", "dW"):
            out[rule["at"]] = []
    return out


def same(a: dict, b: dict) -> bool:
    """The same formulas at the same addresses, node for node."""
    def keyed(d: dict) -> dict:
        return {at: [f.key for f in fs] for at, fs in d.items()}
    return keyed(a) == keyed(b)


def annotations(theorem: Theorem) -> dict:
    out = {}
    for at, p in nodes(theorem.program):
        if isinstance(p, Loop):
            out[at] = [] if p.invariant is None else [p.invariant]
        elif isinstance(p, ODE):
            out[at] = list(p.invariants)
    return out


# --------------------------------------------------------------------------- round trip


def test_the_archive_read_back_proves_every_entry(exported):
    code, out, err = run("prove", str(exported["path"]), "--jobs", "1")
    assert code == 0, out + err
    assert len(exported["entries"]) == 5 and all(e.error is None for e in exported["entries"].values())


def test_the_annotations_read_back_are_the_certificates_formulas(exported, models):
    own = {"grows": f"{models}:GROWS", "looped": f"{models}:LOOPED"}
    for name, entry in exported["entries"].items():
        model = load(own.get(name, name))
        assert same(annotations(entry.theorem), certified(model, proof_of(model))), name
        # and they carry the proof alone: proving the entry read back uses them as they stand
        assert same(certified(entry.theorem, proof_of(entry.theorem)), annotations(entry.theorem)), name
    # the proof found the cuts of the unannotated flow: Darboux for y, and the guarantee's x > -1
    (ode,) = [p for _, p in nodes(exported["entries"]["grows"].theorem.program) if isinstance(p, ODE)]
    assert {str(c) for c in ode.invariants} >= {"y > 0", "x > -1"}


def test_what_has_no_annotation_is_said_in_the_metadata(exported):
    metas = [json.loads(m) for m in re.findall(r"/\*@certiloop (\{.*?\})\s*\*/", exported["text"])]
    notes = {name: m["proof"]["not_annotated"] for name, m in zip(exported["entries"], metas)}
    assert any("the cut y > 0 was proved by dbx with cofactor -1" in n for n in notes["grows"])
    assert any("proved by its solution" in n for n in notes["textbook.train"])
    # KeYmaera X's syntax: the loop's invariant after `}*`, the cut chain after the ODE's `}`
    text = exported["text"]
    assert re.search(r"\}\*@invariant\(", text) and re.search(r"-y\}@invariant\(", text)


@pytest.mark.slow
def test_every_library_proof_exports_and_proves_again():
    """Each library model expected proved that .kyx can express (integers and arrays it cannot)."""
    done = []
    for name in library.names():
        model = library.get(name)
        if model.expected != "proved" or _inexpressible(model):
            continue
        doc = proof_of(model)
        got = annotate(model, doc)
        (entry,) = read_entries(write_archive([got.theorem], [got.notes]), f"{name}.kyx")
        assert same(annotations(entry.theorem), certified(model, doc)), name
        assert same(certified(entry.theorem, proof_of(entry.theorem)), annotations(entry.theorem)), name
        done.append(name)
    assert len(done) >= 30 and "textbook.bouncing_ball" in done and "sbs.ctrl1" in done


def test_a_model_not_proved_stops_the_export_with_one_line(tmp_path):
    target = tmp_path / "none.kyx"
    code, out, err = run("export", "--kyx", "--with-proof", "textbook.train", "textbook.train_no_lookahead",
                         "--jobs", "1", "-o", str(target))
    assert code == 1 and not target.exists() and out == ""
    (line,) = err.strip().splitlines()
    assert "textbook.train_no_lookahead is not proved (refuted" in line and "--with-proof" in line


def test_the_proofs_chain_replaces_a_shorter_one_of_the_author():
    # y > 0 alone does not give x > -1: the proof adds the guarantee's atom to the chain
    x, y = Reals("x y")
    hinted = Theorem("hinted", And(x == 0, y == 1), ode({x: 1 + y**2, y: -y}, invariants=[y > 0]),
                     Not(Or(x <= -1, y <= 0)))
    result = prove(hinted)
    got = annotate(hinted, certificate(*result.proof, result.obligations))
    (flow,) = [p for _, p in nodes(got.theorem.program)]
    assert [str(c) for c in flow.invariants] == ["y > 0", "x > -1"]
    assert got.notes == ("the ODE {x' = 1 + y^2, y' = -y}: the cut y > 0 was proved by dbx with cofactor -1",)


SPRING = """ArchiveEntry "spring, overdamped"
  Definitions Real k; Real c; End.
  ProgramVariables Real x; Real y; End.
  Problem x = 0 & k > 0 & c > 0 & c^2 > 4*k
    -> [ { x := *; ?x > 0; y := 0; {x' = y, y' = -k*x - c*y} }* ] x >= 0
  End.
End."""


def test_cuts_through_the_proofs_own_ghost_are_left_out_and_said():
    # the overdamped spring is proved with an eigenvalue ghost `eig` (proofs/engine/eigen.py)
    (entry,) = read_entries(SPRING)
    result = prove(entry.theorem)
    got = annotate(entry.theorem, certificate(*result.proof, result.obligations))
    (flow,) = [p for _, p in nodes(got.theorem.program) if isinstance(p, ODE)]
    assert flow.invariants and all("eig" not in free_vars(c) for c in flow.invariants)
    assert any(n.startswith("the proof's ghost `eig`") for n in got.notes)
    assert any("uses the proof's own symbols and is left out" in n for n in got.notes)
    (again,) = read_entries(write_archive([got.theorem], [got.notes]))
    assert prove(again.theorem).verdict == "proved"  # certiloop finds the ghost again


# --------------------------------------------------------------------------- independent witnesses


def conjuncts(f: Node) -> list[Node]:
    return [g for a in f.args for g in conjuncts(a)] if f.op == "and" else [f]


class Durations(RandomChooser):
    """Random decisions, and flows of a random duration in [0, 1] (exact replay asks for the
    duration outright; one that leaves the domain blocks the run)."""

    def duration(self, longest):
        return self.rng.uniform(0.0, 1.0)


def kept_by_the_body(model: Theorem, invariant: Node, runs: int = 300) -> tuple[int, list[str]]:
    """Runs of the loop body from states drawn where `invariant` (and the model's assumptions
    on what the body never writes) hold, in exact arithmetic: (runs done, violations). Only
    runs whose flows took time count."""
    loop = model.program
    changed = set(written(loop.body))
    fixed = [a for a in conjuncts(model.assumptions) if not set(free_vars(a)) & changed]
    step = Theorem(f"{model.name} step", And(*fixed, invariant), loop.body, invariant)
    interpreter, done, violations = Interpreter(step, exact=True), 0, []
    for seed in range(runs):
        try:
            r = interpreter.run(Durations(seed))
        except (Blocked, Rejected):  # a test of the body or no start state: no run
            continue
        done += r.checkpoints[-1].time > 0
        violations += [r.violated] if r.violated else []
    return done, violations


@pytest.mark.parametrize("name", ["textbook.train", "textbook.water_tank"])
def test_exported_loop_invariants_are_kept_by_the_loop_body(exported, name):
    model = exported["entries"][name].theorem
    invariant = model.program.invariant
    done, violations = kept_by_the_body(model, invariant)
    assert done >= 50 and violations == [], violations
    # teeth: the same check rejects what the body does not keep (the guarantee alone; half full)
    lo, x, hi = Reals("lo x hi")
    loose = {"textbook.train": lambda: model.guarantee,
             "textbook.water_tank": lambda: And(lo <= x, x <= (lo + hi) / 2)}[name]()
    assert kept_by_the_body(model, loose)[1], f"{loose} should not be kept by the body"


def holds_along_flows(ode: ODE, cuts: list[Node], samples: int = 30, seed: int = 0) -> list[str]:
    """The cuts at 301 points of flows scipy integrates for 3 time units from states drawn in
    [-2, 2]^n where every cut and the domain hold; the flow is followed while the domain holds.
    Returns the violations (margin below -1e-6)."""
    c = Compiler()
    names = sorted({v for f in (*cuts, ode.domain, *(f for _, f in ode.eqs)) for v in free_vars(f)}
                   | {v.payload for v in ode.variables})
    moving = [v.payload for v in ode.variables]
    rates = [c(f) for _, f in ode.eqs]
    truth = [c(f) for f in (*cuts, ode.domain)]
    rng, bad, started = random.Random(seed), [], 0
    while started < samples:
        state = {n: rng.uniform(-2, 2) for n in names}
        if not all(t(state) for t in truth):
            continue
        started += 1

        def rhs(_t, y, state=state):
            s = {**state, **dict(zip(moving, y))}
            return [f(s) for f in rates]

        sol = solve_ivp(rhs, (0.0, 3.0), [state[n] for n in moving], method="DOP853", rtol=1e-10,
                        atol=1e-12, dense_output=True)
        assert sol.success
        for t in np.linspace(0.0, 3.0, 301):
            s = {**state, **dict(zip(moving, sol.sol(t)))}
            if not c(ode.domain)(s):
                break
            for cut in cuts:
                if not _holds(cut, s, c):
                    bad.append(f"{cut} fails at t={t:.2f} from {state}")
    return bad


def _holds(f: Node, s: dict, c: Compiler, tol: float = 1e-6) -> bool:
    """f at s, each comparison with a tolerance for the integration's error."""
    if f.op == "and":
        return all(_holds(a, s, c, tol) for a in f.args)
    if f.op == "or":
        return any(_holds(a, s, c, tol) for a in f.args)
    if f.op == "cmp":
        d = c(f.args[0])(s) - c(f.args[1])(s)
        return {"<": d < tol, "<=": d <= tol, ">": d > -tol, ">=": d >= -tol, "==": abs(d) <= tol,
                "!=": True}[f.payload]
    return bool(c(f)(s))


@pytest.mark.parametrize("name", ["grows", "looped", "textbook.bouncing_ball"])
def test_exported_cuts_hold_along_integrated_flows(exported, name):
    (ode,) = [p for _, p in nodes(exported["entries"][name].theorem.program) if isinstance(p, ODE)]
    assert ode.invariants
    assert holds_along_flows(ode, list(ode.invariants)) == []
    # teeth: a cut the flow breaks is caught (x grows past 1; the ball falls below h = 1/2)
    (moving,) = [v for v in ode.variables if v.payload in ("x", "h")]
    broken = moving >= 0.5 if name == "textbook.bouncing_ball" else moving <= 1
    assert holds_along_flows(ode, [*ode.invariants, broken])
