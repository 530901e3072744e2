"""`python -m certiloop.studies regenerate`: rewrite every generated kernel of every case study
from its model (what `certiloop extract` would write), and say which files changed."""

import sys

from certiloop.kernel.extract.shipped import regenerate


def main(argv: list[str]) -> int:
    if argv != ["regenerate"]:
        print("usage: python -m certiloop.studies regenerate", file=sys.stderr)
        return 2
    written = regenerate()
    for path in written:
        print(f"rewrote {path}")
    print(f"{len(written)} generated file{'s' * (len(written) != 1)} rewritten")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
