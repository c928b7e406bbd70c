"""The controller, one sample at a time: estimate, choose swing-up or balance, command a current.

This is the reference the C component (csrc/RigController/model.c) is tested against:
the same operations in the same order. Each sample, from the encoder readings x and phi:

1. correct the predicted state with the innovations (Kalman gain L; phi's innovation wrapped);
2. balance near upright (LQR), else (task swing-up) pump the pendulum's energy;
3. turn the wanted drive force into a current, adding the friction the cart is believed to
   have (compensation) and limiting it to +-I_max; a stuck self-locking cart that is wanted
   to push less than F_ramp while balancing gets none (holds);
4. predict the next sample's state under that current (plant.RigModel.predict).
"""

from __future__ import annotations

import math

from pendfmu.control.design import Design
from pendfmu.control.plant import wrap

SWING, BALANCE = 0, 1
TRACK_USE = 0.9  # of the track's half-length x_max: where the swing-up's braking aims to stop


def sgn(value: float) -> float:
    """The model's sign (docs/user-guide/model.md): sgn(0) = 1 (a pendulum hanging at rest gets its first push)."""
    return 1.0 if value >= 0.0 else -1.0


def quantized(value: float, step: float) -> float:
    """`value` rounded to the nearest multiple of `step` (halves up); as it is for step 0."""
    return math.floor(value / step + 0.5) * step if step > 0.0 else value


