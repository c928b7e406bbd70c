"""pendfmu.friction, the Python twin of friction.h, against the FMUs' own friction.

The Cart's F_F and the Pendulum's T_F are read through fmpy at t = 0, after an
initialization with the joint's initial speed (v0, w0) and drive set: a joint started at
speed v slides in direction sgn(v) (friction.h's friction_initial_mode), one started at
rest is stuck or breaks away as the net force says. Each extra term is switched on in
turn and all together, sliding both ways, stuck, and on both sides of each breakaway
threshold.

Tolerance: the twin performs friction.h's operations in friction.h's order on the same
doubles (the FMUs are built with -ffp-contract=off: no fused multiply-adds), so where no
exp is involved it must agree bit for bit, and it is asserted equal. The Stribeck term
calls exp: the C library's in the FMU, numpy's in the twin, each within a few units in the
last place (ulp) of the true value. There the limit is 4 ulp of the Stribeck term plus
1 ulp of the total (the last addition may then round the other way), about 1e-15 of the
force: far below any model difference (a Stribeck speed off by 1e-9 of itself moves the
force by 1e-10 of it at v = v_S).
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping, Sequence

import numpy as np
import pytest
from fmpy.fmi2 import FMU2Slave

import pendfmu
from pendfmu.components import COMPONENTS
from pendfmu.fmubuild.compiler import SOURCE_DIR
from pendfmu.friction import CART, JOINTS, LAW_TERMS, PENDULUM, Joint, Law, sign_of
from pendfmu.parameters import INITIAL_STATE_PARAMETERS
from pendfmu.report.content import fitted_law, friction_curve
from pendfmu.report.figures import friction_figure, write_friction_figures
from pendfmu.simulator.component import unpacked_fmu
from pendfmu.virtual_rig import Trial, steps, write_experiments

CART_BASE = {"m_p": 0.0}  # the cart alone: its drive is eta k_M k_D I
CART_CASES = {
    "plain": {},
    "Stribeck": {"v_Sc": 0.05},
    "Stribeck rising": {"v_Sc": 0.05, "F_Sc": 5.0},  # stiction below Coulomb: the threshold is F_K
    "asymmetric": {"dk_fwc": 5.0, "dF_Kc": 1.0},
    "asymmetric thresholds": {"dF_Kc": 1.0, "F_Sc": 8.5},  # F_K(+1) = 9 > F_S > F_K(-1) = 7: 9 and 8.5
    "offset": {"F_Oc": -2.0},
    "all": {"v_Sc": 0.05, "dk_fwc": 5.0, "dF_Kc": 1.0, "F_Oc": -2.0},
}
PENDULUM_CASES = {
    "plain": {},
    "Stribeck": {"w_Sp": 0.3},
    "asymmetric": {"dk_fwp": 5e-4, "dT_Kp": 5e-4},
    "asymmetric thresholds": {"dT_Kp": 5e-4, "T_Sp": 2.2e-3},  # thresholds 2.5e-3 and 2.2e-3
    "offset": {"T_Op": 1e-3},
    "drag": {"k_dp": 2e-4},
    "all": {"w_Sp": 0.3, "dk_fwp": 5e-4, "dT_Kp": 5e-4, "T_Op": 1e-3, "k_dp": 2e-4},
}
CASES = [(CART, CART_BASE, name, extra) for name, extra in CART_CASES.items()] + \
        [(PENDULUM, {}, name, extra) for name, extra in PENDULUM_CASES.items()]
SPEED_SCALE = {"cart": 2.0, "pendulum": 20.0}  # the sweep's fastest speed: beyond anything the rig does
ULP_OF_EXP = 4


class AtStart:
    """One instance of a component FMU, initialized anew per call: its variables at t = 0
    for the given parameters and inputs (set in initialization mode, so that the initial
    mode is the one they imply)."""

    def __init__(self, component: str):
        directory, md = unpacked_fmu(component)
        self.vr = {v.name: v.valueReference for v in md.modelVariables}
        self.slave = FMU2Slave(guid=md.guid, unzipDirectory=str(directory),
                               modelIdentifier=md.coSimulation.modelIdentifier, instanceName=f"{component}-at-start")
        self.slave.instantiate()
        self.initialized = False  # FMI allows fmi2Terminate only after initialization

    def __call__(self, values: Mapping[str, float], reals: Sequence[str]) -> tuple[list[float], int]:
        """(the Real variables `reals`, the friction mode) after initializing with `values`."""
        slave = self.slave
        self.initialized = True
        slave.reset()
        slave.setupExperiment(startTime=0.0)
        slave.enterInitializationMode()
        slave.setReal([self.vr[name] for name in values], [float(v) for v in values.values()])
        slave.exitInitializationMode()
        return slave.getReal([self.vr[name] for name in reals]), slave.getInteger([self.vr["mode"]])[0]

    def close(self) -> None:
        if self.initialized:  # a test run of its own may never use one joint's instance
            self.slave.terminate()
        self.slave.freeInstance()


@pytest.fixture(scope="module")
def at_start():
    instances = {joint.name: AtStart(joint.component) for joint in JOINTS.values()}
    yield instances
    for instance in instances.values():
        instance.close()


def fmu_sliding(at_start: AtStart, joint: Joint, values: Mapping[str, float], speeds: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
    """(friction force, mode) of the joint's FMU started at each of `speeds`."""
    start = INITIAL_STATE_PARAMETERS[joint.speed]
    rows = [at_start({**values, start: v}, [joint.friction]) for v in speeds]
    return np.array([forces[0] for forces, _ in rows]), np.array([mode for _, mode in rows])


