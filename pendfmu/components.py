"""The variable tables of the component FMUs (the rig's three, the Controller and the RigController): the single
source of truth.

Everything that names a variable is generated from these tables: each FMU's
``modelDescription.xml``, the C header with its value references, start values and
allowed ranges, and (in tests) the comparison with the Modelica library. Names, units
and defaults follow the paper's model (``docs/user-guide/model.md``); other tools script
against them, so changing a name here is a breaking change.

Value references are assigned by position: Real variables first, then Integer, then
Boolean, numbered consecutively, so every variable of an FMU has a distinct reference.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

# The internal fixed step of the Co-Simulation integrator: every component has it.
SOLVER_STEP = 1e-4

# A lead screw with eta <= 0.5 is self-locking: the pendulum cannot push the cart back
# (the paper's model, docs/user-guide/model.md: A(eta) = max(0, (2 eta - 1) / eta) is zero
# there), so a rig needs the pendulum's state fed back to the cart only above it.
SELF_LOCKING_ETA = 0.5

# eta_back < 0 (its default, -1) keeps the paper's switch: the back-drive efficiency is A(eta).
# 0 makes the screw self-locking whatever eta (eta is then only the drive's efficiency);
# a value in (0, 1] is the back-drive efficiency itself (a back-drivable screw or belt).
ETA_BACK_FROM_ETA = -1.0


def back_drive_efficiency(eta: float, eta_back: float = ETA_BACK_FROM_ETA) -> float:
    """A, the factor on the pendulum's push in F_A (the paper's A(eta) unless eta_back says
    otherwise: docs/user-guide/drives.md). 0 means a self-locking screw."""
    if eta_back < 0:
        return max(0.0, (2.0 * eta - 1.0) / eta) if eta > SELF_LOCKING_ETA else 0.0
    return eta_back


def back_drivable(values) -> bool:
    """Whether the pendulum pushes the cart (the rig then needs phi, w, alpha fed back) for
    Cart parameter values `values` (a mapping; missing names take the table's defaults)."""
    eta = values.get("eta", CART.variable("eta").start)
    eta_back = values.get("eta_back", CART.variable("eta_back").start)
    return back_drive_efficiency(eta, eta_back) > 0.0


@dataclass(frozen=True)
class Variable:
    """One FMI scalar variable.

    ``low``/``high`` bound a parameter's physical range; the FMU rejects values outside
    with fmi2Error, and pendfmu.ranges checks them in Python. ``low_open`` makes the lower
    bound exclusive (a mass of 0 is not a mass). ``state`` marks a continuous state; ``derivative_of`` names the state this
    variable is the time derivative of. ``depends_on`` lists, for outputs and
    derivatives, the states and inputs they depend on directly (FMI ModelStructure);
    ``None`` means "not declared" (depends on everything).
    """

    name: str
    causality: str  # parameter | input | output | local
    variability: str  # fixed | continuous | discrete
    start: float | int | bool | None
    unit: str = ""
    description: str = ""
    type: str = "Real"  # Real | Integer | Boolean
    low: float | None = None
    high: float | None = None
    low_open: bool = False
    excluded: tuple[float, float] | None = None  # an open interval inside [low, high] that is not allowed
    state: bool = False
    derivative_of: str | None = None
    depends_on: tuple[str, ...] | None = None


@dataclass(frozen=True)
class Component:
    """A component FMU: its identifier, description and variable table."""

    name: str
    description: str
    variables: tuple[Variable, ...]
    event_indicators: int
    # Doubles of model-owned discrete state in the FMU state (DynamicState.store): the sample
    # histories of a sampled component; 0 for a purely continuous one.
    store_size: int = 0

    def __post_init__(self) -> None:
        names = [v.name for v in self.variables]
        if len(names) != len(set(names)):
            raise ValueError(f"{self.name}: duplicate variable names")
        order = {"Real": 0, "Integer": 1, "Boolean": 2}
        kinds = [order[v.type] for v in self.variables]
        if kinds != sorted(kinds):
            raise ValueError(f"{self.name}: list Real, then Integer, then Boolean variables")

    def value_reference(self, name: str) -> int:
        for vr, var in enumerate(self.variables):
            if var.name == name:
                return vr
        raise KeyError(f"{self.name} has no variable {name!r}")

    def variable(self, name: str) -> Variable:
        return self.variables[self.value_reference(name)]

    def of(self, *, causality: str | None = None, type: str | None = None) -> list[Variable]:
        return [
            v
            for v in self.variables
            if (causality is None or v.causality == causality) and (type is None or v.type == type)
        ]

    @property
    def parameters(self) -> dict[str, Variable]:
        return {v.name: v for v in self.variables if v.causality == "parameter"}

    @property
    def states(self) -> list[Variable]:
        return [v for v in self.variables if v.state]


# When the Cart reads the pendulum's inputs: a back-drivable screw (docs/user-guide/drives.md).
_BACK_DRIVEN = f"(used when back-drivable: eta > {SELF_LOCKING_ETA} and eta_back = -1, or eta_back > 0)"


def _param(name, start, unit, description, low=None, high=None, low_open=False, excluded=None):
    return Variable(name, "parameter", "fixed", start, unit, description, low=low, high=high, low_open=low_open,
                    excluded=excluded)


def _solver_step():
    return _param(
        "solver_step", SOLVER_STEP, "s",
        "Upper limit of the internal fixed step of the Co-Simulation integrator (RK4)",
        low=0.0, high=1.0, low_open=True,
    )


def _mode(description):
    return Variable("mode", "local", "discrete", None, "", description, type="Integer")


def _t_mode():
    return Variable("t_mode", "local", "discrete", None, "s",
                    "Time of the last mode change (located to 1e-12 s in Co-Simulation)")


def _friction_extras(joint, *, speed, viscous, coulomb, stiction, names):
    """A joint's optional friction terms beyond the paper's model (docs/user-guide/friction.md,
    "Friction law extras"; pendfmu.friction names each joint's terms): the Stribeck speed and
    the direction asymmetries of the viscous and Coulomb terms. Each is 0 by default, which
    switches it off: the paper's law stays exact. `speed`, `viscous` and `coulomb` are (name,
    unit) pairs of the joint's variables; `names` the three new ones."""
    (w, w_unit), (k, k_unit), (F_K, F_unit) = speed, viscous, coulomb
    v_S, dk, dF = names
    return (
        _param(v_S, 0.0, w_unit, f"Stribeck speed of {joint}: sliding friction falls from {stiction} to {F_K} as "
                                 f"exp(-({w}/{v_S})^2) (0: no Stribeck effect)", low=0.0),
        _param(dk, 0.0, k_unit, f"Direction asymmetry of {joint}'s viscous friction: {k} + {dk} for {w} > 0, "
                                f"{k} - {dk} for {w} < 0"),
        _param(dF, 0.0, F_unit, f"Direction asymmetry of {joint}'s Coulomb friction: {F_K} + {dF} for {w} > 0, "
                                f"{F_K} - {dF} for {w} < 0"),
    )


CURRENT_LOOP = Component(
    name="CurrentLoop",
    description="Current control loop of the DC motor: slope-limited first-order lag plus PWM ripple (paper Eq. 1)",
    event_indicators=1,
    variables=(
        _param("T_i", 0.3e-3, "s", "Equivalent time constant of the current control loop", low=0.0, low_open=True),
        _param("dIdt_max", 2500.0, "A/s", "Maximum slope of the current", low=0.0, low_open=True),
        _param("a_h", 0.0, "A", "Amplitude of the PWM ripple harmonic on the output current", low=0.0),
        _param("f_h", 0.0, "Hz", "Frequency of the PWM ripple harmonic", low=0.0),
        _param("phase_h", 0.0, "rad", "Phase of the PWM ripple harmonic"),
        _param("I0", 0.0, "A", "Initial current"),
        _solver_step(),
        Variable("I_c", "input", "continuous", 0.0, "A", "Command current"),
        Variable("I", "output", "continuous", None, "A", "Motor current, ripple included",
                 depends_on=("I_mean",)),
        Variable("I_mean", "output", "continuous", None, "A",
                 "Current without ripple (state of the lag): what drives the motor's torque", state=True,
                 depends_on=("I_mean",)),
        Variable("der(I_mean)", "local", "continuous", None, "A/s", "Slope of the current",
                 derivative_of="I_mean", depends_on=("I_mean", "I_c")),
        _t_mode(),
        _mode("Slope limit: -1 falling at -dIdt_max, 0 linear lag, +1 rising at dIdt_max"),
        Variable("saturated", "local", "discrete", None, "", "The slope limit is active", type="Boolean"),
    ),
)

CART = Component(
    name="Cart",
    description="Cart on a lead screw driven by the DC motor, with viscous, Coulomb and stiction friction (paper Eq. 2-5)",
    event_indicators=1,
    variables=(
        _param("m_c", 3.0, "kg", "Effective mass of the cart, motor inertia included", low=0.0, low_open=True),
        _param("m_p", 0.2, "kg", "Mass of the pendulum (0: pendulum removed)", low=0.0),
        _param("eta", 0.4, "1", "Efficiency of the lead screw", low=0.0, high=1.0, low_open=True),
        _param("k_M", 0.06, "N.m/A", "Torque constant of the DC motor", low=0.0, low_open=True),
        _param("k_D", 628.3, "1/m", "Translation gain of the lead screw (2*pi/pitch)", low=0.0, low_open=True),
        _param("l", 0.3, "m", "Distance from the pivot to the pendulum's centre of mass", low=0.0, low_open=True),
        _param("k_fwc", 30.0, "N.s/m", "Viscous friction coefficient of the cart", low=0.0),
        _param("F_Kc", 8.0, "N", "Coulomb (kinetic) friction force of the cart", low=0.0),
        _param("F_Sc", 12.0, "N", "Stiction (maximum static friction) force of the cart", low=0.0),
        *_friction_extras("the cart", speed=("v", "m/s"), viscous=("k_fwc", "N.s/m"), coulomb=("F_Kc", "N"),
                          stiction="F_Sc", names=("v_Sc", "dk_fwc", "dF_Kc")),
        _param("F_Oc", 0.0, "N", "Constant offset force on the cart along +x (cable drag, a tilted track)"),
        # Drives beyond the paper's model (docs/user-guide/drives.md): a command u beside the
        # current, all off at 0.
        _param("k_u", 0.0, "N", "Motor force per unit of the command u, before the screw's efficiency "
                                "(0: no command path)"),
        _param("k_emf", 0.0, "N.s/m", "Back-EMF of a voltage-driven motor: the command path's force falls by "
                                      "k_emf*v", low=0.0),
        _param("tau_e", 0.0, "s", "Electrical lag of the command path: tau_e*dF_e/dt = k_u*u - k_emf*v - F_e "
                                  "(0: no lag, the force follows u at once)", low=0.0),
        _param("eta_back", ETA_BACK_FROM_ETA, "1",
               "Back-drive efficiency of the screw: -1 (default) A(eta) = max(0, (2*eta-1)/eta) as the paper; "
               "0 self-locking whatever eta; in (0, 1] this efficiency", low=-1.0, high=1.0, excluded=(-1.0, 0.0)),
        _param("x0", 0.0, "m", "Initial position"),
        _param("v0", 0.0, "m/s", "Initial speed"),
        _solver_step(),
        Variable("I", "input", "continuous", 0.0, "A", "Motor current"),
        Variable("u", "input", "continuous", 0.0, "1",
                 "Drive command: normalized PWM duty or voltage command (force k_u*u, used when k_u != 0)"),
        Variable("phi", "input", "continuous", math.pi, "rad",
                 f"Pendulum angle from the upward vertical {_BACK_DRIVEN}"),
        Variable("w", "input", "continuous", 0.0, "rad/s",
                 f"Pendulum angular speed {_BACK_DRIVEN}"),
        Variable("alpha", "input", "continuous", 0.0, "rad/s2",
                 f"Pendulum angular acceleration {_BACK_DRIVEN}"),
        Variable("x", "output", "continuous", None, "m", "Cart position", state=True, depends_on=("x",)),
        Variable("v", "output", "continuous", None, "m/s", "Cart speed", state=True, derivative_of="x",
                 depends_on=("v",)),
        Variable("a", "output", "continuous", None, "m/s2", "Cart acceleration", derivative_of="v",
                 depends_on=("v", "F_e", "I", "u", "phi", "w", "alpha")),
        Variable("F_A", "output", "continuous", None, "N", "Active force on the cart",
                 depends_on=("v", "F_e", "I", "u", "phi", "w", "alpha")),
        Variable("F_e", "output", "continuous", None, "N",
                 "Lagged force of the command path (state of the electrical lag; stays 0 when tau_e = 0)",
                 state=True, depends_on=("F_e",)),
        Variable("der(F_e)", "local", "continuous", None, "N/s", "Rate of the command path's force",
                 derivative_of="F_e", depends_on=("F_e", "v", "u")),
        Variable("F_F", "local", "continuous", None, "N", "Friction force on the cart"),
        _t_mode(),
        _mode("Friction mode: +1 sliding forward, 0 stuck, -1 sliding backward"),
        Variable("stuck", "local", "discrete", None, "", "The cart is held by stiction", type="Boolean"),
    ),
)

PENDULUM = Component(
    name="Pendulum",
    description="Pendulum on the cart's pivot with viscous, Coulomb and stiction friction (paper Eq. 6-8)",
    event_indicators=1,
    variables=(
        _param("m_p", 0.2, "kg", "Mass of the pendulum", low=0.0, low_open=True),
        _param("l", 0.3, "m", "Distance from the pivot to the centre of mass", low=0.0, low_open=True),
        _param("J_p", 0.0, "kg.m2",
               "Moment of inertia about the pivot; 0 means a uniform rod, (4/3)*m_p*l^2", low=0.0),
        _param("g", 9.81, "m/s2", "Gravitational acceleration", low=0.0),
        _param("k_fwp", 1e-3, "N.m.s", "Viscous friction coefficient of the pivot", low=0.0),
        _param("T_Kp", 2e-3, "N.m", "Coulomb (kinetic) friction torque of the pivot", low=0.0),
        _param("T_Sp", 4e-3, "N.m", "Stiction (maximum static friction) torque of the pivot", low=0.0),
        *_friction_extras("the pivot", speed=("w", "rad/s"), viscous=("k_fwp", "N.m.s"), coulomb=("T_Kp", "N.m"),
                          stiction="T_Sp", names=("w_Sp", "dk_fwp", "dT_Kp")),
        _param("T_Op", 0.0, "N.m", "Constant offset torque on the pendulum towards +phi (a cable, a spring's preload)"),
        _param("k_dp", 0.0, "N.m.s2", "Quadratic air drag of the pendulum: drag torque k_dp*w*|w|", low=0.0),
        _param("phi0", math.pi, "rad", "Initial angle from the upward vertical (hanging: pi)"),
        _param("w0", 0.0, "rad/s", "Initial angular speed"),
        _solver_step(),
        Variable("a", "input", "continuous", 0.0, "m/s2", "Cart acceleration"),
        Variable("phi", "output", "continuous", None, "rad", "Angle from the upward vertical", state=True,
                 depends_on=("phi",)),
        Variable("w", "output", "continuous", None, "rad/s", "Angular speed", state=True,
                 derivative_of="phi", depends_on=("w",)),
        Variable("alpha", "output", "continuous", None, "rad/s2", "Angular acceleration", derivative_of="w",
                 depends_on=("phi", "w", "a")),
        Variable("T_A", "output", "continuous", None, "N.m", "Active torque on the pendulum",
                 depends_on=("phi", "a")),
        Variable("T_F", "local", "continuous", None, "N.m", "Friction torque in the pivot"),
        _t_mode(),
        _mode("Friction mode: +1 turning forward, 0 stuck, -1 turning backward"),
        Variable("stuck", "local", "discrete", None, "", "The pendulum is held by stiction", type="Boolean"),
    ),
)

# The Controller's buffers (pendfmu/csrc/Controller/model.c): at most this many samples of delay and
# of derivative span n_d. Its store holds them plus a few scalars (model.c checks the size).
CONTROLLER_MAX_SAMPLES = 100
# The default saturation: FMI 2 XML cannot write an infinite start value, and the FMUs refuse
# non-finite Reals, so "no saturation" is this finite bound, far beyond any signal.
NO_SATURATION = 1e300

CONTROLLER = Component(
    name="Controller",
    description="Discrete PID controller with sample time, derivative over n_d samples, output delay, "
                "saturation and a feedforward added after it",
    event_indicators=0,
    store_size=8 + 2 * CONTROLLER_MAX_SAMPLES,
    variables=(
        _param("T_s", 1e-3, "s", "Sample time: samples at t_start + k*T_s", low=0.0, low_open=True),
        _param("K_p", 1.0, "", "Proportional gain"),
        _param("K_i", 0.0, "", "Integral gain (per second): the integrator adds K_i*T_s*e at each sample"),
        _param("K_d", 0.0, "", "Derivative gain (seconds): K_d times the difference quotient over n_d samples"),
        _param("u_max", NO_SATURATION, "", f"Upper saturation of the output before u_ff ({NO_SATURATION:g}: none)"),
        _param("u_min", -NO_SATURATION, "", f"Lower saturation of the output before u_ff ({-NO_SATURATION:g}: none)"),
        _param("u0", 0.0, "", "Output (before u_ff) over the first `delay` samples, before a computed value arrives"),
        Variable("r", "input", "continuous", 0.0, "", "Reference, read at each sample"),
        Variable("y", "input", "continuous", 0.0, "", "Measurement, read at each sample"),
        Variable("u_ff", "input", "continuous", 0.0, "", "Feedforward added after the saturation, read at each sample"),
        Variable("u", "output", "discrete", None, "",
                 "Controller output: saturated, delayed PID value plus u_ff, held from one sample to the next",
                 depends_on=("r", "y", "u_ff")),
        Variable("e", "local", "discrete", None, "", "Control error r - y at the last sample"),
        Variable("v", "local", "discrete", None, "", "Unsaturated PID value computed at the last sample"),
        Variable("u_I", "local", "discrete", None, "", "Integrator state after the last sample"),
        Variable("t_sample", "local", "discrete", None, "s", "Time of the last sample taken"),
        _t_mode(),
        Variable("n_d", "parameter", "fixed", 1, "",
                 f"Derivative span in samples: (s(k) - s(k-n_d)) / (n_d*T_s), 1..{CONTROLLER_MAX_SAMPLES}",
                 type="Integer"),
        Variable("delay", "parameter", "fixed", 0, "",
                 f"Pure delay of the output in samples, 0..{CONTROLLER_MAX_SAMPLES}", type="Integer"),
        _mode("Saturation of the last computed value: -1 at u_min, 0 inside, +1 at u_max"),
        Variable("derivative_on_measurement", "parameter", "fixed", False, "",
                 "The derivative acts on -y instead of the error r - y (no kick on reference steps)",
                 type="Boolean"),
        Variable("saturated", "local", "discrete", None, "", "The last computed value was saturated",
                 type="Boolean"),
    ),
)

# The RigController's estimator state, in this order (pendfmu/control/plant.py), and the LQR's:
# the same but for the fifth, the drive (the cart's acceleration on the self-locking axis, else
# the motor current).
RIG_STATES = ("x", "v", "phi", "w", "I")
RIG_READINGS = ("x", "phi")
RIG_LQR_STATES = ("x", "v", "phi", "w", "drive")


def _rig_controller_parameters() -> tuple[Variable, ...]:
    """The RigController's parameters: its design (pendfmu/control/design.py's Design), flat."""
    rig = (
        ("M", "kg", "Moving mass of the cart, m_c + m_p"), ("m_p", "kg", "Mass of the pendulum"),
        ("l", "m", "Distance from the pivot to the pendulum's centre of mass"),
        ("J_p", "kg.m2", "Moment of inertia of the pendulum about the pivot"), ("g", "m/s2", "Gravity"),
        ("eta", "1", "Efficiency of the lead screw"),
        ("A_back", "1", "Back-drive efficiency of the screw (0: self-locking)"),
        ("k_F", "N/A", "Drive force per ampere before the screw, k_M*k_D"),
        ("k_fwc", "N.s/m", "Viscous friction of the cart"), ("F_Kc", "N", "Coulomb friction of the cart"),
        ("F_Sc", "N", "Breakaway force of the cart, max(F_Sc, F_Kc)"),
        ("k_fwp", "N.m.s", "Viscous friction of the pivot"),
        ("T_i", "s", "Time constant of the current loop"), ("dIdt_max", "A/s", "Slope limit of the current loop"),
    )
    gains = [(f"K_{s}", "", f"LQR gain on the estimate of {s} (x: its error from x_ref)") for s in RIG_LQR_STATES]
    gains += [(f"L{s}_{y}", "", f"Estimator gain of {s} on the innovation of {y}")
              for s in RIG_STATES for y in RIG_READINGS]
    law = (
        ("I_max", "A", "Current limit"), ("x_max", "m", "Track half-length"),
        ("k_E", "m/s2", "Swing-up: acceleration per unit of the energy missing, over m_p*g*l"),
        ("a_swing", "m/s2", "Swing-up: limit of the pumping acceleration"),
        ("k_xs", "1/s2", "Swing-up: centring gain on x - x_ref"), ("k_vs", "1/s", "Swing-up: centring gain on v"),
        ("phi_catch", "rad", "Balance takes over within this angle of upright (and lets go at twice it)"),
        ("v_stuck", "m/s", "Friction compensation: below this speed the cart counts as stuck"),
        ("F_ramp", "N", "Friction compensation: wanted force over which the breakaway builds up to F_Sc (a stuck "
                   "self-locking cart wanted to push less while balancing gets no current)"),
        ("x_quantum", "m", "Input x rounded to a multiple of this before use (0: as given): an encoder emulated "
                           "when the loop is closed on a continuous model; leave 0 on the rig"),
        ("phi_quantum", "rad", "Input phi rounded to a multiple of this before use (0: as given), as x_quantum"),
    )
    # The reference rig (docs/user-guide/model.md) and its design with the default options, to
    # 6 digits (checked against a fresh design by tests/test_control.py): the FMU as built
    # balances that rig; `pendfmu control` writes a fit's design as the starts
    reference = {"M": 3.2, "m_p": 0.2, "l": 0.3, "J_p": 0.024, "g": 9.81, "eta": 0.4, "k_F": 0.06 * 628.3,
                 "k_fwc": 30.0, "F_Kc": 8.0, "F_Sc": 12.0, "k_fwp": 1e-3, "T_i": 0.3e-3, "dIdt_max": 2500.0,
                 "I_max": 5.0, "x_max": 0.4, "phi_catch": 0.3, "v_stuck": 5e-3, "F_ramp": 3.0,
                 "k_E": 20.0, "a_swing": 6.0, "k_xs": 8.0, "k_vs": 6.0, "K_x": -49.3243, "K_v": -39.6039,
                 "K_phi": -165.477, "K_w": -26.6965, "K_drive": 0.00810862, "Lx_x": 0.981597, "Lx_phi": 2.55442e-08,
                 "Lv_x": 941.851, "Lv_phi": -1.89793e-05, "Lphi_x": 0.0100838, "Lphi_phi": 0.158613, "Lw_x": 22.8444,
                 "Lw_phi": 13.6627}
    return tuple(_param(name, reference.get(name, 0.0), unit, description)
                 for name, unit, description in (*rig, *gains, *law))


RIG_CONTROLLER = Component(
    name="RigController",
    description="Balance and swing-up controller of the pendulum rig, designed from a fit (pendfmu control): "
                "Kalman estimator from the encoders, LQR about upright, energy swing-up, friction compensation",
    event_indicators=0,
    store_size=12,
    variables=(
        _param("T_s", 1e-3, "s", "Sample time: samples at t_start + k*T_s", low=0.0, low_open=True),
        *_rig_controller_parameters(),
        Variable("x", "input", "continuous", 0.0, "m", "Cart position (the motor encoder's reading)"),
        Variable("phi", "input", "continuous", math.pi, "rad",
                 "Pendulum angle from the upward vertical, continuous (pi hanging; any multiple of 2*pi)"),
        Variable("x_ref", "input", "continuous", 0.0, "m", "Reference position of the cart"),
        Variable("I_c", "output", "discrete", None, "A", "Command current, held from one sample to the next",
                 depends_on=("x", "phi", "x_ref")),
        *(Variable(f"{s}_hat", "local", "discrete", None, unit, f"Estimate of {s} after the last sample")
          for s, unit in zip(RIG_STATES, ("m", "m/s", "rad", "rad/s", ""))),
        Variable("cancelled", "local", "discrete", None, "N", "Friction force compensated at the last sample"),
        _t_mode(),
        _mode("Task of the last sample: 0 swing-up, 1 balance"),
        Variable("swing_up", "parameter", "fixed", False, "", "Swing up from anywhere (else balance only)",
                 type="Boolean"),
        Variable("compensation", "parameter", "fixed", True, "", "Compensate the cart's identified friction",
                 type="Boolean"),
        Variable("axis", "parameter", "fixed", True, "",
                 "The LQR commands the cart's acceleration (self-locking screw), else the current", type="Boolean"),
    ),
)

# The rig's components: their parameters form the rig's parameter table.
COMPONENTS: dict[str, Component] = {c.name: c for c in (CURRENT_LOOP, CART, PENDULUM)}
# Components that are no part of the rig, used around it in systems (a controller in the loop).
CONTROL_COMPONENTS: dict[str, Component] = {c.name: c for c in (CONTROLLER, RIG_CONTROLLER)}
# Every component FMU that `pendfmu build` makes.
ALL_COMPONENTS: dict[str, Component] = {**COMPONENTS, **CONTROL_COMPONENTS}


def parameter_table() -> dict[str, Variable]:
    """Every parameter of the rig by name, with its table row. A name that several
    components have (m_p and l) is one physical quantity: it appears once, with the first
    component's row."""
    rows: dict[str, Variable] = {}
    for component in COMPONENTS.values():
        for name, variable in component.parameters.items():
            rows.setdefault(name, variable)
    return rows


def rig_defaults() -> dict[str, float]:
    """The paper's reference rig (docs/user-guide/model.md): every rig parameter at its table
    default. solver_step is left out: it is a setting of each FMU's integrator, not a property
    of the rig."""
    return {name: float(variable.start) for name, variable in parameter_table().items() if name != "solver_step"}
