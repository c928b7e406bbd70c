"""Stepping order and algebraic-loop detection from connections and FMU dependencies."""

from __future__ import annotations

from pendfmu.simulator.graph import Wire, algebraic_loops, stepping_order
from pendfmu.simulator.master import Master, feedthrough_of

ONE_WAY = [Wire("CurrentLoop", "I_mean", "Cart", "I"), Wire("Cart", "a", "Pendulum", "a")]
BACK = ONE_WAY + [Wire("Pendulum", v, "Cart", v) for v in ("phi", "w", "alpha")]
RIG = ["Pendulum", "Cart", "CurrentLoop"]


def test_one_way_rig_steps_in_signal_order():
    assert stepping_order(RIG, ONE_WAY) == [["CurrentLoop"], ["Cart"], ["Pendulum"]]


def test_back_drivable_rig_couples_cart_and_pendulum():
    assert stepping_order(RIG, BACK) == [["CurrentLoop"], ["Cart", "Pendulum"]]


def test_feedthrough_comes_from_the_model_structure():
    assert feedthrough_of("Cart")["a"] == {"I", "u", "phi", "w", "alpha"}
    assert feedthrough_of("Cart")["x"] == set()
    assert feedthrough_of("Pendulum")["alpha"] == {"a"}
    assert feedthrough_of("CurrentLoop")["I"] == set()


def test_algebraic_loop_runs_through_accelerations_only():
    feedthrough = {name: feedthrough_of(name) for name in RIG}
    assert algebraic_loops(ONE_WAY, feedthrough) == []
    (loop,) = algebraic_loops(BACK, feedthrough)
    assert set(loop) == {"Cart.a", "Pendulum.a", "Pendulum.alpha", "Cart.alpha"}


def test_a_cycle_without_feedthrough_is_coupled_but_no_algebraic_loop():
    """phi and w are states: the pendulum feeding only them back is no algebraic loop."""
    feedthrough = {name: feedthrough_of(name) for name in RIG}
    partial = ONE_WAY + [Wire("Pendulum", "phi", "Cart", "phi")]
    assert algebraic_loops(partial, feedthrough) == []
    assert stepping_order(RIG, partial) == [["CurrentLoop"], ["Cart", "Pendulum"]]


def test_master_rejects_unknown_connection_ends():
    import pytest

    with pytest.raises(ValueError, match="Cart has no input 'acc'"):
        Master({"Cart": "Cart", "Pendulum": "Pendulum"}, [Wire("Pendulum", "alpha", "Cart", "acc")])
    with pytest.raises(ValueError, match="more than one output"):
        Master({"Cart": "Cart", "Pendulum": "Pendulum", "CurrentLoop": "CurrentLoop"},
               [Wire("CurrentLoop", "I", "Cart", "I"), Wire("Pendulum", "w", "Cart", "I")])
