"""Pendulum: period, friction decays and resting, against analytic results.

phi is measured from the upward vertical, so the hanging pendulum swings about pi.
The reference rod: m_p = 0.2 kg, l = 0.3 m, J = (4/3) m_p l^2 = 0.024 kg.m2."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pendfmu.simulator import ComponentFMU

M, L, G = 0.2, 0.3, 9.81
J = 4 / 3 * M * L**2
NO_FRICTION = {"k_fwp": 0.0, "T_Kp": 0.0, "T_Sp": 0.0}


def swing(parameters, stop, step=1e-3):
    times = np.linspace(0.0, stop, int(round(stop / step)) + 1)
    with ComponentFMU("Pendulum", parameters) as pendulum:
        result = pendulum.run(times, ["phi", "w", "alpha", "T_A", "mode", "t_mode"])
    result["theta"] = result["phi"] - math.pi
    return result


def turning_points(result):
    """Extreme angles between sign changes of w, refined by a parabola through 3 samples."""
    theta, w = result["theta"], result["w"]
    points = []
    for k in np.nonzero((w[:-1] > 0) != (w[1:] > 0))[0]:
        if result["mode"][k + 1] == 0 or result["mode"][k] == 0:
            continue
        a, b, c = theta[k - 1], theta[k], theta[k + 1]
        denominator = a - 2 * b + c
        points.append(b - (a - c) ** 2 / (8 * denominator) if denominator else b)
    return np.array(points)


def test_small_angle_period():
    result = swing({**NO_FRICTION, "phi0": math.pi + 0.01}, stop=5.0, step=1e-4)
    theta, t = result["theta"], result["time"]
    up = np.nonzero((theta[:-1] < 0) & (theta[1:] >= 0))[0]
    crossings = t[up] - theta[up] * (t[up + 1] - t[up]) / (theta[up + 1] - theta[up])
    period = np.mean(np.diff(crossings))
    expected = 2 * math.pi * math.sqrt(J / (M * G * L))  # 1.0975 s
    # Amplitude 0.01 rad lengthens the period by theta^2/16 = 6e-6.
    assert period == pytest.approx(expected, rel=2e-5)


def test_coulomb_decay_loses_a_fixed_amplitude_per_half_swing():
    T_K = 2e-3
    result = swing({"k_fwp": 0.0, "T_Kp": T_K, "T_Sp": T_K, "phi0": math.pi + 0.2}, stop=6.0, step=1e-4)
    amplitudes = np.abs(turning_points(result))
    assert len(amplitudes) >= 6
    loss = -np.diff(amplitudes)
    # Linearized: 2 T_K / (m g l) per half swing (Coulomb friction T_K), within 1 %.
    np.testing.assert_allclose(loss, 2 * T_K / (M * G * L), rtol=0.01)
    # Exact energy balance between turning points: m g l (cos a2 - cos a1) = T_K (a1 + a2).
    a1, a2 = amplitudes[:-1], amplitudes[1:]
    np.testing.assert_allclose(M * G * L * (np.cos(a2) - np.cos(a1)), T_K * (a1 + a2), rtol=1e-5)


def test_viscous_decay_follows_the_exponential_envelope():
    k = 1e-3
    result = swing({"k_fwp": k, "T_Kp": 0.0, "T_Sp": 0.0, "phi0": math.pi + 0.05}, stop=20.0, step=1e-3)
    theta, t = result["theta"], result["time"]
    peaks = np.nonzero((theta[1:-1] > theta[:-2]) & (theta[1:-1] >= theta[2:]) & (theta[1:-1] > 0))[0] + 1
    rate = -np.polyfit(t[peaks], np.log(theta[peaks]), 1)[0]
    assert rate == pytest.approx(k / (2 * J), rel=0.005)


def test_comes_to_rest_where_stiction_holds_it():
    params = {"k_fwp": 1e-3, "T_Kp": 2e-3, "T_Sp": 4e-3, "phi0": math.pi + 0.3}
    result = swing(params, stop=30.0)
    assert result["mode"][-1] == 0
    rest = result["time"] >= result["t_mode"][-1]
    assert np.all(result["w"][rest] == 0.0) and np.all(result["alpha"][rest] == 0.0)
    assert np.all(result["phi"][rest] == result["phi"][-1])
    assert abs(M * L * G * math.sin(result["phi"][-1])) <= params["T_Sp"]
    # It stuck where it turned: before the last stop the speed went through zero with
    # |T_A| <= T_Sp, and it never moved again.
    assert result["t_mode"][-1] < 30.0


def test_does_not_start_when_stiction_holds_it():
    # |T_A| = m g l sin(0.005) = 2.9e-3 N.m < T_Sp = 4e-3: held for good.
    result = swing({"phi0": math.pi + 0.005}, stop=10.0)
    assert np.all(result["phi"] == math.pi + 0.005)


def test_cart_acceleration_swings_the_pendulum():
    """A constant cart acceleration tilts the equilibrium: with phi = pi + theta,
    T_A = m l (-g sin(theta) + a cos(theta)) = 0 at tan(theta) = a/g."""
    a = 2.0
    with ComponentFMU("Pendulum", {"k_fwp": 0.05, "T_Kp": 0.0, "T_Sp": 0.0}) as pendulum:
        for _ in range(30):
            pendulum.step(1.0, inputs={"a": a})
        (phi,) = pendulum.get("phi")
    assert phi - math.pi == pytest.approx(math.atan(a / G), abs=1e-6)


def test_explicit_inertia_is_used():
    J_bob = M * L**2  # a point mass on a massless rod: period 2 pi sqrt(l/g)
    result = swing({**NO_FRICTION, "J_p": J_bob, "phi0": math.pi + 0.01}, stop=3.0, step=1e-4)
    theta, t = result["theta"], result["time"]
    up = np.nonzero((theta[:-1] < 0) & (theta[1:] >= 0))[0]
    assert np.mean(np.diff(t[up])) == pytest.approx(2 * math.pi * math.sqrt(L / G), rel=2e-4)


def test_gravity_torque_is_exact_along_a_whole_swing():
    """The FMU evaluates sin and cos of nearby angles from a memo (pendfmu/csrc/framework/trig_memo.h:
    angle addition with Taylor series of the small difference). Along a large swing, with a
    cart acceleration so that cos matters too, T_A must equal m l (g sin phi - a cos phi)
    by libm's sin and cos to a few rounding errors."""
    times = np.linspace(0.0, 3.0, 15001)
    a = 2.0
    with ComponentFMU("Pendulum", {**NO_FRICTION, "phi0": 0.5}) as pendulum:
        result = pendulum.run(times, ["phi", "T_A"], inputs=lambda t: {"a": a})
    phi = result["phi"]
    assert np.ptp(phi) > 5.0  # it falls through the bottom and back: every angle is visited
    expected = M * L * (G * np.sin(phi) - a * np.cos(phi))
    # Both sides round about a dozen times at magnitudes up to m l (g + a): allow 12 half-ulps
    # of that scale (a truncated series would be off by orders of magnitude more).
    # From the first step on (at t = 0 the input is not yet set).
    bound = 12 * np.finfo(float).eps / 2 * M * L * (G + a)
    np.testing.assert_allclose(result["T_A"][1:], expected[1:], rtol=0, atol=bound)


