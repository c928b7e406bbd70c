"""Tests of the reference simulator itself, against analytic results only.

tests/reference_rig.py is the yardstick for the C FMUs and the co-simulation master, so
before it can judge them it must be shown right on cases with known answers: the
paper's Fig. 3 friction test, the current-loop step response, pendulum periods, Coulomb
decay, stiction, exact momentum/energy balances of the coupled (eta > 0.5) system.
"""

from __future__ import annotations

import math
import os
import sys

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.special import ellipk

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import reference_rig as rr  # noqa: E402
from reference_rig import (  # noqa: E402
    Steps, current_step_response, invariants, simulate_cart, simulate_current_loop,
    simulate_pendulum, simulate_rig,
)

NO_FRICTION = dict(k_fwc=0.0, F_Kc=0.0, F_Sc=0.0, k_fwp=0.0, T_Kp=0.0, T_Sp=0.0)


def _trapz_cumulative(y, t):
    """Cumulative trapezoid integral (starts at 0)."""
    out = np.zeros_like(y)
    out[1:] = np.cumsum(0.5 * (y[1:] + y[:-1]) * np.diff(t))
    return out


# ----------------------------------------------------------------- Fig. 3 (friction law)

FIG3 = dict(eta=1.0, k_M=1.0, k_D=1.0, m_c=0.5, m_p=0.0, k_fwc=2.0, F_Kc=0.3, F_Sc=0.8)
OMEGA3 = 2 * math.pi / 0.63
T_BREAK3 = 0.63 * math.asin(0.8) / (2 * math.pi)


def _fig3(t_end=1.26, n=2521):
    t = np.linspace(0.0, t_end, n)
    return simulate_cart(FIG3, lambda s: math.sin(OMEGA3 * s), t)


def _fig3_slide(t, t0, v0, direction):
    """Closed form of 0.5 v' = sin(w t) - 2 v - 0.3*direction from v(t0) = v0: (x - x0, v)."""
    M, k, FK, w = 0.5, 2.0, 0.3 * direction, OMEGA3
    lam = k / M
    den = M * (lam ** 2 + w ** 2)

    def vp(s):
        return -FK / k + (lam * np.sin(w * s) - w * np.cos(w * s)) / den

    def P(s):  # an antiderivative of vp without the constant part
        return (-lam * np.cos(w * s) / w - np.sin(w * s)) / den

    C = v0 - vp(t0)
    e = np.exp(-lam * (t - t0))
    v = C * e + vp(t)
    dx = C * (1 - e) / lam - FK / k * (t - t0) + P(t) - P(t0)
    return dx, v


def test_fig3_breakaway_time():
    """The mass is stuck until sin(2 pi t/0.63) exceeds F_S = 0.8 N (the paper's Fig. 3, in
    docs/user-guide/model.md)."""
    df = _fig3()
    ev = df.attrs["events"]
    assert ev[0].joint == "cart" and (ev[0].old, ev[0].new) == (0, 1)
    assert abs(ev[0].time - T_BREAK3) < 1e-7
    assert abs(ev[0].time - T_BREAK3) < 1e-12  # measured: ~4e-17 s
    before = df[df.time < ev[0].time]
    assert (before.x == 0).all() and (before.v == 0).all() and (before.a == 0).all()


