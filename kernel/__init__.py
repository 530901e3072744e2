"""Runtime kernel: the virtual fixture built from the verified ctrl2 (numpy only)."""

from certiloop.kernel.fixture import Command, VirtualFixture

__all__ = ["Command", "VirtualFixture"]
