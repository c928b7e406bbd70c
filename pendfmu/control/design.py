"""The design: from identified rig values to the controller's gains and settings.

Balance is a discrete LQR on the linearization about upright, sampled at T_s with the
command held (zero-order hold), the current loop's lag included. Why LQR: the controller
holds two outputs (x, phi) with one input, from estimated states; LQR gives a stabilizing
gain on all five states at once from weights that read as the requirements (how far the
cart may wander, how far the pendulum may lean, how hard the motor may work), where pole
placement would ask for five poles chosen by hand with no handle on the current's RMS.

- A self-locking screw (eta <= 0.5, A = 0): the pendulum cannot push the cart, so the cart
  is an acceleration-commanded axis: the LQR commands an acceleration and the controller
  turns it into a current by inverting the identified cart model (plant.RigModel.cart_force).
- A back-drivable screw: the LQR acts on the coupled model with the current as its input.

The state estimator is a steady-state Kalman filter on the same linearization, its
measurement noise the encoders' quantization (a reading rounded to steps of delta has
variance delta^2/12), its process noise the force and torque the model misses (friction).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Mapping

import numpy as np
from scipy.linalg import solve_discrete_are

from pendfmu.control.plant import RigModel, discretize

ENCODER_COUNTS = 1024  # the paper's encoders, both (docs/user-guide/model.md), when no sidecar tells the resolution


@dataclass(frozen=True)
class Weights:
    """LQR weights as scales: how much of each error costs as much as the others (Bryson's
    rule). A larger scale tolerates more of it.

    Attributes
    ----------
    x : float
        The cart's position error [m].
    phi : float
        The pendulum's angle from upright [rad].
    v : float
        The cart's speed [m/s].
    w : float
        The pendulum's angular rate [rad/s].
    a : float
        The cart's acceleration [m/s^2]: the input's weight (on a back-drivable screw the
        current that gives it, eta k_F / M per m/s^2).
    """

    x: float = 0.02
    phi: float = 0.01
    v: float = 0.5
    w: float = 1.0
    a: float = 1.0

    def text(self) -> str:
        """The weights as `pendfmu control --weights` takes them, for notes that say how to
        design with them again.

        Returns
        -------
        str
            "x=0.02 phi=0.01 v=0.5 w=1 a=1", three significant digits each.
        """
        return " ".join(f"{name}={getattr(self, name):.3g}" for name in ("x", "phi", "v", "w", "a"))


@dataclass(frozen=True)
class Options:
    """What the user chooses for a design (`pendfmu control`'s options).

    Attributes
    ----------
    task : str
        "balance" (from near upright) or "swing-up" (from hanging, then balance).
    T_s : float
        The sample period [s].
    I_max : float
        The current limit [A].
    x_max : float
        The track's half-length [m]: the swing-up brakes to stay within 0.9 of it.
    weights : Weights
        The LQR's weights.
    compensation : bool
        Whether the identified cart friction is compensated.
    dx, dphi : float or None
        The encoders' resolutions [m, rad] the estimator is designed for (None: the paper's
        1024-count encoders).
    sigma_F, sigma_T : float
        The estimator's process noise: the force [N] and torque [N m] the model misses.
    """

    task: str = "balance"
    T_s: float = 1e-3
    I_max: float = 5.0
    x_max: float = 0.4
    weights: Weights = field(default_factory=Weights)
    compensation: bool = True
    dx: float | None = None
    dphi: float | None = None
    sigma_F: float = 2.0
    sigma_T: float = 0.02


@dataclass(frozen=True)
class Design:
    """Everything the controller runs with, as flat numbers (the RigController FMU's parameters).

    Attributes
    ----------
    rig : RigModel
        The identified rig the design is for.
    T_s, I_max, x_max : float
        The options' sample period [s], current limit [A] and track half-length [m].
    swing_up : bool
        Whether the task swings up from hanging before balancing.
    compensation : bool
        Whether the identified cart friction is compensated.
    axis : bool
        The LQR commands the cart's acceleration (a self-locking screw) rather than the current.
    K : tuple of float
        The LQR gains on (x - x_ref, v, phi, w, a or I).
    L : tuple of (float, float)
        The estimator's gains (5 x 2) on the innovations of x and phi.
    k_E : float
        The swing-up's energy gain [m/s^2].
    a_swing : float
        The swing-up's acceleration limit [m/s^2].
    k_xs, k_vs : float
        The swing-up's centring gains [1/s^2, 1/s].
    phi_catch : float
        The angle from upright within which balance takes over [rad] (and lets go at twice it).
    v_stuck : float
        The speed below which the cart counts as stuck [m/s].
    F_ramp : float
        The wanted force over which the breakaway compensation builds up to F_Sc [N]; below
        it a stuck self-locking cart holds itself while balancing (law.Controller.holds).
    dx, dphi : float
        The encoders' steps the estimator was designed for [m, rad] (verify.py emulates them).
    x_quantum, phi_quantum : float
        The steps the inputs are rounded to before use [m, rad]; 0: as given (on the rig,
        whose readings are counts already).
    """

    rig: RigModel
    T_s: float
    I_max: float
    x_max: float
    swing_up: bool
    compensation: bool
    axis: bool
    K: tuple[float, ...]
    L: tuple[tuple[float, float], ...]
    k_E: float
    a_swing: float
    k_xs: float
    k_vs: float
    phi_catch: float
    v_stuck: float
    F_ramp: float
    dx: float  # the encoders' steps the estimator was designed for [m, rad] (verify.py emulates them)
    dphi: float
    # the inputs rounded to these steps before use (0: as given): the encoders, emulated when
    # the loop is closed on a continuous model (verify.py); the rig's readings are counts already
    x_quantum: float = 0.0
    phi_quantum: float = 0.0


def lqr_gain(Phi: np.ndarray, Gamma: np.ndarray, Q: np.ndarray, R: np.ndarray) -> np.ndarray:
    """The discrete LQR's gain K (u = -K s) from the Riccati equation's solution."""
    P = solve_discrete_are(Phi, Gamma, Q, R)
    return np.linalg.solve(R + Gamma.T @ P @ Gamma, Gamma.T @ P @ Phi)


def balance_gain(rig: RigModel, options: Options) -> tuple[bool, np.ndarray]:
    """(axis, K): the LQR on the acceleration-commanded axis for a self-locking screw, on the
    coupled model with the current as input otherwise; the input's weight is the same cart
    acceleration in both (a current of eta k_F / M per m/s^2)."""
    w = options.weights
    Q = np.diag([1 / w.x**2, 1 / w.v**2, 1 / w.phi**2, 1 / w.w**2, 0.0])
    if rig.self_locking:
        A, B = rig.axis_linear()
        R = np.array([[1 / w.a**2]])
    else:
        A, B = rig.linear()
        R = np.array([[(rig.eta * rig.k_F / rig.M / w.a) ** 2]])
    Phi, Gamma = discretize(A, B, options.T_s)
    return rig.self_locking, lqr_gain(Phi, Gamma, Q, R)[0]


def estimator_gain(rig: RigModel, options: Options, dx: float, dphi: float) -> np.ndarray:
    """The steady-state Kalman gain L (5 x 2) of the corrected estimate s + L (y - C s)."""
    A, B = rig.linear()
    Phi, _ = discretize(A, B, options.T_s)
    G = np.zeros((5, 2))
    G[1, 0], G[3, 1] = 1 / rig.M, 1 / rig.J
    Qd = G @ np.diag([options.sigma_F**2, options.sigma_T**2]) @ G.T * options.T_s
    C = np.zeros((2, 5))
    C[0, 0] = C[1, 2] = 1.0
    Rd = np.diag([dx**2 / 12, dphi**2 / 12])
    P = solve_discrete_are(Phi.T, C.T, Qd, Rd)
    return P @ C.T @ np.linalg.inv(C @ P @ C.T + Rd)


def design(parameters: Mapping[str, float], options: Options = Options()) -> Design:
    """The controller for an identified rig.

    Parameters
    ----------
    parameters : Mapping[str, float]
        Every rig parameter by its name in the model page (a fit result's values, as
        fromfit.rig_values gives them).
    options : Options
        The task, limits, weights and encoders.

    Returns
    -------
    Design
        The gains and settings, ready for law.Controller or the RigController FMU.
    """
    rig = RigModel.from_parameters(parameters)
    dx = options.dx or 2 * math.pi / (ENCODER_COUNTS * parameters["k_D"])
    dphi = options.dphi or 2 * math.pi / ENCODER_COUNTS
    axis, K = balance_gain(rig, options)
    L = estimator_gain(rig, options, dx, dphi)
    a_drive = (rig.eta * rig.k_F * options.I_max - rig.F_Sc) / rig.M  # what the current limit leaves
    return Design(rig=rig, T_s=options.T_s, I_max=options.I_max, x_max=options.x_max,
                  swing_up=options.task == "swing-up", compensation=options.compensation, axis=axis,
                  K=tuple(float(k) for k in K), L=tuple((float(r[0]), float(r[1])) for r in L),
                  k_E=20.0, a_swing=min(6.0, 0.5 * a_drive), k_xs=8.0, k_vs=6.0, phi_catch=0.3,
                  v_stuck=5e-3, F_ramp=3.0, dx=dx, dphi=dphi)