def test_fig3_slide_matches_closed_form_and_pattern_repeats():
    """First slide against the closed-form solution of the linear ODE; then the mass
    rests around each reversal and breaks away again whenever |F| crosses 0.8 N."""
    df = _fig3()
    ev = df.attrs["events"]
    # the stop: first zero of the closed-form speed after breakaway
    t_stop = brentq(lambda s: _fig3_slide(s, T_BREAK3, 0.0, +1)[1], T_BREAK3 + 1e-3, 0.63,
                    xtol=1e-15)
    assert (ev[1].joint, ev[1].old, ev[1].new) == ("cart", 1, 0)
    assert abs(ev[1].time - t_stop) < 1e-12  # measured: ~3e-16 s
    # at the stop |F| <= F_S, so it sticks (not reverses)
    assert abs(math.sin(OMEGA3 * t_stop)) <= 0.8
    sl = df[(df.time > T_BREAK3) & (df.time < t_stop)]
    dx, v = _fig3_slide(sl.time.to_numpy(), T_BREAK3, 0.0, +1)
    assert np.max(np.abs(sl.v.to_numpy() - v)) < 1e-12  # measured: ~6e-16 m/s
    assert np.max(np.abs(sl.x.to_numpy() - dx)) < 1e-12
    # it rests till the force passes -0.8 N, then the same again with signs swapped,
    # and the pattern is periodic with the forcing from then on
    expected = [(T_BREAK3, 0, 1), (t_stop, 1, 0), (0.315 + T_BREAK3, 0, -1),
                (0.315 + t_stop, -1, 0), (0.63 + T_BREAK3, 0, 1), (0.63 + t_stop, 1, 0),
                (0.945 + T_BREAK3, 0, -1)]
    assert len(ev) == len(expected)
    for e, (te, old, new) in zip(ev, expected):
        assert (e.old, e.new) == (old, new)
        assert abs(e.time - te) < 1e-12
    x_stop = df.x[df.time.between(t_stop + 1e-3, 0.315 + T_BREAK3 - 1e-3)]
    assert np.ptp(x_stop) == 0.0
    assert abs(x_stop.iloc[0] - _fig3_slide(t_stop, T_BREAK3, 0, 1)[0]) < 1e-12


# ------------------------------------------------------------------------- current loop

def test_current_step_ramp_then_exponential():
    """Slew at dIdt_max till |I_c - I| = T_i dIdt_max, then exponential with T_i."""
    p = dict(T_i=0.3e-3, dIdt_max=2500.0)
    D = 0.75
    t = np.linspace(0, 20e-3, 8001)  # the last command holds for 40 T_i
    steps = Steps([0.0, 4e-3, 8e-3], [2.0, -3.0, -2.8])  # last step is smaller than D
    df = simulate_current_loop(p, steps, t)
    # analytic, piece by piece, each piece starting where the previous ended
    ref = np.empty_like(t)
    I0 = 0.0
    corners = []
    for k, (ts, Ic) in enumerate(zip(steps.times, steps.values)):
        te = steps.times[k + 1] if k + 1 < steps.times.size else t[-1] + 1
        m = (t >= ts) & (t < te)
        ref[m] = current_step_response(t[m] - ts, I0, Ic, 0.3e-3, 2500.0)
        if abs(Ic - I0) > D:
            corners.append(ts + (abs(Ic - I0) - D) / 2500.0)
        I0 = float(current_step_response(te - ts, I0, Ic, 0.3e-3, 2500.0))
    err = np.max(np.abs(df.I.to_numpy() - ref))
    assert err < 1e-9, err
    # mode changes: slew on at the step times with large steps, corners located exactly
    ev = df.attrs["events"]
    slews_off = [e.time for e in ev if e.new == 0]
    assert len(slews_off) == len(corners) == 2
    assert np.max(np.abs(np.array(slews_off) - corners)) < 1e-12
    # (the initial mode is in mode_I, not an event)
    assert [(e.time, e.new) for e in ev if e.new != 0] == [(4e-3, -1)]
    assert df.mode_I.iloc[0] == 1
    # the final value is the command, to the accuracy of the integrator
    assert abs(df.I.iloc[-1] - (-2.8)) < 1e-10
    # ramp slope exactly dIdt_max
    r = df[(df.time > 0) & (df.time < corners[0])]
    assert np.allclose(r.I, 2500.0 * r.time, rtol=0, atol=1e-12)


