"""Copy KeYmaera X archives with every `@invariant(...)` annotation removed.

    python benchmarks/strip_invariants.py ARCHIVE.kyx... -o DIR

Writes DIR/NAME (same file name) for each archive: the text with each `@invariant` and its
parenthesised argument (nested parentheses matched) cut out, nothing else changed. Measures
what the automatic invariants prove without the authors' help; the archives are others' text,
so the copies belong in a temporary folder, never in the repository.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

MARK = "@invariant"


def strip(text: str) -> str:
    """The text without its `@invariant(...)` annotations."""
    out, i = [], 0
    while (start := text.find(MARK, i)) >= 0:
        out.append(text[i:start])
        j = start + len(MARK)
        while j < len(text) and text[j].isspace():
            j += 1
        if j >= len(text) or text[j] != "(":
            out.append(MARK)  # not an annotation after all: keep it
            i = start + len(MARK)
            continue
        depth = 0
        for k in range(j, len(text)):
            depth += {"(": 1, ")": -1}.get(text[k], 0)
            if depth == 0:
                break
        i = k + 1
    out.append(text[i:])
    return "".join(out)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("archives", nargs="+")
    parser.add_argument("-o", "--out", required=True, help="folder for the stripped copies")
    args = parser.parse_args()
    folder = Path(args.out)
    folder.mkdir(parents=True, exist_ok=True)
    for archive in args.archives:
        text = Path(archive).read_text(encoding="utf-8")
        stripped = strip(text)
        (folder / Path(archive).name).write_text(stripped, encoding="utf-8")
        print(f"{archive}: {text.count(MARK) - stripped.count(MARK)} annotations removed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
