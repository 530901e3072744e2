"""The RCM step's cheaper pieces compute what the textbook forms compute, bit for bit: the
cofactor row from explicit column deletion, the rows' cross products from np.cross, the
damping from its formula with the gain table read afresh; and a step keeps no memory."""

import tracemalloc

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from certiloop.studies.rcm.demo import demo_controller
from certiloop.studies.rcm.dynamics import TABLE1, Gains, _cross_rows, redundancy_row, variable_damping

finite = st.floats(-10, 10, allow_nan=False, allow_infinity=False)


@settings(max_examples=50)
@given(st.lists(finite, min_size=42, max_size=42))
def test_cofactor_row_is_the_deletion_formula(values):
    J = np.array(values).reshape(6, 7)
    g = np.array([np.linalg.det(np.delete(J, i, axis=1)) * (-1) ** i for i in range(7)])
    norm = np.linalg.norm(g)
    if norm == 0 or not np.isfinite(norm):
        return
    assert np.array_equal(redundancy_row(J), g / norm)


@settings(max_examples=50)
@given(st.lists(finite, min_size=42, max_size=42))
def test_row_cross_products_are_np_cross(values):
    a, b = np.array(values[:21]).reshape(7, 3), np.array(values[21:]).reshape(7, 3)
    assert np.array_equal(_cross_rows(a, b), np.cross(a, b))


@settings(max_examples=50)
@given(st.lists(finite, min_size=5, max_size=5), st.lists(finite, min_size=4, max_size=4))
def test_damping_is_the_formula_for_any_gain_table(xf, frx):
    other = Gains(d_const=(1.0, 2.0, 3.0, 4.0, 5.0), q_gain=(5.0, 4.0, 3.0, 2.0, 1.0))
    for g in (TABLE1, other, TABLE1):
        s = np.array([abs(xf[0]), *[np.linalg.norm(xf[1:4])] * 3, 0.0])
        z = np.array([abs(frx[0]), *[np.linalg.norm(frx[1:4])] * 3, 0.0])
        want = (np.asarray(g.d_const) + np.asarray(g.q_gain) * np.exp(-np.asarray(g.m_gain) * s)
                + np.asarray(g.g_gain) * (1.0 - np.exp(-np.asarray(g.c_gain) * z * z)))
        assert np.array_equal(variable_damping(np.array(xf), np.array(frx), g), want)


def test_steps_keep_no_memory():
    """What a step allocates it gives back: the traced memory after 600 more steps is what it
    was after 100 (a control loop's memory must not grow)."""
    c = demo_controller(points=2000, gap=0.005)
    wrench = [0.5, -0.3, -1.0, 0.01, 0.0, 0.0]
    for _ in range(100):
        c.step(wrench)
    tracemalloc.start()
    try:
        for _ in range(100):
            c.step(wrench)
        before = tracemalloc.get_traced_memory()[0]
        for _ in range(500):
            result = c.step(wrench)
        after = tracemalloc.get_traced_memory()[0]
    finally:
        tracemalloc.stop()
    assert result.ok and np.all(np.isfinite(result.q))
    assert after - before < 4096, (before, after)
