"""certiloop on KeYmaera X archives, entry by entry, through the CLI.

    python benchmarks/bench_kyx.py [--rlimit N] VALID.kyx... [--invalid INVALID.kyx...]

Each entry runs as `certiloop prove 'FILE.kyx:"Entry"' --json -` in its own process, with a
deterministic z3 budget (--rlimit); an entry of an archive passed after --invalid that the
prover does not refute then goes to `certiloop falsify` too. Per entry it prints the verdict
(proved / refuted / unknown / not supported) and the wall time; then the totals, and a
wrong verdict (proved on an invalid archive, refuted on a valid one) loudly. Writes
results/kyx.json with entry names and verdicts only: the archives are others' text and are
not copied (KeYmaera X's benchmarks live in LS-Lab/KeYmaeraX-projects, benchmarks/).
"""

from __future__ import annotations

import argparse
import json
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from common import RESULTS  # noqa: E402

from certiloop.models.kyx import KyxError, read_entries  # noqa: E402

CLI = [sys.executable, "-m", "certiloop.cli"]
SAFETY_NET_S = 120  # a wall-clock guard per process only: reaching it counts as unknown


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def run(args: list[str]) -> tuple[int, str, str, float]:
    t0 = time.perf_counter()
    try:
        done = subprocess.run(CLI + args, capture_output=True, text=True, timeout=SAFETY_NET_S)
    except subprocess.TimeoutExpired:
        return -1, "", "wall-clock safety net reached", time.perf_counter() - t0
    return done.returncode, done.stdout, done.stderr, time.perf_counter() - t0


def entry_verdict(archive: str, name: str, invalid: bool, rlimit: int, examples: int) -> dict:
    spec = f'{archive}:"{name}"'
    code, out, err, seconds = run(["prove", spec, "--json", "-", "--rlimit", str(rlimit), "--jobs", "1"])
    row = {"archive": Path(archive).name, "entry": name, "expected": "refuted" if invalid else "proved"}
    if code == 2:
        return {**row, "verdict": "not supported", "how": err.strip().splitlines()[-1][:160] if err else "",
                "seconds": round(seconds, 2)}
    if code == -1:
        return {**row, "verdict": "unknown", "how": err, "seconds": round(seconds, 2)}
    data = json.loads(out)
    verdict, how = data["verdict"], "prove"
    row["engine_s"] = round(data["seconds"], 2)  # the prover's own time, without process start-up
    if verdict == "refuted":
        check = data.get("run_check") or {}
        how = "prove: counterexample replayed" if check.get("replayed") else "prove: refuted"
    if invalid and verdict != "refuted":
        code, out, err, more = run(["falsify", spec, "--json", "-", "--max-examples", str(examples)])
        seconds += more
        if code == 1:
            verdict, how = "refuted", "falsify: counterexample replayed"
    return {**row, "verdict": verdict, "how": how, "seconds": round(seconds, 2)}


