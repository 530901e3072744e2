"""The product surface: the `certiloop` command, model loading, reports and the gate."""

from certiloop.cli.main import main, run

__all__ = ["main", "run"]