def sweep(joint: Joint, law: Law) -> np.ndarray:
    """Speeds both ways over nine decades, and through the Stribeck fall where there is one."""
    forward = np.geomspace(1e-9, 1.0, 46) * SPEED_SCALE[joint.name]
    if law.v_S > 0:
        forward = np.concatenate([forward, np.linspace(0.05, 4.0, 80) * law.v_S])
    return np.concatenate([-forward[::-1], forward])


def rounding_limit(law: Law, speeds: np.ndarray, forces: np.ndarray) -> np.ndarray:
    """0 without a Stribeck term; with one, ULP_OF_EXP ulp of it plus one of the total."""
    if not law.v_S > 0:
        return np.zeros_like(forces)
    d = sign_of(speeds)
    stribeck = np.abs((law.F_S - law.coulomb(d)) * np.exp(-(speeds / law.v_S) ** 2))
    return ULP_OF_EXP * np.spacing(stribeck) + np.spacing(np.abs(forces))


# ---------------------------------------------------------------- the declarations match the C

def struct_fields() -> list[str]:
    header = (SOURCE_DIR / "framework" / "friction.h").read_text()
    body = re.search(r"typedef struct \{(.*?)\} Friction;", header, re.S).group(1)
    return re.findall(r"double\s+(\w+)\s*;", body)


def test_law_has_friction_h_fields_in_their_order():
    assert list(LAW_TERMS) == struct_fields() == ["k_fw", "F_K", "F_S", "dk_fw", "dF_K", "v_S", "F_O", "drag"]


@pytest.mark.parametrize("joint", JOINTS.values(), ids=JOINTS)
def test_joint_names_the_parameters_its_model_c_passes_to_friction_h(joint):
    """The parameters of each term, as the component's model.c fills friction.h's struct."""
    source = (SOURCE_DIR / joint.component / "model.c").read_text()
    filled = re.search(r"const Friction f = \{(.*?)\};", source).group(1).split(",")
    passed = [None if item.strip() == "0.0" else re.fullmatch(r"R\((\w+)\)", item.strip()).group(1)
              for item in filled]
    assert passed == [joint.terms.get(term) for term in LAW_TERMS]


def test_a_joint_naming_a_variable_its_fmu_lacks_is_refused():
    with pytest.raises(ValueError, match="Cart has no variable k_dp"):
        Joint(**{**{f: getattr(CART, f) for f in CART.__dataclass_fields__}, "drag": "k_dp"})


def test_the_stiction_map_and_boxes_come_from_the_joints():
    from pendfmu.fitting import stages

    assert stages.STICTION_OF == {"F_Sc": "F_Kc", "T_Sp": "T_Kp"}
    assert stages.STRIBECK_OF == {"F_Sc": "v_Sc", "T_Sp": "w_Sp"}
    for joint in JOINTS.values():
        assert all(stages.DEFAULT_BOUNDS[name] == box for name, box in joint.boxes.items())
        assert all(stages.DERIVED_BOUNDS[name] == rule for name, rule in joint.derived.items())
        # an asymmetry or an offset has no default box: its sign and size are the rig's
        assert not {joint.offset, joint.viscous_asymmetry, joint.coulomb_asymmetry} & set(stages.DEFAULT_BOUNDS)


# ---------------------------------------------------------------- the twin against the FMUs

@pytest.mark.parametrize("joint, base, case, extra", CASES, ids=[f"{j.name}-{c}" for j, _, c, _ in CASES])
def test_sliding_friction_equals_the_fmus_both_ways(at_start, joint, base, case, extra):
    values = {**base, **extra}
    law = joint.law(values)
    speeds = sweep(joint, law)
    fmu, modes = fmu_sliding(at_start[joint.name], joint, values, speeds)
    assert np.array_equal(modes, sign_of(speeds))  # every start slides, the way its speed says
    twin = law.sliding(speeds)
    assert np.all(np.abs(twin - fmu) <= rounding_limit(law, speeds, fmu)), np.max(np.abs(twin - fmu))
    if extra and set(extra) != {joint.offset}:  # guard against a vacuous comparison
        assert np.max(np.abs(twin - joint.law(base).sliding(speeds))) > 1e-3 * np.max(np.abs(twin))


