"""CurrentLoop: slope-limited lag (MODEL.md). A step of I_c from 0 to 2 A with the
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
    # RK4 at T_i/10 errs by (0.1)^5/120 = 8e-8 of the remaining error per step.
    np.testing.assert_allclose(step_response["I"], analytic(step_response["time"]), rtol=0, atol=1e-7)


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