def test_current_loop_input_forms_and_harmonic():
    """A callable, a float and (time, value) pairs give the same response; the PWM
    ripple a_h sin(2 pi f_h t + phase_h) is added on top of the lag's output."""
    p = dict(a_h=0.05, f_h=1000.0, phase_h=0.3)
    t = np.linspace(0, 3e-3, 601)
    ref = current_step_response(t, 0.2, 1.5, 0.3e-3, 2500.0)
    ripple = 0.05 * np.sin(2 * math.pi * 1000.0 * t + 0.3)
    for I_c in (lambda s: 1.5, 1.5, [(0.0, 1.5)]):
        df = simulate_current_loop(p, I_c, t, I0=0.2)
        assert np.max(np.abs(df.I.to_numpy() - ripple - ref)) < 1e-9
    with pytest.raises(KeyError):
        simulate_current_loop(dict(Ti=1e-3), 1.0, t)  # a misspelt name is an error


# ---------------------------------------------------------------------------- pendulum

def _small_angle_period(p):
    J = rr._inertia(rr.rig_params(p))
    q = rr.rig_params(p)
    return 2 * math.pi * math.sqrt(J / (q["m_p"] * q["g"] * q["l"]))


def _crossings(t, y):
    """Times where y crosses 0 upward (linear interpolation)."""
    i = np.nonzero((y[:-1] < 0) & (y[1:] >= 0))[0]
    return t[i] - y[i] * (t[i + 1] - t[i]) / (y[i + 1] - y[i])


@pytest.mark.parametrize("J_p", [0.0, 0.05])
def test_pendulum_small_angle_period(J_p):
    """Frictionless, 1 mrad about hanging: period 2 pi sqrt(J/(m g l)) (rod or given J)."""
    p = dict(NO_FRICTION, J_p=J_p)
    T = _small_angle_period(p)
    t = np.arange(0, 3.2 * T, 1e-4)
    df = simulate_pendulum(p, 0.0, t, phi0=math.pi + 1e-3)
    up = _crossings(t, df.phi.to_numpy() - math.pi)
    assert len(up) >= 2
    T_meas = np.mean(np.diff(up))
    assert abs(T_meas / T - 1) < 1e-3
    assert abs(T_meas / T - 1) < 1e-6  # measured: ~1e-8 (the amplitude correction)


def test_pendulum_large_amplitude_period_elliptic():
    """1 rad amplitude: period 4 sqrt(J/(m g l)) K(sin^2(theta0/2)) (complete elliptic)."""
    p = dict(NO_FRICTION)
    q = rr.rig_params(p)
    J = rr._inertia(q)
    T = 4 * math.sqrt(J / (q["m_p"] * q["g"] * q["l"])) * ellipk(math.sin(0.5) ** 2)
    t = np.arange(0, 2.2 * T, 1e-4)
    df = simulate_pendulum(p, 0.0, t, phi0=math.pi + 1.0)
    up = _crossings(t, df.phi.to_numpy() - math.pi)
    assert abs(np.mean(np.diff(up)) / T - 1) < 1e-7
    # and energy J w^2/2 + m g l cos(phi) is conserved
    E = 0.5 * J * df.w ** 2 + q["m_p"] * q["g"] * q["l"] * np.cos(df.phi)
    assert np.ptp(E) < 1e-9 * abs(E.iloc[0])


def test_pendulum_coulomb_decay():
    """Coulomb only: each half swing loses 2 T_K/(m g l) of amplitude (small angles);
    exactly, m g l (cos th2 - cos th1) = T_K (th1 + th2).  It sticks at the first turning
    point where m g l |sin th| <= T_S and reverses at all earlier ones."""
    TK, TS = 2e-3, 4e-3
    p = dict(k_fwp=0.0, T_Kp=TK, T_Sp=TS)
    q = rr.rig_params(p)
    mgl = q["m_p"] * q["g"] * q["l"]
    t = np.linspace(0, 6.0, 601)
    df = simulate_pendulum(p, 0.0, t, phi0=math.pi + 0.05)
    ev = df.attrs["events"]
    assert ev[0].time == 0.0 and (ev[0].old, ev[0].new) == (0, -1)  # released: falls back
    turns = [e.time for e in ev[1:]]
    assert all(e.new == -e.old for e in ev[1:-1]) and ev[-1].new == 0
    # the angles at the turning points: a second run that outputs exactly there
    tp = np.array([0.0] + turns)
    th = np.abs(simulate_pendulum(p, 0.0, tp, phi0=math.pi + 0.05).phi.to_numpy() - math.pi)
    dec = -np.diff(th)
    assert len(dec) >= 5
    assert np.max(np.abs(dec / (2 * TK / mgl) - 1)) < 0.01
    exact = mgl * (np.cos(th[1:]) - np.cos(th[:-1])) - TK * (th[1:] + th[:-1])
    assert np.max(np.abs(exact)) < 1e-12
    assert np.all(mgl * np.sin(th[:-1]) > TS) and mgl * np.sin(th[-1]) <= TS
    rest = df[df.time > turns[-1]]
    assert (rest.w == 0).all() and np.ptp(rest.phi) == 0.0 and (rest.mode_p == 0).all()


