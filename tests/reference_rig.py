"""An independent, event-driven reference simulator of the pendulum rig (tests only).

Why this file exists
--------------------
The C FMUs and the co-simulation master are judged against it. It is therefore written
from the physics spec (``docs/user-guide/model.md``) alone, in plain Python, with a
different numerical strategy from a fixed-step FMU: a variable-step Runge-Kutta integrator
(``scipy.integrate.solve_ivp``, DOP853 at rtol 1e-10) that is *stopped at every mode
change* (a located event) and restarted with the new modes.  Between events the right
hand side is smooth, so the integrator's accuracy is its nominal one, and the event times
are found by root finding on the dense output (to ~1e-15 s when the event function
depends on time only, to ~rtol otherwise).

The paper's model (SI units)
----------------------------
Current loop:  dI/dt = dIdt_max * sat((I_c - I)/(T_i*dIdt_max)); measured output I + a_h*sin(...);
               the cart is driven by the ripple-free I
Cart:          (m_c + m_p) a = F_A - F_F
               F_A = eta*k_M*k_D*I + A*m_p*l*(w^2 sin(phi) - alpha cos(phi)),
               A = max(0, (2 eta - 1)/eta)
Pendulum:      J alpha = T_A - T_F,   T_A = m_p*l*(g sin(phi) - a cos(phi)),
               J = J_p, or (4/3) m_p l^2 (a uniform rod) when J_p == 0
Friction (each joint; speed s, active force F):
               sliding: F_F = k_fw*s + F_K*mode            (mode = +1 / -1)
               stuck:   s = 0, acceleration = 0, the joint holds any |F| <= threshold
               threshold = max(F_S, F_K)   (with F_S < F_K the joint cannot move before
               |F| > F_K: it would decelerate at once and stop again)
Friction extras (docs/user-guide/friction.md, "Friction law extras"; all 0 = off, the paper's law above):
               an offset F_O (F_Oc, T_Op) acts beside F: the joint sees F_N = F + F_O,
               in the equation of motion and in the stick test;
               in direction d = mode the viscous coefficient is k_fw + d*dk_fw and the
               Coulomb level F_K(d) = F_K + d*dF_K; Stribeck (v_S > 0) adds
               d*(F_S - F_K(d))*exp(-(s/v_S)^2); quadratic drag adds drag*s*|s|;
               stuck while -max(F_S, F_K(-1)) <= F_N <= max(F_S, F_K(+1))
Drives (docs/user-guide/drives.md; all off by default: k_u = k_emf = tau_e = 0, eta_back = -1):
               the motor force is F_u = k_M*k_D*I + F_cmd with the command path
               F_cmd = k_u*u - k_emf*v (tau_e = 0), or the lag state F_e with
               tau_e*dF_e/dt = k_u*u - k_emf*v - F_e, F_e(0) = 0 (tau_e > 0);
               F_A = eta*F_u + A*m_p*l*(...); A = A(eta) for eta_back = -1, else eta_back

Modes and events
----------------
* current loop: mode +1 / -1 = slewing at +-dIdt_max, 0 = linear first-order lag.  The
  corner is the event ``|I_c - I| = T_i*dIdt_max``.
* each joint with Coulomb friction: +1 / -1 sliding, 0 stuck.  Events: the speed reaches
  0 while sliding (-> stuck if the force it must then hold is within the threshold, else
  reverse), and ``|active force| = threshold`` while stuck (-> slide in the direction of
  the force).  A joint without Coulomb friction (F_S = F_K = 0) has no modes.
* piecewise-constant inputs (:class:`Steps`) restart the integration exactly at the step
  times; the modes are re-resolved there (a jump of a given current can break a stuck
  cart away at that instant).

For eta > 0.5 the cart and pendulum accelerations depend on each other.  For given modes
the equations are linear in (a, alpha)::

    [ M          A m l cos(phi) ] [a    ]   [ eta F_u + A m l w^2 sin(phi) - F_F ]
    [ m l cos(phi)     J        ] [alpha] = [ m l g sin(phi)               - T_F ]

(M = m_c + m_p, m = m_p) and are solved in closed form at every right-hand-side call.  A
stuck joint drops its row (its acceleration is 0; its friction is whatever holds it), and
its "force to hold" is the active force computed with that zero acceleration.  The
determinant M J - A m^2 l^2 cos^2 is positive for any physical rod or bob (J >= m l^2,
A <= 1), so the 2x2 "friction LCP" has a P-matrix and the mode choice at a restart is
unique; it is found by trying the candidate modes (stuck first) and keeping the first
combination that is self-consistent.

Conserved quantities (derived here, checked in tests/test_reference_rig.py)
----------------------------------------------------------------------------
With I = 0 and no friction the equations are the Euler-Lagrange equations of

    L_A = 1/2 M v^2 + A m l cos(phi) v w + 1/2 A J w^2 - A m g l cos(phi)

(i.e. the pendulum equation multiplied by A).  Hence, for A > 0,

    p_A = M v + A m l cos(phi) w                                (cart "momentum")
    E_A = 1/2 M v^2 + A m l cos(phi) v w + A (1/2 J w^2 + m g l cos(phi))

are conserved.  For eta = 1 (A = 1) these are the true momentum and mechanical energy
of cart + pendulum.  For 0.5 < eta < 1 the true energy E_1 is NOT conserved:
dE_1/dt = -(1 - A) v F_r with F_r = m l (w^2 sin(phi) - alpha cos(phi)) the pendulum's
reaction on the cart; the model applies the back-drive efficiency A to the reaction
whatever the direction of power flow, so E_1 falls while the pendulum back-drives the
cart (v F_r > 0) and *rises* while the cart moves against the reaction.  With friction
and a current, dE_A/dt = v (eta F_u - F_F) - A w T_F and dp_A/dt = eta F_u - F_F, so E_A
never increases under friction alone, and pendulum friction leaves p_A unchanged.
See :func:`invariants`.
"""

