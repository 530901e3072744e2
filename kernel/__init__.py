"""Runtime kernel: the virtual fixture built from the verified ctrl2 (numpy only)."""

from .fixture import Command, VirtualFixture

__all__ = ["Command", "VirtualFixture"]