def test_pendulum_driven_by_constant_acceleration():
    """A step of cart acceleration a at t = 0.2 s: with strong viscous damping the
    pendulum settles at phi = pi + atan(a/g) (T_A = 0).  The step restarts exactly."""
    a = 3.0
    p = dict(k_fwp=0.2, T_Kp=0.0, T_Sp=0.0)
    t = np.linspace(0, 7.0, 71)
    df = simulate_pendulum(p, Steps([0.2], [a]), t)
    assert (df.phi[df.time < 0.2] == math.pi).all() and df.phi.iloc[3] != math.pi
    assert abs(df.phi.iloc[-1] - (math.pi + math.atan(a / 9.81))) < 1e-8
    assert abs(df.T_A.iloc[-1]) < 1e-8


def test_pendulum_holds_under_small_acceleration():
    """Stiction: |T_A| = m l a <= T_S keeps the hanging pendulum exactly still; a step to
    a larger a breaks it away at the step time."""
    q = rr.rig_params({})
    a_hold = 0.9 * q["T_Sp"] / (q["m_p"] * q["l"])
    a_go = 1.1 * q["T_Sp"] / (q["m_p"] * q["l"])
    t = np.linspace(0, 1.0, 101)
    df = simulate_pendulum({}, Steps([0.0, 0.5], [a_hold, a_go]), t)
    held = df[df.time < 0.5]
    assert (held.phi == math.pi).all() and (held.w == 0).all() and (held.alpha == 0).all()
    ev = df.attrs["events"]
    assert (ev[0].time, ev[0].old, ev[0].new) == (0.5, 0, 1)


# ------------------------------------------------------------------------------- cart

def test_cart_alone_startup_and_braking():
    """Experiment 2 (m_p = 0): constant drive force F from rest, then I = 0 till it stops.
    v = v_inf (1 - exp(-t k/M)); braking v = (v1 + F_K/k) exp(-tk/M) - F_K/k."""
    q = rr.rig_params(dict(m_p=0.0))
    M, k, FK = q["m_c"], q["k_fwc"], q["F_Kc"]
    F = q["eta"] * q["k_M"] * q["k_D"] * 2.0
    lam = k / M
    t = np.linspace(0, 0.6, 6001)
    df = simulate_cart(dict(m_p=0.0), Steps([0.0, 0.3], [2.0, 0.0]), t)
    vinf = (F - FK) / k
    m1 = df.time < 0.3
    v_ref = vinf * (1 - np.exp(-lam * df.time[m1]))
    x_ref = vinf * (df.time[m1] - (1 - np.exp(-lam * df.time[m1])) / lam)
    assert np.max(np.abs(df.v[m1] - v_ref)) < 1e-10
    assert np.max(np.abs(df.x[m1] - x_ref)) < 1e-10
    v1 = vinf * (1 - math.exp(-lam * 0.3))
    x1 = vinf * (0.3 - (1 - math.exp(-lam * 0.3)) / lam)
    t_stop = 0.3 + math.log((v1 + FK / k) / (FK / k)) / lam
    x_stop = x1 + (v1 + FK / k) * (1 - math.exp(-lam * (t_stop - 0.3))) / lam \
        - FK / k * (t_stop - 0.3)
    ev = df.attrs["events"]
    assert [(e.old, e.new) for e in ev] == [(0, 1), (1, 0)]
    assert ev[0].time == 0.0
    assert abs(ev[1].time - t_stop) < 1e-10
    after = df[df.time > t_stop]
    assert (after.v == 0).all() and (after.a == 0).all()
    assert np.max(np.abs(after.x - x_stop)) < 1e-10


