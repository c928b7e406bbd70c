"""Cart: stiction holds, sliding under a constant drive, the back-drive coupling."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pendfmu.simulator import ComponentFMU

# Reference rig: eta k_M k_D = 0.4 * 0.06 * 628.3 = 15.08 N per ampere.
FORCE_PER_AMPERE = 0.4 * 0.06 * 628.3
MASS = 3.0 + 0.2


def test_stuck_cart_does_not_move_at_all():
    current = 0.95 * 12.0 / FORCE_PER_AMPERE  # F_A = 11.4 N < F_Sc = 12 N
    with ComponentFMU("Cart", {"x0": 0.123}) as cart:
        result = cart.run(np.linspace(0, 10, 2001), ["x", "v", "a", "mode", "F_F"],
                          inputs=lambda t: {"I": current})
    assert np.all(result["x"] == 0.123) and np.all(result["v"] == 0) and np.all(result["a"] == 0)
    assert np.all(result["mode"] == 0)
    np.testing.assert_allclose(result["F_F"][1:], current * FORCE_PER_AMPERE, rtol=1e-15)


def test_constant_drive_slides_to_the_viscous_terminal_speed():
    """Above stiction: m dv/dt = F - F_K - k v, so v = (F - F_K)/k (1 - exp(-k t / m))."""
    current = 2.0
    force = current * FORCE_PER_AMPERE
    times = np.linspace(0, 0.5, 501)
    with ComponentFMU("Cart") as cart:
        result = cart.run(times, ["x", "v", "mode"], inputs=lambda t: {"I": current})
    v_inf, tau = (force - 8.0) / 30.0, MASS / 30.0
    np.testing.assert_allclose(result["v"], v_inf * (1 - np.exp(-times / tau)), rtol=0, atol=1e-10)
    x = v_inf * (times - tau * (1 - np.exp(-times / tau)))
    np.testing.assert_allclose(result["x"], x, rtol=0, atol=1e-11)


def test_ramped_drive_follows_the_exact_solution():
    """A self-locking cart steps by its exact solution. Under I = I0 + c t,
    v' = A + B t - v/tau with A = (F(I0) - F_K)/m, B = F(c)/m, tau = m/k, so
    v = tau (A - tau B)(1 - exp(-t/tau)) + tau B t; the FMU should match to rounding
    (the former RK4 steps were 1e-10 off)."""
    I0, slope = 2.0, 3.0
    times = np.linspace(0, 0.5, 501)
    with ComponentFMU("Cart") as cart:
        result = cart.run(times, ["x", "v", "mode"], inputs=lambda t: {"I": I0 + slope * t},
                          derivatives=lambda t: {"I": [slope]})
    tau = MASS / 30.0
    A, B = (I0 * FORCE_PER_AMPERE - 8.0) / MASS, slope * FORCE_PER_AMPERE / MASS
    decayed = -np.expm1(-times / tau)
    v = tau * (A - tau * B) * decayed + tau * B * times
    x = tau * (A - tau * B) * (times - tau * decayed) + tau * B * times**2 / 2
    assert np.all(result["mode"][1:] == 1)  # from the first step on (at t = 0 the input is not yet set)
    np.testing.assert_allclose(result["v"], v, rtol=0, atol=1e-14)
    np.testing.assert_allclose(result["x"], x, rtol=0, atol=1e-14)


def test_braking_stops_the_cart_and_holds_it():
    """Coasting from v0 with no drive: m dv/dt = -F_K - k v stops at
    t_stop = (m/k) ln(1 + k v0 / F_K); then stiction holds it for good."""
    v0 = 0.2
    with ComponentFMU("Cart", {"v0": v0}) as cart:
        result = cart.run(np.linspace(0, 0.5, 501), ["x", "v", "mode", "t_mode"], inputs=lambda t: {"I": 0.0})
    t_stop = MASS / 30.0 * math.log(1 + 30.0 * v0 / 8.0)
    assert result["t_mode"][-1] == pytest.approx(t_stop, abs=1e-12)
    x_stop = (MASS / 30.0) * (v0 - 8.0 / 30.0 * math.log(1 + 30.0 * v0 / 8.0))
    assert result["x"][-1] == pytest.approx(x_stop, abs=1e-12)
    assert result["v"][-1] == 0.0


def test_self_locking_screw_ignores_the_pendulum():
    with ComponentFMU("Cart", {"eta": 0.5}) as cart:
        cart.step(1e-3, inputs={"I": 3.0, "phi": 1.0, "w": 5.0, "alpha": 40.0})
        coupled = cart.get("F_A")[0]
    assert coupled == pytest.approx(0.5 * 0.06 * 628.3 * 3.0, rel=1e-15)


def test_back_drivable_screw_feels_the_pendulum():
    eta, phi, w, alpha = 0.7, 2.5, 1.5, -4.0
    with ComponentFMU("Cart", {"eta": eta}) as cart:
        cart.set(I=1.0, phi=phi, w=w, alpha=alpha)
        (F_A,) = cart.get("F_A")
    A = (2 * eta - 1) / eta
    expected = eta * 0.06 * 628.3 + A * 0.2 * 0.3 * (w**2 * math.sin(phi) - alpha * math.cos(phi))
    assert F_A == pytest.approx(expected, rel=1e-14)
