"""The hypothesis search forked beside the batch phase (`--jobs 2`) finds what one after the other
finds: the same JSON result byte for byte (but for its seconds) and the same example database;
the same seed twice gives the same output; a counterexample found so is one the exact
interpreter replays to a violation."""

import json
import re

import pytest

from certiloop.falsify.batch.phase import exact_initial
from certiloop.falsify.choosers import Scripted
from certiloop.falsify.interpreter import Interpreter
from certiloop.falsify.search import Options, falsify
from certiloop.models import library
from certiloop.proofs.engine.forked import can_fork

pytestmark = pytest.mark.skipif(not can_fork(), reason="no fork on this platform")


def _cli_output(tmp_path, name: str, model: str, jobs: int, seed: int, examples: int) -> tuple[bytes, list]:
    """The --json output with its seconds blanked, and the example database's files."""
    from certiloop.cli import main

    folder = tmp_path / name
    folder.mkdir()
    out, db = folder / "out.json", folder / "db"
    code = main(["falsify", model, "--max-examples", str(examples), "--seed", str(seed), "--jobs", str(jobs),
                 "--json", str(out), "--database", str(db), "--quiet"])
    assert code in (0, 1)
    text = out.read_bytes()
    files = sorted(str(p.relative_to(db)) for p in db.rglob("*") if p.is_file()) if db.exists() else []
    return re.sub(rb'"seconds": [0-9.e-]+', b'"seconds": 0', text), files


@pytest.mark.parametrize("model, examples", [("textbook.water_tank", 100), ("sbs.ctrl1_broken", 100)])
def test_two_jobs_give_byte_for_byte_the_output_and_database_of_one(tmp_path, model, examples):
    one, one_db = _cli_output(tmp_path, "one", model, 1, 3, examples)
    two, two_db = _cli_output(tmp_path, "two", model, 2, 3, examples)
    again, again_db = _cli_output(tmp_path, "again", model, 2, 3, examples)
    assert one == two == again
    assert one_db == two_db == again_db
    if model == "textbook.water_tank":  # safe: the search ran to its end and kept its pareto front
        assert json.loads(one)["verdict"] == "no counterexample" and one_db
    else:  # the batch phase found the run first: the forked search left the database alone
        assert json.loads(one)["verdict"] == "refuted" and not one_db


def test_a_counterexample_the_forked_search_found_replays_exactly():
    """One batch run only, which misses: hypothesis (in the forked child) finds the run, the
    parent shrinks it; the same as with one job, and the exact interpreter, given the
    reported decisions, ends in a violation."""
    theorem = library.get("sbs.ctrl1_broken")
    results = [falsify(theorem, Options(max_examples=300, seed=0, database=None, batch_runs=1, jobs=jobs))
               for jobs in (1, 2)]
    docs = [r.to_json() for r in results]
    for d in docs:
        d.pop("seconds")
    assert docs[0] == docs[1]
    found = results[1]
    assert found.found and found.phase == "hypothesis"
    exact = Interpreter(theorem, exact=True)
    start = None if found.initial is None else exact_initial(theorem, found.initial, exact.c)
    run = exact.run(Scripted(found.script), start)
    assert run.violated is not None
    assert min(run.checkpoints[-1].margins.values()) < 0