from __future__ import annotations

import math
from itertools import product
from typing import Callable, NamedTuple, Sequence

import numpy as np
import pandas as pd
from scipy.integrate import solve_ivp

NEGLIGIBLE_RATE = 1e-100  # A/s: a current's rate below this is 0 (rhs)

__all__ = [
    "DEFAULTS",
    "INITIAL_DEFAULTS",
    "Event",
    "Steps",
    "rig_params",
    "simulate_rig",
    "simulate_current_loop",
    "simulate_cart",
    "simulate_pendulum",
    "current_step_response",
    "invariants",
]

#: The reference rig (docs/user-guide/model.md); J_p = 0 means "a uniform rod": J = (4/3) m_p l^2.
DEFAULTS: dict[str, float] = dict(
    # current loop
    T_i=0.3e-3, dIdt_max=2500.0, a_h=0.0, f_h=0.0, phase_h=0.0,
    # cart
    k_M=0.06, k_D=628.3, eta=0.4, m_c=3.0, m_p=0.2, l=0.3,
    k_fwc=30.0, F_Kc=8.0, F_Sc=12.0,
    # pendulum
    J_p=0.0, g=9.81, k_fwp=1e-3, T_Kp=2e-3, T_Sp=4e-3,
    # friction extras, all off (docs/user-guide/friction.md)
    v_Sc=0.0, dk_fwc=0.0, dF_Kc=0.0, F_Oc=0.0,
    w_Sp=0.0, dk_fwp=0.0, dT_Kp=0.0, T_Op=0.0, k_dp=0.0,
    # drives beyond the paper's model, all off (docs/user-guide/drives.md)
    k_u=0.0, k_emf=0.0, tau_e=0.0, eta_back=-1.0,
)
#: Initial states (x0, v0 are Cart parameters, phi0, w0 Pendulum ones in the paper's model).
INITIAL_DEFAULTS: dict[str, float] = dict(x0=0.0, v0=0.0, phi0=math.pi, w0=0.0, I0=0.0)

_COLUMNS_RIG = ["time", "I_c", "I", "x", "v", "a", "F_A", "phi", "w", "alpha", "T_A", "F_e",
                "mode_I", "mode_c", "mode_p"]


class Event(NamedTuple):
    """One mode change: ``joint`` is 'current', 'cart' or 'pendulum'.

    Modes: joints +1 / -1 sliding forward / backward, 0 stuck; current loop +1 / -1
    slewing up / down at dIdt_max, 0 linear lag.  A sliding joint that reverses at a
    zero crossing of its speed is one event from +1 to -1 (or back).
    """

    time: float
    joint: str
    old: int
    new: int


# --------------------------------------------------------------------------- inputs

class Steps:
    """A piecewise-constant signal: ``values[k]`` holds on ``[times[k], times[k+1])``.

    Before ``times[0]`` the value is ``before``.  The simulators restart the integration
    exactly at each step time, so a jump never falls inside an integration step.
    """

    def __init__(self, times: Sequence[float], values: Sequence[float], before: float = 0.0):
        self.times = np.asarray(times, dtype=float).ravel()
        self.values = np.asarray(values, dtype=float).ravel()
        if self.times.shape != self.values.shape or self.times.size == 0:
            raise ValueError("Steps needs equally many (>= 1) times and values")
        if np.any(np.diff(self.times) <= 0):
            raise ValueError("Steps times must be strictly increasing")
        self.before = float(before)

    @classmethod
    def from_pairs(cls, pairs: Sequence[tuple[float, float]], before: float = 0.0) -> "Steps":
        t, v = zip(*pairs)
        return cls(t, v, before)

    def __call__(self, t: float) -> float:
        k = int(np.searchsorted(self.times, t, side="right")) - 1
        return self.before if k < 0 else float(self.values[k])

    @property
    def breakpoints(self) -> tuple[float, ...]:
        return tuple(float(b) for b in self.times)