def test_cart_stuck_below_stiction():
    """|F_A| < F_S: the cart does not move at all (x, v, a exactly 0), in the full rig."""
    q = rr.rig_params({})
    I_hold = 0.95 * q["F_Sc"] / (q["eta"] * q["k_M"] * q["k_D"])
    t = np.linspace(0, 0.5, 501)
    df = simulate_rig({}, I_hold, t)
    assert abs(df.I.iloc[-1] - I_hold) < 1e-10
    assert (df.x == 0).all() and (df.v == 0).all() and (df.a == 0).all()
    assert (df.phi == math.pi).all() and (df.w == 0).all()
    assert [e for e in df.attrs["events"] if e.joint != "current"] == []


@pytest.mark.parametrize("eta", [0.4, 0.8])
def test_rig_breakaway_during_current_ramp(eta):
    """Command step 2 A: the cart breaks away when eta k_M k_D I(t) = F_S, during the
    current ramp I = dIdt_max t, and its jump of acceleration breaks the hanging
    pendulum away at the same instant (m l a > T_S)."""
    q = rr.rig_params(dict(eta=eta))
    kF = q["eta"] * q["k_M"] * q["k_D"]
    t_b = q["F_Sc"] / kF / q["dIdt_max"]
    assert t_b < (2.0 - q["T_i"] * q["dIdt_max"]) / q["dIdt_max"]  # still in the ramp
    t = np.linspace(0, 0.05, 501)
    df = simulate_rig(dict(eta=eta), Steps([0.0], [2.0]), t)
    ev = [e for e in df.attrs["events"] if e.joint != "current"]
    assert [(e.joint, e.old, e.new) for e in ev[:2]] == [("cart", 0, 1), ("pendulum", 0, 1)]
    assert abs(ev[0].time - t_b) < 1e-12 and ev[1].time == ev[0].time
    assert (df.x[df.time < t_b] == 0).all()


def test_cart_alone_backdriven_by_given_pendulum():
    """Cart FMU inputs for eta > 0.5: F_A = eta k_M k_D I + A m l (w^2 sin - alpha cos)."""
    p = dict(eta=0.8, m_p=0.2, l=0.3, k_fwc=0.0, F_Kc=0.0, F_Sc=0.0)
    q = rr.rig_params(p)
    A = (2 * 0.8 - 1) / 0.8
    phi, w, alpha = 1.0, 2.0, -3.0
    FA = q["eta"] * q["k_M"] * q["k_D"] * 0.1 + A * 0.06 * (w * w * math.sin(phi)
                                                            - alpha * math.cos(phi))
    t = np.linspace(0, 0.1, 11)
    df = simulate_cart(p, 0.1, t, pendulum=(phi, w, alpha))
    assert np.allclose(df.F_A, FA, rtol=1e-14)
    assert np.allclose(df.x, 0.5 * FA / 3.2 * t ** 2, rtol=1e-10, atol=1e-14)


# ----------------------------------------------- coupled (eta > 0.5): invariants, balances

def _coupled_run(eta, extra=None, t_end=3.0, n=3001, I_c=0.0, initial=None):
    p = dict(NO_FRICTION, eta=eta, m_c=0.5)
    p.update(extra or {})
    ini = initial or dict(v0=0.4, phi0=2.5, w0=1.5)
    t = np.linspace(0, t_end, n)
    return p, simulate_rig(p, I_c, t, ini)


