"""Adversarial soundness suite (see harness.py)."""