class _Signal:
    """An input: a constant, a :class:`Steps`, a list of (time, value) pairs or a callable.

    ``on_segment(t0, t1)`` returns a callable valid on the closed segment [t0, t1]
    between two breakpoints: for steps the constant value that holds from t0 on; for a
    callable the callable itself, but evaluated just left of t1 at t1 so that a jump a
    user declared as a breakpoint never leaks into the segment before it.
    """

    def __init__(self, src, breakpoints: Sequence[float] = ()):
        self.const = None
        self.steps = None
        self.fn = None
        if isinstance(src, Steps):
            self.steps = src
        elif callable(src):
            self.fn = src
        elif isinstance(src, (list, tuple)) and src and isinstance(src[0], (list, tuple)):
            self.steps = Steps.from_pairs(src)
        else:
            self.const = src  # a float, or a tuple for the pendulum signals
        self.breakpoints = tuple(breakpoints) + (self.steps.breakpoints if self.steps else ())

    def on_segment(self, t0: float, t1: float) -> Callable[[float], object]:
        if self.const is not None:
            c = self.const
            return lambda t: c
        if self.steps is not None:
            c = self.steps(t0)
            return lambda t: c
        fn = self.fn
        t_left = float(np.nextafter(t1, -np.inf))
        return lambda t: fn(t if t < t1 else t_left)


class _Inputs:
    """The segment-wise input callables (Ic, I, a, pend, u); None where not used."""

    def __init__(self, signals: dict[str, _Signal], t0: float, t1: float):
        for name in ("Ic", "I", "a", "pend", "u"):
            sig = signals.get(name)
            setattr(self, name, sig.on_segment(t0, t1) if sig is not None else None)


# ------------------------------------------------------------------------ parameters

def rig_params(params: dict | None = None) -> dict[str, float]:
    """The reference rig updated with ``params`` (unknown names are an error)."""
    p = dict(DEFAULTS)
    for k, v in (params or {}).items():
        if k not in DEFAULTS and k not in INITIAL_DEFAULTS:
            raise KeyError(f"unknown rig parameter {k!r}")
        p[k] = float(v)
    return p


def _inertia(p: dict) -> float:
    return p["J_p"] if p["J_p"] > 0 else 4.0 / 3.0 * p["m_p"] * p["l"] ** 2


def _backdrive(eta: float, eta_back: float = -1.0) -> float:
    if eta_back >= 0:
        return eta_back
    return max(0.0, (2.0 * eta - 1.0) / eta) if eta > 0 else 0.0


class _Joint:
    """Friction law of one joint (cart: k_fwc, F_Kc, F_Sc; pendulum: k_fwp, T_Kp, T_Sp),
    with the extras: Stribeck speed v_S, asymmetries dk_fw and dF_K, offset F_O, drag."""

    def __init__(self, k_fw: float, F_K: float, F_S: float, *, v_S: float = 0.0, dk_fw: float = 0.0,
                 dF_K: float = 0.0, F_O: float = 0.0, drag: float = 0.0):
        if F_K < 0 or F_S < 0 or abs(dF_K) > F_K or abs(dk_fw) > k_fw or v_S < 0:
            raise ValueError("friction levels must be >= 0 in both directions, v_S >= 0")
        self.k_fw, self.F_K, self.F_S = k_fw, F_K, F_S
        self.v_S, self.dk_fw, self.dF_K, self.F_O, self.drag = v_S, dk_fw, dF_K, F_O, drag
        self.coulomb = max(self.threshold(1), self.threshold(-1)) > 0  # else no stuck mode, no events

    def kinetic(self, direction: int) -> float:
        """The Coulomb level of a direction of motion."""
        return self.F_K + direction * self.dF_K

    def threshold(self, direction: int) -> float:
        """The net force a joint at rest holds before it slides in ``direction``."""
        return max(self.F_S, self.kinetic(direction))

    def holds(self, net: float) -> bool:
        """Whether the net force (active force plus offset) leaves a joint at rest."""
        return -self.threshold(-1) <= net <= self.threshold(1)

    def sliding(self, speed: float, mode: int) -> float:
        # A joint without stuck mode keeps mode +1; its direction is its speed's sign.
        d = mode if self.coulomb else _sgn(speed)
        force = (self.k_fw + d * self.dk_fw) * speed + self.kinetic(d) * mode
        if self.v_S > 0:
            force += mode * (self.F_S - self.kinetic(d)) * math.exp(-(speed / self.v_S) ** 2)
        return force + self.drag * speed * abs(speed)


def _sgn(x: float) -> int:
    """The paper's sgn with sgn(0) = +1."""
    return 1 if x >= 0 else -1


# ----------------------------------------------------------------------------- model

