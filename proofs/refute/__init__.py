"""Refutation: searching for a concrete run that violates a theorem's guarantee."""

from certiloop.proofs.refute.unroll import Refutation, Replay, Step, refute

__all__ = ["Refutation", "Replay", "Step", "refute"]
