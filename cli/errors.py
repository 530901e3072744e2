"""Exit codes and the user-error exception of the `certiloop` command."""

from __future__ import annotations

import argparse

EXIT_OK, EXIT_FAILED, EXIT_BAD_INPUT, EXIT_INCONSISTENT, EXIT_INTERRUPTED = 0, 1, 2, 3, 130


class BadInput(Exception):
    """A user error: reported on one line, exit 2."""


class Parser(argparse.ArgumentParser):
    def error(self, message: str) -> None:  # argparse prints usage + exits 2; keep it one line
        raise BadInput(f"{message} (see `{self.prog} --help`)")