class _Rig:
    """The hybrid system.  State y = [I, x, v, phi, w, F_e] whatever the configuration
    (F_e: the drive's lagged command force, constant 0 unless tau_e > 0).

    loop=True: I is the current-loop state driven by input Ic; else I is an input.
    cart='dynamic' | 'driven' (the cart acceleration is the input ``a``: pendulum alone).
    pend='dynamic' | 'given' (phi, w, alpha are the input ``pend``: cart alone).
    Modes are (mode_I, mode_c, mode_p); a joint without modes keeps mode +1.
    """

    def __init__(self, p: dict, loop: bool, cart: str, pend: str):
        self.p = p
        self.loop, self.cart, self.pend = loop, cart, pend
        if loop and not p["T_i"] > 0:
            raise ValueError("T_i must be > 0")
        self.D = p["T_i"] * p["dIdt_max"]  # |I_c - I| at the slope-limit corner
        self.slew = loop and math.isfinite(p["dIdt_max"])
        self.M = p["m_c"] + p["m_p"]
        self.J = _inertia(p)
        self.ml = p["m_p"] * p["l"]
        self.A = _backdrive(p["eta"], p["eta_back"])
        self.kF = p["eta"] * p["k_M"] * p["k_D"]  # drive force per ampere, after eta
        if p["k_emf"] < 0 or p["tau_e"] < 0:
            raise ValueError("k_emf and tau_e must be >= 0")
        self.cj = _Joint(p["k_fwc"], p["F_Kc"], p["F_Sc"], v_S=p["v_Sc"], dk_fw=p["dk_fwc"],
                         dF_K=p["dF_Kc"], F_O=p["F_Oc"])
        self.pj = _Joint(p["k_fwp"], p["T_Kp"], p["T_Sp"], v_S=p["w_Sp"], dk_fw=p["dk_fwp"],
                         dF_K=p["dT_Kp"], F_O=p["T_Op"], drag=p["k_dp"])
        self.cart_modal = cart == "dynamic" and self.cj.coulomb
        self.pend_modal = pend == "dynamic" and self.pj.coulomb
        if cart == "dynamic" and not self.M > 0:
            raise ValueError("m_c + m_p must be > 0")
        if pend == "dynamic" and not self.J > 0:
            raise ValueError("the pendulum needs J > 0")
        w_h = 2 * math.pi * p["f_h"]
        a_h, ph = p["a_h"], p["phase_h"]
        self.harm = (lambda t: a_h * math.sin(w_h * t + ph)) if a_h != 0 else (lambda t: 0.0)

    # -- the algebra of one instant ------------------------------------------------
    def eval(self, t: float, y, modes, u: _Inputs):
        """(dI, I_out, a, alpha, F_A, T_A, phi, w) at (t, y) for the given modes."""
        mI, mc, mp = modes
        I_s, _x, v, phi, w, F_e = y
        p = self.p
        if self.loop:
            z = u.Ic(t) - I_s
            dI = z / p["T_i"] if mI == 0 else mI * p["dIdt_max"]
            I = I_s + self.harm(t)
            I_force = I_s  # the ripple is on the measured current; the mechanics see the mean
        else:
            dI = 0.0
            I = I_force = u.I(t)
        F_drive = self.kF * I_force + p["eta"] * self.command(t, v, F_e, u)  # eta F_u
        if self.pend == "given":
            phi, w, alpha_in = u.pend(t)
        s, c = math.sin(phi), math.cos(phi)
        ml, A = self.ml, self.A
        if self.cart == "driven":
            a = u.a(t)
            F_A = math.nan
            T_A = ml * (p["g"] * s - a * c)
            alpha = 0.0 if mp == 0 else (T_A + self.pj.F_O - self.pj.sliding(w, mp)) / self.J
        elif self.pend == "given":
            alpha = alpha_in
            F_A = F_drive + A * ml * (w * w * s - alpha * c)
            a = 0.0 if mc == 0 else (F_A + self.cj.F_O - self.cj.sliding(v, mc)) / self.M
            T_A = ml * (p["g"] * s - a * c)  # what the cart would exert on the pendulum
        else:
            F0 = F_drive + A * ml * w * w * s  # cart active force without the alpha term
            Tg = ml * p["g"] * s                   # pendulum active torque without the a term
            F0n, Tgn = F0 + self.cj.F_O, Tg + self.pj.F_O  # with the offsets: what the joints feel
            if mc != 0 and mp != 0:                # both sliding: the coupled 2x2 system
                b1 = F0n - self.cj.sliding(v, mc)
                b2 = Tgn - self.pj.sliding(w, mp)
                m12, m21 = A * ml * c, ml * c
                det = self.M * self.J - m12 * m21
                a = (self.J * b1 - m12 * b2) / det
                alpha = (self.M * b2 - m21 * b1) / det
            elif mc != 0:                          # pendulum stuck: w = alpha = 0
                alpha = 0.0
                a = (F0n - self.cj.sliding(v, mc)) / self.M
            elif mp != 0:                          # cart stuck: a = 0
                a = 0.0
                alpha = (Tgn - self.pj.sliding(w, mp)) / self.J
            else:
                a = alpha = 0.0
            F_A = F0 - A * ml * c * alpha
            T_A = Tg - ml * c * a
        return dI, I, a, alpha, F_A, T_A, phi, w

    def command(self, t: float, v: float, F_e: float, u: _Inputs) -> float:
        """The command path's force before the screw: the lag's state, or k_u u - k_emf v."""
        p = self.p
        if p["tau_e"] > 0:
            return F_e
        u_t = u.u(t) if u.u is not None else 0.0
        return p["k_u"] * u_t - p["k_emf"] * v

    def rhs(self, t, y, modes, u):
        yl = y.tolist()
        dI, _I, a, alpha, _F, _T, _phi, _w = self.eval(t, yl, modes, u)
        if abs(dI) < NEGLIGIBLE_RATE:  # a current decaying to a command held at 0 A for seconds: from about
            dI = 0.0                   # 1e-160 A on, DOP853's error estimate divided 0 by 0 (subnormal squares)
        dphi, dw = (yl[4], alpha) if self.pend == "dynamic" else (0.0, 0.0)
        p = self.p
        dF = 0.0
        if p["tau_e"] > 0:
            u_t = u.u(t) if u.u is not None else 0.0
            dF = (p["k_u"] * u_t - p["k_emf"] * yl[2] - yl[5]) / p["tau_e"]
        return [dI, yl[2], a, dphi, dw, dF]

    # -- events ----------------------------------------------------------------------
    def events(self, modes, u):
        """Terminal event functions for the current modes, each tagged with .info."""
        mI, mc, mp = modes
        evs = []

        def mk(fn, direction, info):
            fn.terminal = True
            fn.direction = direction
            fn.info = info
            evs.append(fn)

        if self.slew:
            D = self.D
            if mI == 0:
                mk(lambda t, y: u.Ic(t) - y[0] - D, +1, ("current", "slew", +1))
                mk(lambda t, y: u.Ic(t) - y[0] + D, -1, ("current", "slew", -1))
            else:
                mk(lambda t, y, m=mI: u.Ic(t) - y[0] - m * D, -mI, ("current", "lin", 0))
        # joint, modal?, mode, its speed in y, its active force in eval(), its friction law
        joints = (("cart", self.cart_modal, mc, 2, 4, self.cj), ("pendulum", self.pend_modal, mp, 4, 5, self.pj))
        for name, modal, mode, speed, force, jt in joints:
            if not modal:
                continue
            if mode != 0:
                mk(lambda t, y, i=speed: y[i], -mode, (name, "stop", None))
                continue
            # Breakaway either way: the net force (active plus offset) passes the threshold of
            # that direction (the two differ with an asymmetric Coulomb level).
            for d in (1, -1):
                mk(lambda t, y, i=force, jt=jt, d=d: d * (self.eval(t, y.tolist(), modes, u)[i] + jt.F_O)
                   - jt.threshold(d), +1, (name, "break", None))
        return evs

    # -- choosing consistent modes at a restart ----------------------------------------
    def current_mode(self, t, y, u) -> int:
        if not self.slew:
            return 0
        z = u.Ic(t) - y[0]
        return 1 if z > self.D else (-1 if z < -self.D else 0)

    def resolve(self, t, y, u, prev, event=None):
        """Modes consistent at (t, y): stuck joints hold, zero-speed sliders accelerate
        the way they slide.  ``event`` = (joint, kind, new) of the event just located.
        """
        mI = prev[0]
        if event is None:
            mI = self.current_mode(t, y, u)
        elif event[0] == "current":
            mI = event[2]
        out = self._resolve_joints(t, y, u, (mI,) + tuple(prev[1:]), event)
        if out is None and event is not None and event[1] == "break":
            out = self._resolve_joints(t, y, u, (mI,) + tuple(prev[1:]), None)
        if out is None:
            raise RuntimeError(f"no consistent friction modes at t={t!r}, y={list(y)}, "
                               f"previous modes {prev}, event {event}")
        return out

    def _resolve_joints(self, t, y, u, prev, event):
        mI = prev[0]
        forced = {}
        cand = {}
        for j, idx, modal in (("cart", 2, self.cart_modal), ("pendulum", 4, self.pend_modal)):
            pm = prev[1] if j == "cart" else prev[2]
            if not modal:
                cand[j] = [pm]
                continue
            speed = y[idx]
            if event is not None and event[0] == j and event[1] == "break":
                jt = self.cj if j == "cart" else self.pj
                force = self.eval(t, y, prev, u)[4 if j == "cart" else 5] + jt.F_O
                cand[j] = [_sgn(force)]
                forced[j] = "break"
            elif event is not None and event[0] == j and event[1] == "stop":
                cand[j] = [0, -pm]
                forced[j] = "stop"
            elif speed != 0:
                cand[j] = [_sgn(speed)]
            else:
                cand[j] = [pm] + [m for m in (0, 1, -1) if m != pm]
        for mc, mp in product(cand["cart"], cand["pendulum"]):
            modes = (mI, mc, mp)
            _dI, _I, a, alpha, F_A, T_A, _phi, _w = self.eval(t, y, modes, u)
            ok = True
            for j, idx, modal, m, acc, force, jt, pm in (
                    ("cart", 2, self.cart_modal, mc, a, F_A, self.cj, prev[1]),
                    ("pendulum", 4, self.pend_modal, mp, alpha, T_A, self.pj, prev[2])):
                if not modal or y[idx] != 0:
                    continue
                if m == 0:
                    ok = jt.holds(force + jt.F_O)
                elif forced.get(j) == "break" or (m == pm and j not in forced):
                    ok = m * acc >= 0
                else:
                    ok = m * acc > 0
                if not ok:
                    break
            if ok:
                return modes
        return None

    # -- the event loop ----------------------------------------------------------------
    def run(self, signals: dict[str, _Signal], t_eval, y0, *, method="DOP853",
            rtol=1e-10, atol=1e-12, max_step=1e-3, max_stall=20):
        """Integrate from t_eval[0] to t_eval[-1]; return (DataFrame, events)."""
        t_eval = np.asarray(t_eval, dtype=float).ravel()
        if t_eval.size == 0 or np.any(np.diff(t_eval) <= 0):
            raise ValueError("t_eval must be non-empty and strictly increasing")
        t0, tN = float(t_eval[0]), float(t_eval[-1])
        bps = sorted({float(b) for s in signals.values() for b in s.breakpoints
                      if t0 < b < tN})
        edges = bps + [tN]
        k_edge = 0
        u = _Inputs(signals, t0, edges[0])
        y = np.array(list(y0) + [0.0] * (6 - len(y0)), dtype=float)  # F_e(0) = 0 unless given
        # Before t0 a joint at rest counts as stuck, a moving one as sliding its way.
        prev0 = (self.current_mode(t0, y, u),
                 (_sgn(y[2]) if y[2] != 0 else 0) if self.cart_modal else 1,
                 (_sgn(y[4]) if y[4] != 0 else 0) if self.pend_modal else 1)
        modes = self.resolve(t0, y.tolist(), u, prev0, None)
        events: list[Event] = []
        self._record(events, t0, prev0, modes, include_current=False)
        n = t_eval.size
        rows = np.empty((n, 14))
        idx = 0
        t = t0
        stall = 0
        while t < tN:
            if t >= edges[k_edge]:  # a breakpoint: new input values, re-resolve the modes
                k_edge += 1
                u = _Inputs(signals, t, edges[k_edge])
                new_modes = self.resolve(t, y.tolist(), u, modes, None)
                self._record(events, t, modes, new_modes, include_current=True)
                modes = new_modes
                continue
            seg_end = edges[k_edge]
            evs = self.events(modes, u)
            sol = solve_ivp(lambda tt, yy, m=modes, uu=u: self.rhs(tt, yy, m, uu),
                            (t, seg_end), y, method=method, rtol=rtol, atol=atol,
                            max_step=max_step, events=evs or None, dense_output=True)
            if sol.status < 0:
                raise RuntimeError(f"integration failed at t={t}: {sol.message}")
            t1 = float(sol.t[-1])
            final = sol.status == 0 and k_edge == len(edges) - 1
            j = idx
            while j < n and (t_eval[j] < t1 or (final and t_eval[j] <= t1)):
                j += 1
            if j > idx:
                self._fill(rows, idx, t_eval[idx:j], sol.sol(t_eval[idx:j]), modes, u)
                idx = j
            y = sol.y[:, -1].copy()
            if sol.status == 0:  # reached the end of the segment
                t = t1
                continue
            fired = [e for e, te in zip(evs, sol.t_events) if te.size and te[-1] == t1]
            joint, kind, new = fired[0].info
            if kind == "stop":
                y[2 if joint == "cart" else 4] = 0.0  # exactly at rest
            if kind == "break":
                t1, y = _past_root(fired[0], sol.sol, t1, seg_end, y)
            new_modes = self.resolve(t1, y.tolist(), u, modes, (joint, kind, new))
            self._record(events, t1, modes, new_modes, include_current=True)
            stall = stall + 1 if t1 <= t else 0
            if stall > max_stall:
                raise RuntimeError(f"{stall} events without progress at t={t1} (Zeno?)")
            modes, t = new_modes, t1
        if idx < n:  # points at t_end after an event located exactly there
            self._fill(rows, idx, t_eval[idx:], np.repeat(y[:, None], n - idx, axis=1),
                       modes, u)
        df = pd.DataFrame(rows, columns=[c for c in _COLUMNS_RIG if c != "time"])
        df.insert(0, "time", t_eval)
        for c in ("mode_I", "mode_c", "mode_p"):
            df[c] = df[c].astype(int)
        return df, events

    def _fill(self, rows, i0, ts, Y, modes, u):
        for k, (t, yk) in enumerate(zip(ts, Y.T)):
            yl = yk.tolist()
            _dI, I, a, alpha, F_A, T_A, phi, w = self.eval(float(t), yl, modes, u)
            Ic = u.Ic(float(t)) if self.loop else math.nan
            rows[i0 + k] = (Ic, I, yl[1], yl[2], a, F_A, phi, w, alpha, T_A, yl[5], *modes)

    def _record(self, events, t, old, new, include_current):
        names = ("current", "cart", "pendulum")
        for k in range(3):
            if k == 0 and not include_current:
                continue
            if old[k] != new[k]:
                events.append(Event(float(t), names[k], int(old[k]), int(new[k])))