def drive(joint: Joint, active: float) -> dict[str, float]:
    """What makes the joint's active force `active` at rest: the cart's current (eta k_M k_D I
    with the table's defaults), the pendulum's angle from hanging (a still cart: T_A = m_p g l sin phi)."""
    if joint is CART:
        return {"I": active / (0.4 * 0.06 * 628.3)}
    return {"phi0": math.pi - math.asin(active / (0.2 * 9.81 * 0.3))}


@pytest.mark.parametrize("joint, base, case, extra", CASES, ids=[f"{j.name}-{c}" for j, _, c, _ in CASES])
def test_a_stuck_joint_holds_the_net_force_as_the_fmu_does(at_start, joint, base, case, extra):
    law = joint.law({**base, **extra})
    start = INITIAL_STATE_PARAMETERS[joint.speed]
    for fraction in (-0.999, -0.5, 0.0, 0.3, 0.999):  # of the threshold the net force's way
        net = fraction * float(law.threshold(sign_of(fraction)))
        (friction, active), mode = at_start[joint.name]({**base, **extra, **drive(joint, net - law.F_O), start: 0.0},
                                                        [joint.friction, joint.active])
        assert mode == 0 and law.mode_at_rest(active) == 0
        assert friction == law.held(active) == law.force(0, 0.0, active)


@pytest.mark.parametrize("joint, base, case, extra", CASES, ids=[f"{j.name}-{c}" for j, _, c, _ in CASES])
def test_breakaway_thresholds_are_the_fmus(at_start, joint, base, case, extra):
    """At rest, net forces 1e-15 and 1e-12 of themselves to either side of each direction's
    threshold: the twin's mode (stuck, or sliding the net force's way) is the FMU's, from
    the FMU's own active force."""
    law = joint.law({**base, **extra})
    start = INITIAL_STATE_PARAMETERS[joint.speed]
    modes = []
    for d in (1.0, -1.0):
        threshold = float(law.threshold(d))
        for step in (-1e-12, -1e-15, 0.0, 1e-15, 1e-12):
            net = d * threshold * (1.0 + step)
            (active,), mode = at_start[joint.name]({**base, **extra, **drive(joint, net - law.F_O), start: 0.0},
                                                   [joint.active])
            assert mode == law.mode_at_rest(active), (d, step, active)
            modes.append(mode)
    assert {0, 1, -1} <= set(modes)  # the net forces straddle both thresholds



# ---------------------------------------------------------------- the report's figure of a real fit

FIT_CART = {"k_fwc": 26.0, "F_Kc": 7.0, "F_Sc": 10.5, "eta": 0.42, "v_Sc": 0.04, "F_Oc": 1.5}
FIT_PENDULUM = {"k_fwp": 1e-3, "T_Kp": 2e-3, "T_Sp": 4e-3, "k_dp": 3e-4}
LOCAL = pendfmu.GlobalOptions(enabled=False)  # short fits from a start near the truth: no global search


@pytest.fixture(scope="module")
def cart_fit(tmp_path_factory):
    """A short cart-stage fit with a Stribeck speed and an offset free, on a virtual-rig
    recording drawn with both: forward and backward sliding (so that the offset and the
    Coulomb friction separate), from a start away from the truth (3 s)."""
    out = tmp_path_factory.mktemp("stribeck-offset")
    drive = steps((0, 0.0), (0.02, 1.2), (0.2, 2.0), (0.3, -2.0), (0.45, 0.0))
    experiment = Trial("cart", "cart", 0.6, 2e-4, ("I_c", "I", "x"), drive, sidecar_parameters={"m_p": 0.0},
                            known_initial=("x", "v"))
    write_experiments(out, FIT_CART, seed=4, experiments=[experiment])
    start = {**FIT_CART, "k_fwc": 24.0, "F_Sc": 9.0, "v_Sc": 0.02, "F_Oc": 0.5}
    return pendfmu.fit("cart", [out / "cart.csv"], start, free=["v_Sc", "F_Oc"], fix=["eta"],
                       bounds={"F_Oc": (-5.0, 5.0)}, uncertainty="jacobian", progress=False, global_search=LOCAL)