def classic_rk4(derivative, x, h, steps):
    """Textbook RK4 on the state vector (phi, w): the independent implementation."""
    for _ in range(steps):
        k1 = derivative(x)
        k2 = derivative(x + 0.5 * h * k1)
        k3 = derivative(x + 0.5 * h * k2)
        k4 = derivative(x + h * k3)
        x = x + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    return x


def test_the_solver_is_classic_rk4():
    """The FMU writes RK4 for a joint in its Nystrom form (stage positions from the speed and
    the earlier accelerations). That is the same method: over 100 communication steps of
    0.2 ms (200 internal steps of 0.1 ms) of a sliding swing under a constant cart
    acceleration, it matches textbook RK4 to rounding. A slip in one stage coefficient (the
    h^2/4 of the third stage taken as h^2/2) moves the angle by 4e-11 rad, 400 times the bound."""
    k, T_K, a = 1e-3, 2e-3, 0.7
    start = np.array([math.pi + 0.6, -0.5])  # sliding backward all along: no event

    def derivative(x, mode=-1):
        return np.array([x[1], (M * L * (G * math.sin(x[0]) - a * math.cos(x[0])) - k * x[1] - T_K * mode) / J])

    with ComponentFMU("Pendulum", {"phi0": start[0], "w0": start[1], "k_fwp": k, "T_Kp": T_K}) as pendulum:
        for _ in range(100):
            pendulum.step(2e-4, {"a": a})
        phi, w, mode = pendulum.get("phi", "w", "mode")
    assert mode == -1
    reference = classic_rk4(derivative, start, 1e-4, 200)
    assert abs(phi - reference[0]) < 1e-13 and abs(w - reference[1]) < 1e-12

    def slipped(x, h=1e-4):  # the Nystrom form with the third stage's h^2/4 taken as h^2/2
        p, v = x
        f = lambda p_, v_: derivative(np.array([p_, v_]))[1]  # noqa: E731
        f1 = f(p, v)
        f2 = f(p + h / 2 * v, v + h / 2 * f1)
        f3 = f(p + h / 2 * v + h * h / 2 * f1, v + h / 2 * f2)
        f4 = f(p + h * v + h * h / 2 * f2, v + h * f3)
        return np.array([p + h * v + h * h / 6 * (f1 + f2 + f3), v + h / 6 * (f1 + 2 * f2 + 2 * f3 + f4)])

    x = start
    for _ in range(200):
        x = slipped(x)
    assert abs(x[0] - reference[0]) > 1e-11  # so the bound above would see such a slip
