"""pendfmu.ranges, the one rule for a parameter's declared range: its ends, its message, and
its agreement with the check the FMUs make in C."""

from __future__ import annotations

import math

import pytest

from pendfmu.components import CART, COMPONENTS, PENDULUM, Variable
from pendfmu.ranges import admits, interval, number, outside
from pendfmu.simulator import ComponentFMU, FMUError


def variable(low=None, high=None, low_open=False, unit="kg") -> Variable:
    return Variable("q", "parameter", "fixed", 1.0, unit, low=low, high=high, low_open=low_open)


@pytest.mark.parametrize("declared, value, expected", [
    (variable(0.0), 0.0, True),
    (variable(0.0, low_open=True), 0.0, False),
    (variable(0.0, low_open=True), 5e-324, True),
    (variable(0.0), -5e-324, False),
    (variable(0.0, 1.0), 1.0, True),
    (variable(0.0, 1.0), math.nextafter(1.0, 2.0), False),
    (variable(), -1e300, True),
    (variable(), math.inf, False),
    (variable(), math.nan, False),
])
def test_admits_closed_and_open_ends_and_only_finite_values(declared, value, expected):
    assert admits(declared, value) is expected


@pytest.mark.parametrize("declared, text", [
    (variable(0.0, 1.0, low_open=True), "(0.0, 1.0]"), (variable(0.0), "[0.0, inf)"),
    (variable(None, 2.5), "(-inf, 2.5]"), (variable(), "(-inf, inf)"),
])
def test_interval_reads_like_the_range(declared, text):
    assert interval(declared) == text


@pytest.mark.parametrize("value, text", [(-1.0, "-1"), (0.0, "0"), (1.5, "1.5"), (1e-5, "1e-05"),
                                         (1.0000001, "1.0000001"), (math.nan, "nan")])
def test_number_is_short_where_that_is_exact(value, text):
    assert number(value) == text


def test_outside_names_subject_value_range_and_unit():
    assert outside("Cart.eta", 1.5, [CART.variable("eta")]) == "Cart.eta = 1.5 is outside its physical range (0.0, 1.0] [1]"
    assert outside("Cart.eta", 1.0, [CART.variable("eta")]) is None


def test_a_shared_quantity_is_valid_when_one_owner_takes_it():
    owners = [CART.variable("m_p"), PENDULUM.variable("m_p")]
    assert outside("m_p", 0.0, owners) is None  # a cart whose pendulum is removed
    assert outside("m_p", -1.0, owners) == "m_p = -1 is outside its physical range (0.0, inf) or [0.0, inf) [kg]"


def _ends():
    """Every bounded parameter of the table at and just beyond each of its ends."""
    for component in COMPONENTS.values():
        for name, declared in component.parameters.items():
            for end, beyond in ((declared.low, -math.inf), (declared.high, math.inf)):
                if end is not None:
                    for value in (end, math.nextafter(end, beyond)):
                        yield pytest.param(component.name, name, value, id=f"{component.name}.{name}={value!r}")


@pytest.mark.parametrize("component, name, value", list(_ends()))
def test_the_fmus_take_exactly_what_the_python_rule_admits(component, name, value):
    admitted = admits(COMPONENTS[component].variable(name), value)
    try:
        ComponentFMU(component, {name: value}).free()
        taken = True
    except FMUError as error:
        assert "physical range" in str(error)
        taken = False
    assert taken is admitted