@pytest.fixture(scope="module")
def pendulum_fit(tmp_path_factory):
    """A short free decay with air drag, fitted with k_dp free (7 s)."""
    out = tmp_path_factory.mktemp("drag")
    experiment = Trial("decay", "pendulum", 4.0, 2e-4, ("phi",), lambda t: 0.0,
                            truth_overrides={"phi0": math.pi + 1.0, "w0": 0.0}, known_initial=("phi", "w"))
    write_experiments(out, FIT_PENDULUM, seed=5, experiments=[experiment])
    return pendfmu.fit("pendulum", [out / "decay.csv"], {**FIT_PENDULUM, "k_dp": 1e-4}, free=["k_dp"],
                       uncertainty="jacobian", progress=False, global_search=LOCAL)


def drawn(result, joint: Joint, label: str) -> tuple[np.ndarray, np.ndarray]:
    """(x, y) of the friction figure's curve whose legend label starts with `label`."""
    axis = friction_figure(result, joint).axes[0]
    line = next(line for line in axis.get_lines() if line.get_label().startswith(label))
    return np.asarray(line.get_xdata(), float), np.asarray(line.get_ydata(), float)


def fmu_values(result, joint: Joint) -> dict[str, float]:
    """The joint's FMU parameters as the result has them: the fitted values, the rest as given."""
    names = COMPONENTS[joint.component].parameters
    values = {name: float(value) for name, value in result.parameters.items() if name in names}
    return {**values, **{name: float(e.value) for name, e in result.estimates.items() if name in names}}


def test_cart_figure_of_a_stribeck_and_offset_fit_is_the_fmus_F_F(cart_fit, at_start):
    for name in ("v_Sc", "F_Oc", "F_Sc", "F_Kc"):  # a real fit: it found the truth (measured: within 0.12 %)
        assert cart_fit.estimates[name].value == pytest.approx(FIT_CART[name], rel=0.01), name
    values = fmu_values(cart_fit, CART)
    speeds, forces = drawn(cart_fit, CART, "sliding")
    law = fitted_law(cart_fit, CART)
    assert law == CART.law(values) and law.v_S > 0 and law.F_O != 0
    assert all(np.array_equal(a, b) for a, b in zip((speeds, forces), friction_curve(law)))  # what is drawn
    assert np.sum(np.abs(speeds) < 3 * law.v_S) >= 100  # the Stribeck fall is drawn, both ways
    fmu, modes = fmu_sliding(at_start["cart"], CART, values, speeds)
    assert np.array_equal(modes, sign_of(speeds))
    assert np.all(np.abs(forces - fmu) <= rounding_limit(law, speeds, fmu)), np.max(np.abs(forces - fmu))
    plain = CART.law({name: values[name] for name in CART.plain}).sliding(speeds)
    assert np.max(np.abs(forces - plain)) > 0.2 * law.F_S  # the old figure's law would not pass


def test_the_offset_shows_as_the_drive_that_holds_each_speed(cart_fit, at_start, tmp_path):
    """The offset does not change F_F: the figure draws it as the active force that holds
    each speed, F_F - F_O. Driven by it, the FMU's cart does not accelerate (to the rounding
    of F_A = eta k_M k_D I and of the sum F_A + F_O - F_F: 4 ulp of F_F; measured 1)."""
    values = fmu_values(cart_fit, CART)
    speeds, holding = drawn(cart_fit, CART, "F_A holding the speed")
    gain = values["eta"] * values["k_M"] * values["k_D"]
    mass = values["m_c"] + values["m_p"]
    for v, active in zip(speeds[::7], holding[::7]):
        (acceleration, friction), mode = at_start["cart"]({**values, "v0": v, "I": active / gain}, ["a", "F_F"])
        assert mode == sign_of(v) and abs(acceleration) * mass <= 4 * np.spacing(abs(friction)), (v, acceleration)
    caption = next(p.caption for p in write_friction_figures(cart_fit, tmp_path) if p.file == "friction-cart.png")
    assert "v_Sc" in caption and "F_Oc" in caption and "dashed" in caption


def test_pendulum_figure_of_a_drag_fit_is_the_fmus_T_F(pendulum_fit, at_start):
    assert pendulum_fit.estimates["k_dp"].value == pytest.approx(FIT_PENDULUM["k_dp"], rel=0.2)
    values = fmu_values(pendulum_fit, PENDULUM)
    speeds, torques = drawn(pendulum_fit, PENDULUM, "sliding")
    law = fitted_law(pendulum_fit, PENDULUM)
    assert law == PENDULUM.law(values) and law.drag > 0
    fmu, modes = fmu_sliding(at_start["pendulum"], PENDULUM, values, speeds)
    assert np.array_equal(modes, sign_of(speeds))
    assert np.array_equal(torques, fmu)  # no exp in this law: bit for bit
    assert law.drag * speeds[-1] ** 2 > 0.1 * torques[-1]  # the drag shows in the curve
