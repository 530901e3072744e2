"""The product surface: the `certiloop` command, model loading, reports and the gate."""

from certiloop.proofs.cli.main import main, run

__all__ = ["main", "run"]
