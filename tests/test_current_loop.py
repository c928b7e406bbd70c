"""CurrentLoop: slope-limited lag (docs/user-guide/model.md). A step of I_c from 0 to 2 A with the
reference T_i = 0.3 ms and dIdt_max = 2500 A/s: the error 2 A exceeds the band
T_i*dIdt_max = 0.75 A, so the current ramps at 2500 A/s until I = 1.25 A at t1 = 0.5 ms,
then follows I = 2 - 0.75 exp(-(t - t1)/T_i)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pendfmu.simulator import ComponentFMU

T_I, SLOPE, TARGET = 0.3e-3, 2500.0, 2.0
T1 = (TARGET - T_I * SLOPE) / SLOPE


def analytic(t):
    return np.where(t < T1, SLOPE * t, TARGET - T_I * SLOPE * np.exp(-(t - T1) / T_I))


@pytest.fixture(scope="module")
def step_response():
    times = np.linspace(0.0, 10e-3, 501)  # 20 us sampling
    with ComponentFMU("CurrentLoop") as loop:
        return loop.run(times, ["I", "der(I_mean)", "mode", "t_mode"], inputs=lambda t: {"I_c": TARGET})


def test_ramp_while_saturated(step_response):
    ramp = step_response["time"] < T1 - 1e-9
    assert np.all(step_response["der(I_mean)"][ramp][1:] == SLOPE)
    np.testing.assert_allclose(step_response["I"][ramp], SLOPE * step_response["time"][ramp], rtol=0, atol=1e-12)


def test_saturation_ends_at_the_analytic_instant(step_response):
    assert step_response["mode"][-1] == 0
    assert abs(step_response["t_mode"][-1] - T1) < 1e-12


def test_exponential_after_the_corner(step_response):
    # The current loop steps with its exact solution (held or ramped input): only rounding.
    np.testing.assert_allclose(step_response["I"], analytic(step_response["time"]), rtol=0, atol=1e-13)


def test_ramp_input_follows_the_exact_lag():
    """A ramp u = u0 + c t through input derivatives, inside the linear band:
    I = u0 + c t - c T (1 - exp(-t/T)) from I(0) = u0."""
    times = np.linspace(0.0, 10e-3, 501)
    with ComponentFMU("CurrentLoop", {"I0": 0.5}) as loop:
        result = loop.run(times, ["I", "mode"], inputs=lambda t: {"I_c": 0.5 + 100.0 * t},
                          derivatives=lambda t: {"I_c": [100.0]})
    exact = 0.5 + 100.0 * times - 100.0 * T_I * (1 - np.exp(-times / T_I))
    assert np.all(result["mode"] == 0)
    np.testing.assert_allclose(result["I"], exact, rtol=0, atol=1e-13)


def test_curved_input_falls_back_to_rk4_and_stays_accurate():
    """Second derivatives have no closed form here: RK4 at T_i/10, errors ~1e-8 of the step."""
    times = np.linspace(0.0, 5e-3, 251)
    with ComponentFMU("CurrentLoop") as loop:
        result = loop.run(times, ["I"], inputs=lambda t: {"I_c": 2e4 * t * t},
                          derivatives=lambda t: {"I_c": [4e4 * t, 4e4]})
    # u = a t^2 in the linear band: I = a (t^2 - 2 T t + 2 T^2 (1 - exp(-t/T)))
    a = 2e4
    exact = a * (times**2 - 2 * T_I * times + 2 * T_I**2 * (1 - np.exp(-times / T_I)))
    np.testing.assert_allclose(result["I"], exact, rtol=0, atol=1e-9)


def test_exact_final_value(step_response):
    # After 31 time constants the lag's error is 0.75 exp(-31) = 2.6e-14 A.
    assert abs(step_response["I"][-1] - TARGET) < 1e-13


def test_falling_step_ramps_down_at_the_limit():
    with ComponentFMU("CurrentLoop", {"I0": 3.0}) as loop:
        loop.step(0.2e-3, inputs={"I_c": 0.0})
        (current,) = loop.get("I")
    assert current == pytest.approx(3.0 - SLOPE * 0.2e-3, abs=1e-12)


def test_ripple_harmonic_on_the_output():
    ripple = {"a_h": 0.1, "f_h": 1000.0, "phase_h": 0.3}
    with ComponentFMU("CurrentLoop", {"I0": 1.0, **ripple}) as loop:
        loop.step(1.3e-3, inputs={"I_c": 1.0})
        current, mean = loop.get("I", "I_mean")
    assert mean == 1.0
    assert current == pytest.approx(1.0 + 0.1 * math.sin(2 * math.pi * 1000.0 * 1.3e-3 + 0.3), abs=1e-12)