def _past_root(event, dense, t1: float, t_max: float, y):
    """A breakaway's time moved just past its root, where the net force has crossed the
    threshold (the event function > 0), as the FMU's event bracket does (its right end).

    Why: the root finder may return a time a hair before the crossing. Without Stribeck
    that does not matter (the joint then accelerates at (|F_N| - F_K)/m > 0), but with
    Stribeck the sliding friction at v = 0 equals F_S, so the acceleration there is
    (|F_N| - F_S)/m: zero at the root and of the wrong sign before it, and the joint would
    stop again at once (Zeno). Steps of 1, 2, 4, ... ulps up to 1e-12 s (the FMU's bracket)
    on the dense output; a root found on the far side is kept as it is.
    """
    if event(t1, y) > 0:
        return t1, y
    step = abs(np.spacing(t1))
    while step <= 1e-12:
        t = min(t1 + step, t_max)
        y_t = dense(t)
        if event(t, y_t) > 0:
            return t, y_t
        step *= 2
    return t1, y


# ---------------------------------------------------------------------- public API

def _solver_kw(kw: dict) -> dict:
    allowed = {"method", "rtol", "atol", "max_step", "max_stall"}
    bad = set(kw) - allowed
    if bad:
        raise TypeError(f"unexpected solver options {sorted(bad)}")
    return kw


