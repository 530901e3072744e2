"""The RCM paper's admittance controller kernel (KUKA LWR4+, 250 Hz): one import path.

* `studies/rcm/arm.py` (numpy only): LWR4+ kinematics and Jacobian, the RCM error and constraint
  Jacobian, the weighted null-space projector, the paper's axial Euler step, and the proved
  sampled-data guard (`guard_speed`, running the hash-pinned `studies/rcm/generated/axial_guard.py`).
* `RcmAdmittance` (`studies/rcm/dynamics.py`) and `demo_controller` (`studies/rcm/demo.py`): the
  7-DOF target dynamics with the KD-tree barrier. Loaded on first use (PEP 562), because they
  need scipy and an importer of the guard alone should not pay for it.
"""

from __future__ import annotations

from importlib import import_module

from certiloop.studies.rcm.arm import (  # noqa: F401 (re-exported)
    D0,
    DH_ALPHA,
    DH_D,
    K_BAR,
    Q_ANCHOR,
    GuardedCommand,
    H,
    axial_euler_step,
    barrier_force_axial,
    damping_axial,
    guard_speed,
    guarded_axial_step,
    guarded_tip_velocity,
    lwr4_forward,
    lwr4_jacobian,
    null_projector,
    rcm_constraint_jacobian,
    rcm_error,
    tool_tip,
)

_LAZY = {"demo_controller": "certiloop.studies.rcm.demo", "RcmAdmittance": "certiloop.studies.rcm.dynamics"}


def __getattr__(name: str):
    if name in _LAZY:
        return getattr(import_module(_LAZY[name]), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
