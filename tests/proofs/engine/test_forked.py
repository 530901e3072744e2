"""forked_map: the serial map's result, in order, computed in forked children."""

import os

import pytest

from certiloop.proofs.engine.forked import SERIAL_BELOW, forked_map


def test_the_result_is_the_serial_maps_in_order_and_computed_in_children():
    data = [k * k - 7 for k in range(50)]  # seen by the children as it is at the fork
    pids = forked_map(lambda i: os.getpid(), 50)
    assert forked_map(lambda i: data[i] * 3, 50) == [x * 3 for x in data]
    assert os.getpid() not in pids and len(set(pids)) == 2


def test_a_few_items_run_in_this_process():
    assert forked_map(lambda i: os.getpid(), SERIAL_BELOW - 1) == [os.getpid()] * (SERIAL_BELOW - 1)


def test_an_item_that_raises_raises_here():
    def fn(i):
        if i == 31:
            raise ValueError("item 31")
        return i

    with pytest.raises(ValueError, match="item 31"):
        forked_map(fn, 40)