def simulate_rig(params: dict | None = None, I_c=0.0, t_eval=None, initial: dict | None = None,
                 *, I_c_breakpoints: Sequence[float] = (), **solver) -> pd.DataFrame:
    """Simulate current loop -> cart -> pendulum (coupled both ways when eta > 0.5).

    params   the rig's names (T_i, dIdt_max, a_h, f_h, phase_h, k_M, k_D, eta, m_c, m_p, l,
             k_fwc, F_Kc, F_Sc, J_p, g, k_fwp, T_Kp, T_Sp); missing ones take the
             reference-rig defaults (:data:`DEFAULTS`).
    I_c      command current: a float, a :class:`Steps`, a list of (time, value) pairs
             (value holds from that time on; 0 before the first), or a callable t -> A
             (give ``I_c_breakpoints`` for any jumps it has).
    t_eval   output times (strictly increasing); the simulation starts at t_eval[0].
    initial  dict with x0, v0, phi0, w0, I0 (defaults 0, 0, pi, 0, 0; hanging at rest).
    solver   method ('DOP853'), rtol (1e-10), atol (1e-12), max_step (1e-3 s: keeps two
             crossings of a time-dependent event function out of one step).

    Returns a DataFrame with columns time, I_c, I, x, v, a, F_A, phi, w, alpha, T_A and
    the modes mode_I, mode_c, mode_p; ``df.attrs['events']`` is the list of
    :class:`Event` (time, joint, old, new) mode changes.  If the pendulum is absent
    (m_p = 0 and J_p = 0) phi stays at phi0 and w = alpha = 0.
    """
    p = rig_params(params)
    ini = dict(INITIAL_DEFAULTS)
    ini.update({k: p.pop(k) for k in INITIAL_DEFAULTS if k in p})
    for k, v in (initial or {}).items():
        if k not in INITIAL_DEFAULTS:
            raise KeyError(f"unknown initial state {k!r} (expected {sorted(INITIAL_DEFAULTS)})")
        ini[k] = float(v)
    absent = not _inertia(p) > 0
    if absent and ini["w0"] != 0:
        raise ValueError("a pendulum without inertia cannot have w0 != 0")
    rig = _Rig(p, loop=True, cart="dynamic", pend="given" if absent else "dynamic")
    signals = {"Ic": _Signal(I_c, I_c_breakpoints)}
    if absent:
        signals["pend"] = _Signal((float(ini["phi0"]), 0.0, 0.0))
    y0 = [ini["I0"], ini["x0"], ini["v0"], ini["phi0"], ini["w0"]]
    df, events = rig.run(signals, t_eval, y0, **_solver_kw(solver))
    df.attrs["events"] = events
    return df


