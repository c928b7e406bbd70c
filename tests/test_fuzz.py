"""Fuzzing the FMUs' parameters and inputs (issue 7): whatever the values (NaN, Inf, huge,
tiny, sign flips), every call returns fmi2OK or fmi2Error with a logged reason, and never
crashes or hangs. A crash would take the test process down; a hang is caught by the
per-example deadline."""

from __future__ import annotations

import math
from datetime import timedelta

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pendfmu.components import ALL_COMPONENTS as COMPONENTS
from pendfmu.simulator.component import ComponentFMU, FMUError

SPECIAL = [0.0, -0.0, 1e-300, -1e-300, 5e-324, 1e-12, 1.0, -1.0, 1e12, -1e12, 1e300, -1e300, 1.7e308,
           math.inf, -math.inf, math.nan]
values = st.one_of(st.sampled_from(SPECIAL), st.floats(allow_nan=True, allow_infinity=True))


INTEGERS = st.one_of(st.sampled_from([0, -1, 1, 2, 100, 101, -2**31, 2**31 - 1]), st.integers(-2**31, 2**31 - 1))


def parameters_of(name):
    """Real parameters get any float; Integer and Boolean ones (the Controller's n_d, delay,
    derivative_on_measurement) any value of their type."""
    table = COMPONENTS[name].parameters
    if all(v.type == "Real" for v in table.values()):  # the rig's components: the examples as ever
        return st.dictionaries(st.sampled_from(sorted(table)), values, max_size=4)
    kinds = {"Real": values, "Integer": INTEGERS, "Boolean": st.booleans()}
    return st.dictionaries(st.sampled_from(sorted(table)), values, max_size=4).flatmap(
        lambda chosen: st.fixed_dictionaries({n: kinds[table[n].type] for n in chosen}))


def inputs_of(name):
    names = [v.name for v in COMPONENTS[name].of(causality="input")]
    return st.lists(st.dictionaries(st.sampled_from(names), values, max_size=len(names)), min_size=1, max_size=4)


def exercise(name, parameters, steps):
    """Instantiate with the parameters and step with the inputs; every failure must be an
    FMUError that carries the FMU's reason."""
    try:
        fmu = ComponentFMU(name, parameters)
    except FMUError as error:
        assert str(error).strip() != f"{name}:", "an error without a reason"
        return
    try:
        for inputs in steps:
            try:
                fmu.step(1e-3, inputs)
                fmu.get(*(v.name for v in fmu.component.of(causality="output")))
            except FMUError as error:
                assert len(str(error)) > len(name) + 2, "an error without a reason"
                return
    finally:
        fmu.free()


def fuzz(name):
    @settings(max_examples=60, deadline=timedelta(seconds=5), derandomize=True,
              suppress_health_check=[HealthCheck.too_slow])
    @given(parameters_of(name), inputs_of(name))
    def run(parameters, steps):
        exercise(name, parameters, steps)

    return run


test_fuzz_current_loop = fuzz("CurrentLoop")
test_fuzz_cart = fuzz("Cart")
test_fuzz_pendulum = fuzz("Pendulum")
test_fuzz_controller = fuzz("Controller")


def test_stiff_parameters_fail_with_a_reason_instead_of_hanging():
    """Where RK4 integrates, a time constant near zero would need endless internal steps."""
    cases = (("CurrentLoop", {"T_i": 1e-300}, {"I_c": [1.0, 1e3]}),  # a curved input: RK4 fallback
             ("Cart", {"k_fwc": 1e300, "eta": 0.7}, {}),  # back-drivable: RK4
             ("Pendulum", {"solver_step": 1e-300}, {}))
    for name, parameters, derivatives in cases:
        try:
            with ComponentFMU(name, parameters) as fmu:
                fmu.step(1e-3, {}, derivatives)
        except FMUError as error:
            assert "too stiff" in str(error)
        else:
            raise AssertionError(f"{name} with {parameters} stepped without complaint")


def test_a_vanishing_time_constant_is_fine_where_the_step_is_exact():
    """With a held input the current loop steps exactly: T_i = 1e-300 is an instantaneous
    lag behind the slope limit, so 1 A is reached after 0.4 ms at 2500 A/s."""
    with ComponentFMU("CurrentLoop", {"T_i": 1e-300}) as fmu:
        fmu.step(1e-3, {"I_c": 1.0})
        (current,) = fmu.get("I")
    assert abs(current - 1.0) < 1e-12


def test_an_overwhelming_viscous_friction_is_fine_where_the_cart_steps_exactly():
    """A self-locking cart steps exactly: with k_fwc = 1e300 N.s/m it breaks away but
    cannot gather speed (v = F/k_fwc, about 1e-300 m/s)."""
    with ComponentFMU("Cart", {"k_fwc": 1e300, "eta": 0.4}) as fmu:
        fmu.step(1e-3, {"I": 5.0})
        x, v, mode = fmu.get("x", "v", "mode")
    assert mode == 1 and 0.0 < v < 1e-290 and 0.0 < x < 1e-290
