"""The rig as the controller sees it: the paper's equations about a known state, in one place
(docs/user-guide/model.md).

Two uses need the same physics: the state estimator predicts one sample ahead with the
nonlinear equations (the swing-up runs far from upright, where a linearization about it
is wrong), and the design linearizes them about upright. The C controller
(csrc/RigController/model.c) repeats `predict` and `cart_current` operation for operation:
the FMU and this module must agree sample by sample (tests/test_control.py).

The estimator's state is s = (x, v, phi, w, I): cart position and speed, pendulum angle
(0 upright, kept within (-pi, pi]) and speed, and the motor current behind the current
loop. The cart's Coulomb friction is not in the prediction: the controller adds what it
believes the friction to be to its command (`compensation`), and tells the predictor the
force it meant, so the prediction sees the friction cancelled, or, with compensation off,
a cart without Coulomb friction (the design that ignores it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping

import numpy as np
from scipy.linalg import expm

from pendfmu.components import back_drive_efficiency
from pendfmu.physics import pivot_inertia

# Integration substeps of one sample in the prediction (RK2): 0.1 ms at T_s = 1 ms, a third of
# the reference rig's current-loop constant, where an explicit step of the lag is accurate.
SUBSTEPS = 10


@dataclass(frozen=True)
class RigModel:
    """The identified rig's constants that the controller needs (the model page's names).

    Attributes: M = m_c + m_p the moving mass [kg]; m, l, J the pendulum's mass, centre
    of mass distance and inertia about the pivot; g; eta and A the screw's drive and
    back-drive efficiencies (A = 0: self-locking); k_F = k_M k_D the drive force per ampere
    before the screw [N/A]; k_fwc, F_Kc, F_Sc the cart's friction; k_fwp the pivot's viscous
    friction; T_i, dIdt_max the current loop.
    """

    M: float
    m: float
    l: float
    J: float
    g: float
    eta: float
    A: float
    k_F: float
    k_fwc: float
    F_Kc: float
    F_Sc: float
    k_fwp: float
    T_i: float
    dIdt_max: float

    @classmethod
    def from_parameters(cls, p: Mapping[str, float]) -> RigModel:
        """From a full set of rig parameter values (rig_defaults() updated by a fit)."""
        return cls(M=p["m_c"] + p["m_p"], m=p["m_p"], l=p["l"], J=pivot_inertia(p), g=p["g"], eta=p["eta"],
                   A=back_drive_efficiency(p["eta"], p.get("eta_back", -1.0)), k_F=p["k_M"] * p["k_D"],
                   k_fwc=p["k_fwc"], F_Kc=p["F_Kc"], F_Sc=max(p["F_Sc"], p["F_Kc"]), k_fwp=p["k_fwp"],
                   T_i=p["T_i"], dIdt_max=p["dIdt_max"])

    @property
    def self_locking(self) -> bool:
        return self.A == 0.0

    def accelerations(self, v: float, phi: float, w: float, force: float) -> tuple[float, float]:
        """(a, alpha) of cart and pendulum under the drive force `force` after the screw
        (eta k_F I less what the controller cancels as friction): the model's cart and
        pendulum, solved together (the 2x2 system of a back-drivable screw; A = 0 decouples it)."""
        s, c = math.sin(phi), math.cos(phi)
        b1 = force - self.k_fwc * v + self.A * self.m * self.l * w * w * s
        b2 = self.m * self.l * self.g * s - self.k_fwp * w
        a12 = self.A * self.m * self.l * c
        a21 = self.m * self.l * c
        det = self.M * self.J - a12 * a21
        return (b1 * self.J - a12 * b2) / det, (self.M * b2 - a21 * b1) / det

    def cart_force(self, a: float, v: float, phi: float, w: float) -> float:
        """The drive force after the screw that gives the cart the acceleration `a`: the cart's
        equation solved for it (inverse dynamics, viscous friction and the pendulum's push)."""
        s, c = math.sin(phi), math.cos(phi)
        alpha = (self.m * self.l * (self.g * s - a * c) - self.k_fwp * w) / self.J
        return self.M * a + self.k_fwc * v - self.A * self.m * self.l * (w * w * s - alpha * c)

    def current_rate(self, I: float, I_c: float) -> float:
        """The model's current loop: a first-order lag whose slope is limited."""
        z = (I_c - I) / (self.T_i * self.dIdt_max)
        return self.dIdt_max * max(-1.0, min(1.0, z))

    def derivative(self, s: list[float], I_c: float, cancelled: float) -> list[float]:
        """ds/dt of s = (x, v, phi, w, I) under the command I_c, with `cancelled` the force the
        controller spends on friction (left out of the drive)."""
        a, alpha = self.accelerations(s[1], s[2], s[3], self.eta * self.k_F * s[4] - cancelled)
        return [s[1], a, s[3], alpha, self.current_rate(s[4], I_c)]

    def predict(self, s: list[float], I_c: float, cancelled: float, T_s: float) -> list[float]:
        """The state one sample later (RK2, SUBSTEPS steps), phi wrapped into (-pi, pi]."""
        h = T_s / SUBSTEPS
        for _ in range(SUBSTEPS):
            d1 = self.derivative(s, I_c, cancelled)
            mid = [si + 0.5 * h * di for si, di in zip(s, d1)]
            d2 = self.derivative(mid, I_c, cancelled)
            s = [si + h * di for si, di in zip(s, d2)]
        s[2] = wrap(s[2])
        return s

    def linear(self) -> tuple[np.ndarray, np.ndarray]:
        """(A, B) of ds/dt = A s + B I_c about upright at rest (the coupled model; the
        current loop's lag without its slope limit)."""
        eps = 1e-6
        A = np.zeros((5, 5))
        for j in range(5):
            up, down = [0.0] * 5, [0.0] * 5
            up[j], down[j] = eps, -eps
            A[:, j] = (np.array(self.derivative(up, 0.0, 0.0)) - self.derivative(down, 0.0, 0.0)) / (2 * eps)
        B = np.zeros(5)
        B[4] = 1.0 / self.T_i
        return A, B[:, None]

    def axis_linear(self) -> tuple[np.ndarray, np.ndarray]:
        """(A, B) of the self-locking cart as an acceleration-commanded axis: s = (x, v, phi, w, a),
        the cart's acceleration following the command a_c through the current loop's lag
        (the controller inverts the cart's model, so the lag is all that is left of it)."""
        A = np.zeros((5, 5))
        A[0, 1] = A[2, 3] = A[1, 4] = 1.0
        A[3, 2] = self.m * self.l * self.g / self.J
        A[3, 3] = -self.k_fwp / self.J
        A[3, 4] = -self.m * self.l / self.J
        A[4, 4] = -1.0 / self.T_i
        B = np.zeros((5, 1))
        B[4, 0] = 1.0 / self.T_i
        return A, B


def wrap(angle: float) -> float:
    """An angle brought into (-pi, pi]: the encoder's phi is continuous (any multiple of 2 pi)."""
    wrapped = math.fmod(angle + math.pi, 2.0 * math.pi)
    if wrapped <= 0.0:
        wrapped += 2.0 * math.pi
    return wrapped - math.pi


def discretize(A: np.ndarray, B: np.ndarray, T_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Zero-order hold: the command is held over the sample (the FMU holds its output)."""
    n, m = B.shape
    block = np.zeros((n + m, n + m))
    block[:n, :n], block[:n, n:] = A, B
    E = expm(block * T_s)
    return E[:n, :n], E[:n, n:]
