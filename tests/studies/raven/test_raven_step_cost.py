"""RavenArm.step's cheaper forms decide as the textbook ones: a non-finite positioning joint is
held at 0 while the finite ones are kept, the torque is clipped to its limits, runs are
independent of their batch, nothing is NaN."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from certiloop.studies.raven import arm as raven

anything = st.floats(allow_nan=True, allow_infinity=True)
joint = st.floats(-2, 2, allow_nan=False)


@settings(max_examples=60)
@given(st.lists(st.lists(st.one_of(joint, anything), min_size=6, max_size=6), min_size=1, max_size=4),
       st.lists(st.one_of(joint, anything), min_size=6, max_size=6))
def test_step_holds_non_finite_joints_at_zero_and_is_batch_independent(rows, target):
    arm = raven.RavenArm()
    q = np.array(rows, dtype=float)
    state = raven.ArmState(q, np.zeros_like(q), np.zeros((len(q), 3)))
    targets = np.tile(np.array(target), (len(q), 1))
    new, tau, braked = arm.step(state, targets)
    assert np.all(np.isfinite(new.q)) and np.all(np.isfinite(new.qdot)) and np.all(np.isfinite(tau))
    assert np.all(np.abs(tau) <= arm.p.tau_max)
    for r, row in enumerate(q):
        qp = row[:3]
        # each run alone gives what it gave in the batch
        alone = raven.ArmState(row[None].copy(), np.zeros((1, 6)), np.zeros((1, 3)))
        one, one_tau, _ = arm.step(alone, np.array(target)[None])
        assert np.array_equal(one.q[0], new.q[r]) and np.array_equal(one_tau[0], tau[r])
        if not np.all(np.isfinite(qp)):  # the hold: q' = 0 there, so q_new = held q + tau dt^2/I
            held = np.where(np.isfinite(qp), qp, 0.0)
            acc = tau[r] / arm.p.inertia
            assert np.array_equal(new.q[r, :3], held + (acc * arm.p.dt) * arm.p.dt)
