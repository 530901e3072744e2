"""Choose the slow tier from a timed run of the whole suite.

    SOUNDNESS_TIMES=cases.txt python -m pytest -q -m "slow or not slow" --durations=0 \
        -p no:cacheprovider > durations.txt
    python tests/tiers.py durations.txt cases.txt

Writes tests/slow_tests.txt: the slowest tests, marked `slow` at collection (conftest.py), until
the rest takes at most QUICK_SHARE of the suite's time; the cheapest test of every file stays
in the quick tier, so the quick tier still reaches every module. A test not in the list (a new
one) is quick until the next timing says otherwise.

A soundness theme proves its selected cases in one fixture (tests/soundness/themes.py), so pytest
charges them all to the first test's setup; SOUNDNESS_TIMES writes each case's own time, which
replaces that setup here.
"""

import re
import sys
from collections import defaultdict
from pathlib import Path

QUICK_SHARE = 0.12  # the quick tier's aim: 5 minutes on 2 idle cores
HERE = Path(__file__).parent


def choose(durations: str, cases: str = "") -> list[str]:
    case_seconds = {}
    for line in cases.splitlines():
        m = re.match(r"([\d.]+)s case\s+(\S.*?)\s*$", line)
        if m:
            case_seconds[m.group(2)] = float(m.group(1))
    seconds: dict[str, float] = defaultdict(float)
    for line in durations.splitlines():
        m = re.match(r"([\d.]+)s (setup|call|teardown)\s+(\S.*?)\s*$", line)
        if m and not (m.group(2) == "setup" and m.group(3) in case_seconds):
            seconds[m.group(3)] += float(m.group(1))
    for node, t in case_seconds.items():
        seconds[node] += t
    total = sum(seconds.values())
    by_file: dict[str, list] = defaultdict(list)
    for node, t in seconds.items():
        by_file[node.split("::")[0]].append((t, node))
    cheapest = {min(tests)[1] for tests in by_file.values()}
    slow, quick = [], total
    for node, t in sorted(seconds.items(), key=lambda item: -item[1]):
        if quick <= QUICK_SHARE * total:
            break
        if node not in cheapest:
            slow.append(node)
            quick -= t
    return sorted(slow)


if __name__ == "__main__":
    chosen = choose(Path(sys.argv[1]).read_text(), Path(sys.argv[2]).read_text() if len(sys.argv) > 2 else "")
    (HERE / "slow_tests.txt").write_text("\n".join(chosen) + "\n")
    print(f"{len(chosen)} tests in the slow tier")