def read_only(archives: list[str]) -> int:
    from collections import Counter

    parsed, entries, read, reasons = 0, 0, 0, Counter()
    for archive in archives:
        try:
            found = read_entries(Path(archive).read_text(encoding="utf-8", errors="replace"), archive)
        except KyxError as exc:
            reasons["file: " + str(exc).split(": ", 1)[-1][:60]] += 1
            continue
        parsed += 1
        entries += len(found)
        read += sum(e.theorem is not None for e in found)
        reasons.update("entry: " + e.error.split(": ", 1)[-1][:60] for e in found if e.error)
    print(f"{parsed} of {len(archives)} files parse; {read} of {entries} entries read as theorems")
    for why, n in reasons.most_common():
        print(f"  {n:4d}  {why}")
    return 0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("valid", nargs="*", help="archives whose entries are all valid")
    parser.add_argument("--invalid", nargs="*", default=[], help="archives whose entries are all false")
    parser.add_argument("--rlimit", type=int, default=2_000_000, help="z3 resource units per obligation")
    parser.add_argument("--max-examples", type=int, default=300, help="falsifier examples per entry")
    parser.add_argument("--only", help="run only entries whose name contains this text")
    parser.add_argument("--record", default="kyx", help="results/NAME.json to write (default kyx)")
    parser.add_argument("--read-only", action="store_true",
                        help="only read the archives (any, games and exercises included): how many "
                        "files parse and how many entries become theorems, with the reasons for the rest")
    args = parser.parse_args()
    if args.read_only:
        return read_only(args.valid + args.invalid)
    rows: list[dict] = []
    unread: dict[str, str] = {}
    for archive, invalid in [(a, False) for a in args.valid] + [(a, True) for a in args.invalid]:
        try:
            entries = read_entries(Path(archive).read_text(encoding="utf-8", errors="replace"), archive)
        except KyxError as exc:  # the whole archive is refused (e.g. hybrid games): say so, go on
            unread[archive] = str(exc)
            print(f"not read       {archive}: {exc}", flush=True)
            continue
        for entry in entries:
            if args.only and args.only not in entry.name:
                continue
            cpu = _children_cpu()
            row = entry_verdict(archive, entry.name, invalid, args.rlimit, args.max_examples)
            row["cpu_s"] = round(_children_cpu() - cpu, 2)  # start-up included, waiting excluded
            rows.append(row)
            undecided = ("unknown", "not supported", row["expected"])
            wrong = " WRONG VERDICT" if row["verdict"] not in undecided else ""
            print(f"{row['verdict']:<14} {row['seconds']:7.2f} s  {row['entry']}  ({row['how']}){wrong}",
                  flush=True)
    totals = {}
    for archive in dict.fromkeys(r["archive"] for r in rows):
        mine = [r for r in rows if r["archive"] == archive]
        counts = {v: sum(r["verdict"] == v for r in mine) for v in ("proved", "refuted", "unknown",
                                                                     "not supported")}
        wrong = [r["entry"] for r in mine
                 if r["verdict"] in ("proved", "refuted") and r["verdict"] != r["expected"]]
        times = [r["seconds"] for r in mine]
        engine = [r["engine_s"] for r in mine if "engine_s" in r] or [0.0]
        cpu = [r["cpu_s"] for r in mine]
        totals[archive] = {"entries": len(mine), **counts, "wrong": wrong,
                           "median_s": round(statistics.median(times), 2), "max_s": max(times),
                           "engine_median_s": round(statistics.median(engine), 2),
                           "engine_max_s": max(engine), "cpu_median_s": round(statistics.median(cpu), 2),
                           "cpu_max_s": max(cpu)}
        print(f"{archive}: {len(mine)} entries, " + ", ".join(f"{v} {n}" for v, n in counts.items())
              + f", wrong verdicts {len(wrong)}, median {totals[archive]['median_s']} s, "
              f"max {totals[archive]['max_s']} s (prover alone: median "
              f"{totals[archive]['engine_median_s']} s, max {totals[archive]['engine_max_s']} s; CPU "
              f"median {totals[archive]['cpu_median_s']} s, max {totals[archive]['cpu_max_s']} s)")
        for w in wrong:
            print(f"  WRONG VERDICT: {w}")
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / f"{args.record}.json").write_text(json.dumps({
        "benchmark": "kyx", "rlimit": args.rlimit, "date": time.strftime("%Y-%m-%d"),
        "machine": "2-core sandbox shared with other jobs", "totals": totals, "not_read": unread,
        "rows": [{k: r.get(k) for k in ("archive", "entry", "expected", "verdict", "seconds", "engine_s",
                                            "cpu_s")}
                 for r in rows],
    }, indent=2) + "\n")
    return 1 if any(t["wrong"] for t in totals.values()) else 0


if __name__ == "__main__":
    sys.exit(main())