class Controller:
    """The sampled controller of a Design; `step(x, phi, x_ref)` returns the command I_c [A].

    Parameters
    ----------
    design : Design
        The gains and settings (design.design).

    Attributes
    ----------
    d : Design
        The design it runs.
    s : list of float or None
        The state (x, v, phi, w, I) predicted for the coming sample; None before the first.
    mode : int
        SWING or BALANCE, as chosen at the last sample.
    cancelled : float
        The friction force the last command added [N].
    """

    def __init__(self, design: Design):
        self.d = design
        self.s: list[float] | None = None  # the state predicted for the coming sample
        self.mode = BALANCE
        self.cancelled = 0.0  # the force spent on friction at the last sample [N]

    def step(self, x: float, phi: float, x_ref: float = 0.0) -> float:
        """One sample: estimate, choose the mode, command (the module's steps 1-4).

        Parameters
        ----------
        x : float
            The cart's encoder reading [m].
        phi : float
            The pendulum's encoder reading [rad], continuous (0 upright, pi hanging, any
            multiple of 2 pi added).
        x_ref : float
            Where the cart should balance [m].

        Returns
        -------
        float
            The current command I_c [A], within +-I_max, held until the next sample.
        """
        s = self.correct(quantized(x, self.d.x_quantum), wrap(quantized(phi, self.d.phi_quantum)))
        self.mode = self.choose_mode(s)
        if self.mode == BALANCE:
            force = self.balance_force(s, x_ref)
        else:
            force = self.d.rig.cart_force(self.swing_acceleration(s, x_ref), s[1], s[2], s[3])
        rig = self.d.rig
        if self.holds(force, s[1]):
            force, cancelled = 0.0, 0.0
        else:
            cancelled = self.compensation(force, s[1])
        I_c = max(-self.d.I_max, min(self.d.I_max, (force + cancelled) / (rig.eta * rig.k_F)))
        self.cancelled = cancelled
        self.s = rig.predict(s, I_c, cancelled, self.d.T_s)
        return I_c

    def correct(self, x: float, phi: float) -> list[float]:
        """The estimate after this sample's readings (the first sample starts at rest there).

        Parameters
        ----------
        x, phi : float
            The readings [m, rad], phi wrapped into (-pi, pi].

        Returns
        -------
        list of float
            The corrected state (x, v, phi, w, I).
        """
        if self.s is None:
            return [x, 0.0, phi, 0.0, 0.0]
        e_x, e_phi = x - self.s[0], wrap(phi - self.s[2])
        s = [si + g_x * e_x + g_phi * e_phi for si, (g_x, g_phi) in zip(self.s, self.d.L)]
        s[2] = wrap(s[2])
        return s

    def choose_mode(self, s: list[float]) -> int:
        """Balance for the balance task; for swing-up, balance once within phi_catch of upright
        and until the pendulum falls past twice that.

        Parameters
        ----------
        s : list of float
            The corrected state (x, v, phi, w, I).

        Returns
        -------
        int
            BALANCE or SWING.
        """
        if not self.d.swing_up:
            return BALANCE
        limit = self.d.phi_catch if self.mode == SWING else 2.0 * self.d.phi_catch
        return BALANCE if abs(s[2]) < limit else SWING

    def balance_force(self, s: list[float], x_ref: float) -> float:
        """The LQR's drive force: from an acceleration on the self-locking axis, or a current.

        Parameters
        ----------
        s : list of float
            The corrected state (x, v, phi, w, I).
        x_ref : float
            Where the cart should balance [m].

        Returns
        -------
        float
            The wanted drive force on the cart [N], friction not yet added.
        """
        rig, K = self.d.rig, self.d.K
        if self.d.axis:
            a = rig.accelerations(s[1], s[2], s[3], rig.eta * rig.k_F * s[4] - self.cancelled)[0]
            a_c = -(K[0] * (s[0] - x_ref) + K[1] * s[1] + K[2] * s[2] + K[3] * s[3] + K[4] * a)
            return rig.cart_force(a_c, s[1], s[2], s[3])
        I = -(K[0] * (s[0] - x_ref) + K[1] * s[1] + K[2] * s[2] + K[3] * s[3] + K[4] * s[4])
        return rig.eta * rig.k_F * I

    def swing_acceleration(self, s: list[float], x_ref: float) -> float:
        """The energy law: push the cart against w cos(phi) in proportion to the energy missing
        to upright (E = 0 there), within a_swing, while springs pull the cart back to x_ref.

        Parameters
        ----------
        s : list of float
            The corrected state (x, v, phi, w, I).
        x_ref : float
            Where the springs pull the cart [m].

        Returns
        -------
        float
            The wanted cart acceleration [m/s^2], within the track (within_track).
        """
        d, rig = self.d, self.d.rig
        E = 0.5 * rig.J * (s[3] * s[3]) + rig.m * rig.g * rig.l * (math.cos(s[2]) - 1.0)
        pump = d.k_E * E / (rig.m * rig.g * rig.l) * sgn(s[3] * math.cos(s[2]))
        pump = max(-d.a_swing, min(d.a_swing, pump))
        return self.within_track(pump - d.k_xs * (s[0] - x_ref) - d.k_vs * s[1], s[0], s[1])

    def within_track(self, a: float, x: float, v: float) -> float:
        """The track limit: a cart heading for an end that could only just stop before
        TRACK_USE of the half-length at the swing's acceleration limit brakes at that limit
        (else `a`). The swing-up is what travels far; balance stays near x_ref.

        Parameters
        ----------
        a : float
            The wanted acceleration [m/s^2].
        x, v : float
            The cart's estimated position [m] and speed [m/s].

        Returns
        -------
        float
            `a`, or the braking acceleration [m/s^2].
        """
        d = self.d
        room = TRACK_USE * d.x_max - abs(x)
        if x * v > 0.0 and v * v >= 2.0 * d.a_swing * room:
            return -sgn(v) * d.a_swing
        return a

    def holds(self, force: float, v: float) -> bool:
        """Whether the cart is left to hold itself, with no current: balancing on a
        self-locking screw (compensation on), stuck, and wanting less than F_ramp. Why: a
        self-locking cart stays put unpowered, and the pendulum's own stiction holds it near
        upright; a breakaway ramped in below F_ramp left such a cart stuck with current
        flowing for good (the table's rig 1: 1.14 steps from upright with 0.6 A; rig 4's
        figures, 1.13 steps and 0.78 A RMS, are of the same kind), and in a trial one that
        grew to the full stiction while stuck made rig 3's cart slip to and fro at 1 A.

        Parameters
        ----------
        force : float
            The wanted drive force [N].
        v : float
            The cart's estimated speed [m/s].

        Returns
        -------
        bool
            True: command no current this sample.
        """
        return (self.d.axis and self.d.compensation and self.mode == BALANCE and abs(v) <= self.d.v_stuck
                and abs(force) < self.d.F_ramp)

    def compensation(self, force: float, v: float) -> float:
        """The cart's friction as identified: Coulomb against a sliding cart; a stuck one is
        broken away in the direction of the wanted force, the full stiction from F_ramp on.

        Parameters
        ----------
        force : float
            The wanted drive force [N].
        v : float
            The cart's estimated speed [m/s].

        Returns
        -------
        float
            The friction force to add to the wanted force [N] (0 with compensation off).
        """
        if not self.d.compensation:
            return 0.0
        rig = self.d.rig
        if abs(v) > self.d.v_stuck:
            return rig.F_Kc * sgn(v)
        return rig.F_Sc * max(-1.0, min(1.0, force / self.d.F_ramp))