def simulate_current_loop(params: dict | None, I_c, t_eval, I0: float = 0.0, *,
                          I_c_breakpoints: Sequence[float] = (), **solver) -> pd.DataFrame:
    """The CurrentLoop block alone: columns time, I_c, I (I includes the a_h harmonic),
    mode_I; attrs['events'] has the slope-limit corners."""
    p = rig_params(params)
    for k in INITIAL_DEFAULTS:
        p.pop(k, None)
    # The cart is irrelevant here: a unit mass without Coulomb friction has no events.
    p.update(F_Kc=0.0, F_Sc=0.0, m_c=1.0, m_p=0.0)
    rig = _Rig(p, loop=True, cart="dynamic", pend="given")
    signals = {"Ic": _Signal(I_c, I_c_breakpoints), "pend": _Signal((math.pi, 0.0, 0.0))}
    df, events = rig.run(signals, t_eval, [I0, 0.0, 0.0, math.pi, 0.0], **_solver_kw(solver))
    out = df[["time", "I_c", "I", "mode_I"]].copy()
    out.attrs["events"] = events
    return out


def simulate_cart(params: dict | None, I, t_eval, x0: float = 0.0, v0: float = 0.0,
                  pendulum=None, *, u=0.0, breakpoints: Sequence[float] = (),
                  **solver) -> pd.DataFrame:
    """The Cart block alone, driven by the current ``I`` (float, Steps, pairs, callable)
    and the drive command ``u`` (the same forms; used when k_u != 0, docs/user-guide/drives.md).

    ``pendulum``: for a back-drivable screw (eta > 0.5) the pendulum signals, a callable
    t -> (phi, w, alpha) or a constant tuple; None means a pendulum at rest (no force).
    Columns time, I, x, v, a, F_A, F_e, mode_c; attrs['events'] the cart's mode changes.
    """
    p = rig_params(params)
    for k in INITIAL_DEFAULTS:
        p.pop(k, None)
    rig = _Rig(p, loop=False, cart="dynamic", pend="given")
    pend = pendulum if pendulum is not None else (math.pi, 0.0, 0.0)
    signals = {"I": _Signal(I, breakpoints), "pend": _Signal(pend, breakpoints), "u": _Signal(u, breakpoints)}
    df, events = rig.run(signals, t_eval, [0.0, x0, v0, math.pi, 0.0], **_solver_kw(solver))
    out = df[["time", "I", "x", "v", "a", "F_A", "F_e", "mode_c"]].copy()
    out.attrs["events"] = [e for e in events if e.joint == "cart"]
    return out


