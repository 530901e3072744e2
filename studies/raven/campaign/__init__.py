"""Fault-injection campaigns over a batched closed loop of the Raven-II deviation monitor."""