def test_eta1_conserves_true_momentum_and_energy():
    """eta = 1 (A = 1): the equations are Lagrange's for cart + pendulum, so with I = 0 and
    no friction p = M v + m l cos(phi) w and E = kinetic + m g l cos(phi) are constant."""
    p, df = _coupled_run(1.0)
    inv = invariants(df, p)
    assert np.ptp(inv.p_A) < 1e-11 * abs(inv.p_A.iloc[0])  # measured: ~1e-14
    assert np.ptp(inv.E_1) < 1e-11 * abs(inv.E_1.iloc[0])
    assert np.ptp(df.phi) > 1.0  # it really swung


def test_eta08_conserves_scaled_quantities_not_true_energy():
    """0.5 < eta < 1: p_A and E_A (the Lagrangian with the pendulum scaled by A) are
    conserved; the true energy E_1 is not (the back-drive efficiency A applies to the
    reaction in both directions of power flow)."""
    p, df = _coupled_run(0.8, n=30001)
    inv = invariants(df, p)
    assert np.ptp(inv.p_A) < 1e-11 * abs(inv.p_A.iloc[0])  # measured: ~3e-15
    assert np.ptp(inv.E_A) < 1e-11 * abs(inv.E_A.iloc[0])  # measured: ~7e-15
    assert np.ptp(inv.E_1) > 1e-3 * abs(inv.E_1.iloc[0])   # measured: 9 %
    # dE_1/dt = -(1 - A) v F_r, F_r = m l (w^2 sin - alpha cos): integrate and compare
    A = 0.75
    Fr = 0.06 * (df.w ** 2 * np.sin(df.phi) - df.alpha * np.cos(df.phi))
    lost = _trapz_cumulative(-(1 - A) * (df.v * Fr).to_numpy(), df.time.to_numpy())
    E1 = inv.E_1.to_numpy()
    assert np.max(np.abs(E1 - E1[0] - lost)) < 1e-7


def test_self_locking_screw_leaves_pendulum_energy_alone():
    """eta <= 0.5: A = 0, a frictionless unpowered cart keeps its speed and the pendulum
    (in an unaccelerated frame) keeps J w^2/2 + m g l cos(phi)."""
    p, df = _coupled_run(0.4)
    assert np.ptp(df.v) == 0.0 and (df.a == 0).all()
    Ep = 0.5 * rr._inertia(rr.rig_params(p)) * df.w ** 2 + 0.06 * 9.81 * np.cos(df.phi)
    assert np.ptp(Ep) < 1e-9 * abs(Ep.iloc[0])


def test_pendulum_friction_keeps_momentum_through_sticking():
    """dp_A/dt = eta F_u - F_F: pendulum friction is internal, so with a frictionless cart
    and I = 0, p_A stays 0 while the pendulum's Coulomb friction stops it (and the cart)."""
    p, df = _coupled_run(0.8, dict(k_fwp=0.0, T_Kp=0.01, T_Sp=0.015), t_end=8.0, n=8001,
                         initial=dict(v0=0.0, phi0=math.pi + 0.4, w0=0.0))
    inv = invariants(df, p)
    assert np.max(np.abs(inv.p_A)) < 1e-10
    ev = [e for e in df.attrs["events"] if e.joint == "pendulum"]
    assert ev[-1].new == 0 and len(ev) > 5
    rest = df[df.time > ev[-1].time]
    assert (rest.w == 0).all() and np.max(np.abs(rest.v)) < 1e-10


STICK_SLIP = [
    # cart friction comparable to the pendulum's reaction: the cart sticks, breaks away
    # and reverses without sticking; the pendulum keeps swinging
    dict(extra=dict(k_fwc=0.5, F_Kc=0.35, F_Sc=0.5, k_fwp=2e-4, T_Kp=2e-3, T_Sp=3e-3),
         theta0=0.8, I1=0.01, t_end=2.5, n=250001, pend_sticks=False),
    # both joints stick in the end: the pendulum while the cart is stuck
    dict(extra=dict(k_fwc=0.5, F_Kc=0.07, F_Sc=0.1, k_fwp=2e-4, T_Kp=0.01, T_Sp=0.02),
         theta0=0.3, I1=0.003, t_end=4.5, n=90001, pend_sticks=True),
]


