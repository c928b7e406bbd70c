"""The joints' friction law, once for Python: each joint's declaration and a twin of friction.h.

The FMUs compute the law in ``pendfmu/csrc/framework/friction.h``: the paper's viscous,
Coulomb and stiction friction (docs/user-guide/model.md) with the optional extras of the
user guide's "Friction law extras" (docs/user-guide/friction.md) (a Stribeck speed, direction
asymmetries of the viscous and Coulomb terms, a constant offset force, quadratic drag), each
off at 0. Everything in Python that needs the law or a joint's names reads them here: the
report's friction figure, the stiction analysis, the stages' search boxes and the virtual
rig.

``Law`` is friction.h's ``Friction`` struct with its functions, vectorized over speeds and
forces and written with the same operations in the same order, so that it agrees with the
FMUs' own ``F_F`` and ``T_F`` to the rounding of ``exp`` (tests/test_friction_law.py).
A ``Joint`` names a joint's terms (parameters of the variable table, pendfmu.components),
its variables and the search-box rules of its friction terms.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields

import numpy as np

from pendfmu.components import COMPONENTS


def sign_of(value) -> np.ndarray:
    """friction.h's sign_of: +1 for value >= 0 (the paper's sgn(0) = 1), else -1."""
    return np.where(np.asarray(value, float) >= 0.0, 1.0, -1.0)


@dataclass(frozen=True)
class Law:
    """One joint's friction values: the fields of friction.h's ``Friction``, in its order.

    Attributes
    ----------
    k_fw, F_K, F_S : float
        Viscous coefficient, Coulomb (kinetic) friction, stiction.
    dk_fw, dF_K : float
        Direction asymmetries: k_fw + d dk_fw and F_K + d dF_K in direction d.
    v_S : float
        Stribeck speed (0: none): sliding friction falls from F_S to F_K as exp(-(v/v_S)^2).
    F_O : float
        Constant offset force added to the active force: it moves the stick condition and
        the net force, never the sliding friction.
    drag : float
        Quadratic drag coefficient: drag v |v| (the pendulum's air drag).
    """

    k_fw: float
    F_K: float
    F_S: float
    dk_fw: float = 0.0
    dF_K: float = 0.0
    v_S: float = 0.0
    F_O: float = 0.0
    drag: float = 0.0

    def viscous(self, direction):
        return self.k_fw + direction * self.dk_fw

    def coulomb(self, direction):
        return self.F_K + direction * self.dF_K

    def threshold(self, direction) -> np.ndarray:
        """The force a joint at rest holds before it slides in `direction`: max(F_S, F_K(d))
        (friction.h explains why F_K when it is the larger)."""
        return np.maximum(self.F_S, self.coulomb(direction))

    def holds(self, net) -> np.ndarray:
        """Whether a net force F_N = F_A + F_O leaves a joint at rest."""
        return np.abs(net) <= self.threshold(sign_of(net))

    def mode_at_rest(self, active) -> np.ndarray:
        """The mode of a joint at rest under active force F_A: 0 stuck, else the direction of F_A + F_O."""
        net = np.asarray(active, float) + self.F_O
        return np.where(self.holds(net), 0.0, sign_of(net))

    def sliding(self, speed, direction=None) -> np.ndarray:
        """The friction force of a joint sliding at `speed` in `direction` (default: the
        speed's sign), every term included: friction.h's friction_force for mode != 0."""
        v = np.asarray(speed, float)
        d = sign_of(v) if direction is None else np.asarray(direction, float)
        plain = self.viscous(d) * v + self.coulomb(d) * d
        if not (self.v_S > 0.0 or self.drag != 0.0):
            return plain  # the plain law's arithmetic, as friction.h keeps it
        return plain + self._extra(v, d)

    def _extra(self, v: np.ndarray, d: np.ndarray) -> np.ndarray:
        """The Stribeck and drag terms (friction.h's friction_extra)."""
        extra = np.zeros(np.broadcast(v, d).shape)
        if self.v_S > 0.0:
            ratio = v / self.v_S
            extra = extra + d * (self.F_S - self.coulomb(d)) * np.exp(-ratio * ratio)
        if self.drag != 0.0:
            extra = extra + self.drag * v * np.abs(v)
        return extra

    def held(self, active) -> np.ndarray:
        """The friction force of a stuck joint: it holds the whole net force F_A + F_O."""
        return np.asarray(active, float) + self.F_O

    def force(self, mode, speed, active) -> np.ndarray:
        """friction.h's friction_force: held while stuck (mode 0), sliding otherwise."""
        mode = np.asarray(mode, float)
        sliding = self.sliding(speed, np.where(mode == 0, 1.0, mode))
        return np.where(mode == 0, self.held(active), sliding)


LAW_TERMS = tuple(f.name for f in fields(Law))


@dataclass(frozen=True)
class Joint:
    """A joint with friction: the parameter of each of its law's terms, its variables, and
    the search-box rules of its friction terms.

    Attributes
    ----------
    name : str
        The joint, and the identification stage that fits its friction (stages.py).
    component : str
        The FMU whose variable table holds the names below.
    viscous, coulomb, stiction, stribeck, viscous_asymmetry, coulomb_asymmetry, offset : str
        The parameters of the law's terms (Law's k_fw, F_K, F_S, v_S, dk_fw, dF_K, F_O).
    drag : str or None
        The quadratic drag's parameter; None for a joint without one (the cart).
    speed, acceleration, active, friction : str
        The joint's speed, acceleration, active force (F_A, T_A) and friction force (F_F, T_F).
    speed_label, force_label : str
        The speed and the friction force in words, for the axes of a figure.
    boxes : mapping name -> (low, high, logarithmic)
        The physical search boxes of the friction terms (stages.DEFAULT_BOUNDS). An
        asymmetry or an offset has none: its sign and size are the rig's, so it needs --bounds.
    derived : mapping name -> (scale, low, high)
        The box of a term the user gave no value for: [low, high] times one of the rig's
        scales (stages.rig_scales, stages.DERIVED_BOUNDS).
    """

    name: str
    component: str
    viscous: str
    coulomb: str
    stiction: str
    stribeck: str
    viscous_asymmetry: str
    coulomb_asymmetry: str
    offset: str
    drag: str | None
    speed: str
    acceleration: str
    active: str
    friction: str
    speed_label: str
    force_label: str
    boxes: Mapping[str, tuple[float, float, bool]]
    derived: Mapping[str, tuple[str, float, float]]

    def __post_init__(self) -> None:
        table = COMPONENTS[self.component]
        names = (*self.parameters, self.speed, self.acceleration, self.active, self.friction)
        unknown = [name for name in names if name not in {v.name for v in table.variables}]
        if unknown:
            raise ValueError(f"{self.component} has no variable {', '.join(unknown)}")

    @property
    def stage(self) -> str:
        """The stage that fits this joint's friction: it has the joint's name."""
        return self.name

    @property
    def terms(self) -> dict[str, str]:
        """Law field -> this joint's parameter, for the terms the joint has."""
        names = (self.viscous, self.coulomb, self.stiction, self.viscous_asymmetry, self.coulomb_asymmetry,
                 self.stribeck, self.offset, self.drag)
        return {term: name for term, name in zip(LAW_TERMS, names) if name is not None}

    @property
    def parameters(self) -> tuple[str, ...]:
        """Every parameter of the joint's law, in friction.h's order."""
        return tuple(self.terms.values())

    @property
    def plain(self) -> tuple[str, str, str]:
        """The paper's three: viscous, Coulomb, stiction."""
        return self.viscous, self.coulomb, self.stiction

    @property
    def unit(self) -> str:
        """The unit of the joint's forces (N, or N.m for a torque), from the variable table."""
        return COMPONENTS[self.component].variable(self.friction).unit

    def law(self, values: Mapping[str, float]) -> Law:
        """The law at `values` (parameter name -> value); a term missing there takes its
        default from the variable table (the extras' 0: off)."""
        table = COMPONENTS[self.component]
        return Law(**{term: float(values.get(name, table.variable(name).start)) for term, name in self.terms.items()})


# Search boxes. DEFAULT boxes: physical ranges wide enough for any lab rig; the extras are
# off at 0, so a decade around the start cannot apply: Stribeck speeds and air drag search
# their physical decades, asymmetries and offsets need --bounds.
#
# DERIVED boxes, for a friction parameter the user gave no value for: from the rig's own
# scales, not from the reference rig's value (a 20 g pendulum's pivot friction is a
# hundredth of the paper's 0.2 kg rod's). name -> (scale, low, high): the box is [low, high]
# times the scale.
#
# Pendulum: the torque scale m_p g l (gravity's largest torque) and the viscous scale
# m_p g l / omega_0 (omega_0 = sqrt(m_p g l / J_p)), for which k_fwp / scale is twice the
# damping ratio. Coulomb friction or stiction above 0.3 m_p g l holds the pendulum 17 deg
# from hanging (asin 0.3) and a free decay barely swings; below 1e-4 it takes 2e-4 rad
# (0.01 deg) off each half swing, below a lab encoder's step over a whole record. A damping
# ratio from 5e-5 (a swing losing 0.03 % per period) to 0.5 (dead after one period).
# The reference rig: T_Kp = 3.4e-3, k_fwp = 8.4e-3 times their scales; the Furuta pendulum
# of examples/realdata: 1.5e-2 and 2.2e-2.
#
# Cart: the force scale is the drive's largest force over the recordings, k_M k_D max|I|
# (the cart stage's drives are the current I or its command I_c; (m_c + m_p) g without
# one), and the viscous scale that force over the largest speed the recordings show
# (from x). The cart moved, so its sliding friction is below eta times the drive's force,
# <= 1 times the scale; a cart accelerated from rest by at most that force never exceeds
# its terminal speed F / k_fwc, so k_fwc <= F / v_max (2: room for the speed's estimate).
# Three decades below: friction a thousandth of the drive is not what a lab rig shows.
# The reference rig's runs (3 A, 1.2 m/s): F_Kc = 0.07, k_fwc = 0.32 of their scales.
CART = Joint(
    "cart", "Cart", viscous="k_fwc", coulomb="F_Kc", stiction="F_Sc", stribeck="v_Sc",
    viscous_asymmetry="dk_fwc", coulomb_asymmetry="dF_Kc", offset="F_Oc", drag=None,
    speed="v", acceleration="a", active="F_A", friction="F_F",
    speed_label="cart speed v", force_label="friction force F_F",
    boxes={"k_fwc": (1e-2, 1e3, True), "F_Kc": (1e-2, 1e3, True), "F_Sc": (1e-2, 1e3, True),
           "v_Sc": (1e-4, 1.0, True)},
    derived={"F_Kc": ("force", 1e-3, 1.0), "F_Sc": ("force", 1e-3, 1.0), "k_fwc": ("translation", 1e-3, 2.0)},
)
PENDULUM = Joint(
    "pendulum", "Pendulum", viscous="k_fwp", coulomb="T_Kp", stiction="T_Sp", stribeck="w_Sp",
    viscous_asymmetry="dk_fwp", coulomb_asymmetry="dT_Kp", offset="T_Op", drag="k_dp",
    speed="w", acceleration="alpha", active="T_A", friction="T_F",
    speed_label="angular speed w", force_label="friction torque T_F",
    boxes={"k_fwp": (1e-7, 1e-1, True), "T_Kp": (1e-7, 1e-1, True), "T_Sp": (1e-7, 1e-1, True),
           "w_Sp": (1e-4, 10.0, True), "k_dp": (1e-9, 1e-1, True)},
    derived={"T_Kp": ("torque", 1e-4, 0.3), "T_Sp": ("torque", 1e-4, 0.3), "k_fwp": ("rotation", 1e-4, 1.0)},
)
JOINTS: dict[str, Joint] = {joint.name: joint for joint in (CART, PENDULUM)}  # by name (= stage)

# The search-box rules of the friction terms, as the stages read them (stages.py).
FRICTION_BOUNDS = {name: box for joint in JOINTS.values() for name, box in joint.boxes.items()}
DERIVED_BOUNDS = {name: rule for joint in JOINTS.values() for name, rule in joint.derived.items()}
STICTION_OF = {joint.stiction: joint.coulomb for joint in JOINTS.values()}  # stiction -> its Coulomb friction
STICTION_RATIO = (1.0, 10.0)  # stiction over Coulomb friction: the box of a stiction fitted relative to it
# With a Stribeck speed (free, or given > 0) the stiction is the sliding friction's level at
# v -> 0, and a level below the Coulomb friction is a curve that rises to it (friction.h):
# the ratio's box then reaches down a decade too. Without one, stiction below Coulomb
# friction has no effect, and the box starts at 1.
STRIBECK_OF = {joint.stiction: joint.stribeck for joint in JOINTS.values()}  # stiction -> its Stribeck speed
STRIBECK_RATIO = (0.1, 10.0)