def simulate_pendulum(params: dict | None, a, t_eval, phi0: float = math.pi, w0: float = 0.0,
                      *, breakpoints: Sequence[float] = (), **solver) -> pd.DataFrame:
    """The Pendulum block alone, driven by the cart acceleration ``a`` (float, Steps,
    pairs, callable).  Columns time, a, phi, w, alpha, T_A, mode_p; attrs['events'].
    """
    p = rig_params(params)
    for k in INITIAL_DEFAULTS:
        p.pop(k, None)
    rig = _Rig(p, loop=False, cart="driven", pend="dynamic")
    signals = {"I": _Signal(0.0), "a": _Signal(a, breakpoints)}
    df, events = rig.run(signals, t_eval, [0.0, 0.0, 0.0, phi0, w0], **_solver_kw(solver))
    out = df[["time", "a", "phi", "w", "alpha", "T_A", "mode_p"]].copy()
    out.attrs["events"] = [e for e in events if e.joint == "pendulum"]
    return out


def current_step_response(t, I0: float, I_c: float, T_i: float, dIdt_max: float) -> np.ndarray:
    """Closed-form current for a constant command I_c from I(0) = I0 (t >= 0).

    While |I_c - I| > T_i*dIdt_max the current slews at dIdt_max; from the corner on it
    approaches I_c exponentially with time constant T_i (the slope is continuous there).
    """
    t = np.asarray(t, dtype=float)
    D = T_i * dIdt_max
    e0 = I_c - I0
    sg = 1.0 if e0 >= 0 else -1.0
    t_c = max(0.0, (abs(e0) - D) / dIdt_max)  # end of the slew
    e_c = min(abs(e0), D)                      # |I_c - I| at the corner
    ramp = I0 + sg * dIdt_max * np.minimum(t, t_c)
    expo = I_c - sg * e_c * np.exp(-(t - t_c) / T_i)
    return np.where(t <= t_c, ramp, expo)


def invariants(df: pd.DataFrame, params: dict | None = None) -> pd.DataFrame:
    """p_A, E_A (conserved without current and friction, see the module docstring) and
    the plain mechanical energy E_1 of cart + pendulum, per row of a rig DataFrame."""
    p = rig_params(params)
    M, J, ml = p["m_c"] + p["m_p"], _inertia(p), p["m_p"] * p["l"]
    A = _backdrive(p["eta"], p["eta_back"])
    v, w, c = df["v"].to_numpy(), df["w"].to_numpy(), np.cos(df["phi"].to_numpy())
    pend = 0.5 * J * w ** 2 + ml * p["g"] * c
    return pd.DataFrame({
        "time": df["time"].to_numpy(),
        "p_A": M * v + A * ml * c * w,
        "E_A": 0.5 * M * v ** 2 + A * ml * c * v * w + A * pend,
        "E_1": 0.5 * M * v ** 2 + ml * c * v * w + pend,
    })