@pytest.mark.parametrize("case", STICK_SLIP, ids=["cart-stick-slip", "both-stick"])
def test_coupled_stick_slip_energy_balance(case):
    """Both joints with viscous + Coulomb friction and stiction, eta = 0.8, a current
    pulse: E_A(t) - E_A(0) = int v (eta F_u - F_F) - A w T_F dt and
    p_A(t) - p_A(0) = int (eta F_u - F_F) dt hold through all the stick/slip events."""
    I_c = Steps([0.0, 0.4], [case["I1"], 0.0])
    p, df = _coupled_run(0.8, case["extra"], t_end=case["t_end"], n=case["n"], I_c=I_c,
                         initial=dict(v0=0.0, phi0=math.pi + case["theta0"], w0=0.0))
    q = rr.rig_params(p)
    A = 0.75
    ev = df.attrs["events"]
    assert sum(e.joint == "cart" and e.new == 0 for e in ev) >= 2  # it sticks, repeatedly
    assert sum(e.joint == "cart" and e.old == 0 for e in ev) >= 2  # and breaks away
    assert any(e.joint == "cart" and e.old == -e.new for e in ev)  # and reverses
    assert (ev[-1].joint, ev[-1].new) == ("pendulum", 0) or not case["pend_sticks"]
    t = df.time.to_numpy()
    dt = t[1] - t[0]
    v, w = df.v.to_numpy(), df.w.to_numpy()
    mc, mp = df.mode_c.to_numpy(), df.mode_p.to_numpy()
    # friction: the sliding law, or while stuck whatever holds the joint (= its active force)
    FF = np.where(mc != 0, q["k_fwc"] * v + q["F_Kc"] * mc, df.F_A.to_numpy())
    TF = np.where(mp != 0, q["k_fwp"] * w + q["T_Kp"] * mp, df.T_A.to_numpy())
    Fu = q["eta"] * q["k_M"] * q["k_D"] * df.I.to_numpy()
    inv = invariants(df, p)
    dE = _trapz_cumulative(v * (Fu - FF) - A * w * TF, t)
    dp = _trapz_cumulative(Fu - FF, t)
    # the integrand of E_A is continuous (friction jumps only where v = 0), so trapezoids
    # are O(dt^2); that of p_A jumps at each event, which costs O(dt * jump) there
    assert np.max(np.abs(inv.E_A.to_numpy() - inv.E_A.iloc[0] - dE)) < 1e-8
    jumps = len(ev) * dt * 2 * q["F_Sc"]
    assert np.max(np.abs(inv.p_A.to_numpy() - inv.p_A.iloc[0] - dp)) < jumps
    # and without drive E_A never increases (up to integration noise)
    off = df.time > 0.4
    assert np.all(np.diff(inv.E_A[off]) < 1e-11)
    # stuck means exactly stuck
    assert (df.v[mc == 0] == 0).all() and (df.a[mc == 0] == 0).all()
    assert (df.w[mp == 0] == 0).all() and (df.alpha[mp == 0] == 0).all()
    # a stuck joint holds a force within its threshold
    assert np.all(np.abs(df.F_A[mc == 0]) <= q["F_Sc"] + 1e-12)
    assert np.all(np.abs(df.T_A[mp == 0]) <= q["T_Sp"] + 1e-12)


def test_breakaway_threshold_is_max_of_stiction_and_coulomb():
    """F_S < F_K: a joint at rest moves only once |F_A| > F_K (it could not keep moving
    earlier), so the Fig. 3 mass with F_S = 0.2 N, F_K = 0.3 N breaks away at asin(0.3)."""
    t = np.linspace(0.0, 0.3, 301)
    df = simulate_cart(dict(FIG3, F_Sc=0.2), lambda s: math.sin(OMEGA3 * s), t)
    ev = df.attrs["events"]
    assert (ev[0].old, ev[0].new) == (0, 1)
    assert abs(ev[0].time - 0.63 * math.asin(0.3) / (2 * math.pi)) < 1e-12
