"""The paper's identification stages: presets of the generic fit.

The paper identifies the rig block by block; each stage simulates only the FMUs it needs
and compares them with the signals the block's sensor recorded:

    current   CurrentLoop driven by the recorded I_c (held)       -> fitted to I
    cart      CurrentLoop -> Cart driven by I_c (held), or Cart
              driven by the recorded I (linear, ``drive="I"``), or
              by a recorded command u (held, ``drive="u"``: PWM or
              voltage drives, user guide: Drives)                  -> fitted to x
    pendulum  Pendulum driven by the recorded cart acceleration a
              (linear), or a still cart                            -> fitted to phi

Each is a Setup (experiment.py) of pendfmu's own components: the same mechanism as a
user's FMU, with the drives, matches, free parameters and estimated initial states the
paper uses. Nothing in the simulator knows the stages' names.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from pendfmu.components import COMPONENTS
from pendfmu.errors import OptionError
from pendfmu.fitting.experiment import Experiment, Setup, StartState, prepare
from pendfmu.fitting.free import Policy, free_parameters
from pendfmu.fitting.residuals import FreeParameter
from pendfmu.friction import DERIVED_BOUNDS, FRICTION_BOUNDS, STICTION_OF, STICTION_RATIO, STRIBECK_OF, STRIBECK_RATIO
from pendfmu.parameters import INITIAL_STATE_PARAMETERS, recording_values
from pendfmu.recording import Recording, RecordingError
from pendfmu.recording.measurement import default_box, is_measurement, measurement_signal
from pendfmu.simulator.graph import Wire
from pendfmu.simulator.model import Model
from pendfmu.suggest import did_you_mean


@dataclass(frozen=True)
class Stage:
    name: str
    component: str  # the FMU whose parameters are fitted
    fitted: tuple[str, ...]  # recorded signals compared with the simulation (same names as the outputs)
    default_free: tuple[str, ...]
    drives: tuple[str, ...]  # acceptable drive signals, preferred first ("" = none)
    estimated_initial: tuple[str, ...] = ()  # initial states estimated when a recording does not state them
    starts: tuple[StartState, ...] = ()  # the initial states a recording can tell (estimated on request)
    # The joint's speed, where a recording holds it (a tachometer, or a rate the logger
    # derives): its first reading tells the initial speed, and the fit compares it too when
    # asked (match).
    rates: tuple[str, ...] = ()
    # The global search's cheaper model: every k-th sample, and a longer internal step.
    # Only where the drive is slow: the cart's drive current carries the PWM ripple, which
    # a coarser sampling would alias.
    coarse_decimate: int = 1
    coarse_solver_step: float | None = None


STAGES: dict[str, Stage] = {
    "current": Stage("current", "CurrentLoop", ("I",), ("T_i", "dIdt_max"), ("I_c",), starts=(StartState("I0", "I"),)),
    "cart": Stage("cart", "Cart", ("x",), ("eta", "k_fwc", "F_Kc", "F_Sc"), ("I_c", "I", "u"),
                  coarse_solver_step=4e-4, rates=("v",),
                  starts=(StartState("x0", "x"), StartState("v0", "v"), StartState("v0", "x", rate=True))),
    "pendulum": Stage("pendulum", "Pendulum", ("phi",), ("k_fwp", "T_Kp", "T_Sp"), ("a", ""),
                      estimated_initial=("phi",), coarse_decimate=10, coarse_solver_step=4e-4, rates=("w",),
                      starts=(StartState("phi0", "phi"), StartState("w0", "w"), StartState("w0", "phi", rate=True))),
}


# The current after a jump of the command relaxes with time constant T_i (0.3 ms), which is
# not much longer than a 0.2 ms sample: passed to the cart linearly interpolated between
# samples, its impulse was off by enough to move the cart's estimates by many of their
# standard errors (the cart's position against an exact event-driven simulator: up to
# 0.9 encoder steps after a step, 0.5 on a staircase ramp, whose small steps all err the
# same way). Every step in which the current has not settled is stepped on a finer grid.
SUBSTEPS = 8  # communication steps per sample inside a transient: the chord error falls 64-fold
SETTLE = 8.0  # a transient lasts the slew |jump| / dIdt_max plus SETTLE time constants (e^-8)


def transient_grid(times: np.ndarray, command: np.ndarray, T_i: float, dIdt_max: float
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Communication points for a chain driven by a held command: the samples, with
    SUBSTEPS points per sample while the current settles after a change. Returns the
    points and the index of each sample among them."""
    jumps = np.abs(np.diff(command))
    refine = np.zeros(len(times), bool)  # refine[k]: the step from sample k to k+1
    changes = np.flatnonzero(jumps > 0) + 1
    if len(changes):
        ends = times[changes] + jumps[changes - 1] / dIdt_max + SETTLE * T_i
        last = np.searchsorted(times, ends, side="right")
        # sample k is refined when a change at or before it has not settled by k
        marks = np.zeros(len(times) + 1, int)
        np.add.at(marks, changes, 1)
        np.add.at(marks, last, -1)
        refine = np.cumsum(marks[:-1]) > 0
    refine[-1] = False
    if not refine.any():
        return times, np.arange(len(times))
    counts = np.where(refine, SUBSTEPS, 1)
    starts = np.repeat(times, counts)
    within = np.arange(len(starts)) - np.repeat(np.cumsum(counts) - counts, counts)
    widths = np.repeat(np.append(np.diff(times), 0.0) / counts, counts)
    points = starts + within * widths
    return points, np.cumsum(counts) - counts


def settling_current(times: np.ndarray, drives: Mapping[str, np.ndarray], values: Mapping[str, float]
                     ) -> tuple[np.ndarray, np.ndarray]:
    """The cart stage's refinement (a Replay's `refine`): the transient grid of its command."""
    return transient_grid(times, drives["CurrentLoop.I_c"], values["T_i"], values["dIdt_max"])


# A command-driven cart (drive u) has no current: the force is eta (k_u u - k_emf v), and eta
# multiplies both k_u and k_emf, so only their products with eta show in x: the fit keeps eta
# at its given value. Without a lag the back-EMF acts on x exactly as viscous friction does
# (both proportional to v while sliding, both 0 at rest): x shows k_fwc + eta k_emf only, so
# the fit keeps k_fwc at its given value (from a current-driven run, the paper's cart stage)
# and estimates the drive's gain, back-EMF and the Coulomb friction and stiction.
COMMAND_FREE = ("k_u", "k_emf", "F_Kc", "F_Sc")


def default_free(stage: str, drives: Sequence[str]) -> tuple[str, ...]:
    """The parameters a stage fits unless told otherwise, for recordings driven by `drives`."""
    if stage == "cart" and "u" in drives:
        return COMMAND_FREE
    return STAGES[stage].default_free


@lru_cache(maxsize=None)
def stage_setup(stage: str, drive: str, compared: tuple[str, ...] = ()) -> Setup:
    """The Setup of a stage driven by the recorded column `drive` ("" for none), that
    compares its rates named in `compared` (match) besides its own signals."""
    spec = STAGES[stage]
    match = {name: name for name in (*spec.fitted, *compared)}
    estimated = {name: INITIAL_STATE_PARAMETERS[name] for name in spec.estimated_initial}
    measured = {name: INITIAL_STATE_PARAMETERS[name] for name in spec.rates}
    coarse = {"solver_step": spec.coarse_solver_step} if spec.coarse_solver_step else {}
    if stage == "cart" and drive == "I_c":
        model = Model.of_components("cart", {"CurrentLoop": "CurrentLoop", "Cart": "Cart"},
                                    [Wire("CurrentLoop", "I_mean", "Cart", "I")])
        return Setup(stage, model, {"I_c": ("I_c", "hold")}, match, estimated, settling_current,
                     spec.coarse_decimate, coarse, spec.starts, measured)
    model = Model.of_components(stage, {spec.component: spec.component})
    # a recorded current is held, as the converter's command is, and so is a drive command u
    # (PWM duty, voltage); a recorded current or acceleration the cart follows is smooth, so
    # linear between samples
    drives = {drive: (drive, "hold" if drive in ("I_c", "u") else "linear")} if drive else {}
    return Setup(stage, model, drives, match, estimated, None, spec.coarse_decimate, coarse, spec.starts, measured)


def make_experiment(recording: Recording, stage: str, parameters: Mapping[str, float],
                    drive: str | None = None, per_recording: Sequence[str] = (), start: str = "estimated",
                    match: Mapping[str, str] | None = None) -> Experiment:
    """Check that `recording` has what `stage` needs and gather its fixed values. `match`:
    the stage's rates to compare as well (compared_rates)."""
    if stage not in STAGES:
        raise RecordingError(f"unknown stage {stage!r}; stages: {', '.join(STAGES)}")
    spec = STAGES[stage]
    where = str(recording.path)
    compared = compared_rates(stage, match)
    for name in (*spec.fitted, *compared):
        if name not in recording.signals:
            raise RecordingError(f"{where}: stage {stage} needs the recorded signal {name!r}"
                                 f"{' (match)' if name in compared else ''}; "
                                 f"columns: {', '.join(('time', *recording.signals))}")
    chosen = _choose_drive(recording, spec, drive)
    fixed = recording_values(parameters, recording)
    return prepare(recording, stage_setup(stage, chosen, compared), fixed, per_recording, start)


def compared_rates(stage: str, match: Mapping[str, str] | None) -> tuple[str, ...]:
    """The rates a stage compares besides its own signals, as the `match` option asks: each
    output one of the stage's rates (w for the pendulum, v for the cart), compared with the
    recorded column of its name; the stage's own signals may be named and change nothing."""
    spec = STAGES[stage]
    compared = []
    for output, column in (match or {}).items():
        if output not in (*spec.fitted, *spec.rates) or column != output:
            own = ", ".join(spec.rates) or "none"
            raise OptionError("match", f"the {stage} stage compares {', '.join(spec.fitted)} and, when asked, its "
                                       f"recorded rate ({own}) with the column of the same name; not "
                                       f"{output}={column}")
        if output in spec.rates:
            compared.append(output)
    return tuple(compared)


def _choose_drive(recording: Recording, spec: Stage, drive: str | None) -> str:
    if drive is not None:
        if drive not in spec.drives:
            raise RecordingError(f"stage {spec.name} is driven by {' or '.join(d for d in spec.drives if d)}, "
                                 f"not {drive!r}")
        if drive and drive not in recording.signals:
            raise RecordingError(f"{recording.path}: no column {drive!r} to drive the {spec.name} stage")
        return drive
    for candidate in spec.drives:
        if candidate == "" or candidate in recording.signals:
            return candidate
    raise RecordingError(f"{recording.path}: stage {spec.name} needs a drive signal "
                         f"({' or '.join(spec.drives)}); columns: {', '.join(('time', *recording.signals))}")


# name: (low, high, logarithmic). Physical ranges wide enough for any lab rig.
DEFAULT_BOUNDS: dict[str, tuple[float, float, bool]] = {
    "T_i": (1e-5, 1e-1, True), "dIdt_max": (10.0, 1e6, True),
    "a_h": (0.0, 1.0, False), "f_h": (1.0, 1e5, True), "phase_h": (-math.pi, math.pi, False),
    "eta": (0.05, 1.0, False),
    "m_c": (0.05, 100.0, True), "x0": (-1.0, 1.0, False), "v0": (-5.0, 5.0, False),
    "J_p": (1e-6, 10.0, True), "w0": (-20.0, 20.0, False),
    # The friction terms' boxes, the extras' included, are the joints' (pendfmu.friction).
    **FRICTION_BOUNDS,
    # Drives (docs/user-guide/drives.md). k_u: a motor of k_M/R = 0.01-1 N.m/(V.ohm) on a 1-100 mm pitch
    # gives 0.1 to 6e4 N per volt, a normalized PWM command the same times its full voltage.
    # k_emf = k_M^2 k_D^2 / R: from 1e-2 (a weak motor on a coarse pitch) to 1e5 N.s/m.
    # tau_e = L/R of the winding or a drive's filter: 0.1 ms to 1 s. A reversed sign of k_u
    # (wiring) needs --bounds.
    "k_u": (1e-2, 1e5, True), "k_emf": (1e-2, 1e5, True), "tau_e": (1e-4, 1.0, True),
}


SEARCH_DECADE = 10.0  # default search box: the given value divided and multiplied by this

SPEED_WINDOW = 0.01  # the largest speed: position differences over 1 % of a recording (>= 10 samples)


def rig_scales(values: Mapping[str, float], experiments: Sequence[Experiment]) -> dict[str, float]:
    """The scales of DERIVED_BOUNDS from the known values (`values`: given, else the
    reference rig's) and the recordings: torque [N m], rotation [N m s], force [N] (the
    drive's largest: k_M k_D |I| or k_u |u|, else the weight), translation [N s/m]."""
    g = values.get("g", 9.81)
    torque = values["m_p"] * g * values["l"]
    inertia = values.get("J_p", 0.0) or 4.0 / 3.0 * values["m_p"] * values["l"] ** 2  # 0: a uniform rod
    scales = {"torque": torque, "rotation": torque / math.sqrt(torque / inertia) if torque > 0 else 0.0}
    current = command = 0.0
    speed = 0.0
    for experiment in experiments:
        for column, _ in experiment.setup.drives.values():
            if column in ("I", "I_c", "u"):
                drive = experiment.recorded(column)
                largest = float(np.max(np.abs(drive[np.isfinite(drive)]), initial=0.0))
                if column == "u":
                    command = max(command, largest)
                else:
                    current = max(current, largest)
        if "x" in experiment.recording.signals:
            speed = max(speed, largest_speed(experiment.time, experiment.recorded("x")))
    # the drive's largest force: the current's through the motor, or the command's (docs/user-guide/drives.md)
    force = max(values.get("k_M", 0.0) * values.get("k_D", 0.0) * current, abs(values.get("k_u", 0.0)) * command)
    if not force > 0:
        force = (values.get("m_c", 0.0) + values.get("m_p", 0.0)) * g
    scales["force"] = force
    scales["translation"] = force / speed if speed > 0 else force  # no motion seen: per m/s
    return scales


def largest_speed(time: np.ndarray, position: np.ndarray) -> float:
    """The largest |speed| of a position record: differences over SPEED_WINDOW of its
    samples (at least 10), so that a sensor step between two samples is not a speed."""
    present = np.isfinite(position)
    t, x = time[present], position[present]
    n = max(10, int(SPEED_WINDOW * len(t)))
    if len(t) <= n:
        return 0.0
    return float(np.max(np.abs((x[n:] - x[:-n]) / (t[n:] - t[:-n]))))


def derived_box(name: str, values: Mapping[str, float], experiments: Sequence[Experiment]
                ) -> tuple[float, float] | None:
    """The box of a friction parameter without a given value (DERIVED_BOUNDS), or None
    for any other parameter or when the rig's scales are unknown."""
    if name not in DERIVED_BOUNDS:
        return None
    kind, low, high = DERIVED_BOUNDS[name]
    try:
        scale = rig_scales(values, experiments)[kind]
    except KeyError:
        return None
    if not (math.isfinite(scale) and scale > 0):
        return None
    return low * scale, high * scale


def _stribeck(stiction: str, names: Sequence[str], fix: Sequence[str], values: Mapping[str, float]) -> bool:
    """Whether the stiction's joint has a Stribeck speed: fitted, or given above 0."""
    speed = STRIBECK_OF[stiction]
    return (speed in names and speed not in fix) or values.get(speed, 0.0) > 0.0


def stage_has(stage: str, name: str, recordings: Sequence[Recording]) -> bool:
    """Whether a parameter belongs to a stage, so that the sequence ("all") passes an option
    naming it there: a parameter of the stage's component, or a sensor's offset, scale or
    delay of a signal the stage's recordings hold."""
    component = COMPONENTS[STAGES[stage].component]
    signals = {signal for recording in recordings for signal in recording.signals}
    return name in component.parameters or is_measurement(name, signals)


def stage_free_parameters(stage: str, experiments: list[Experiment], free: Sequence[str] | None,
                          fix: Sequence[str], bounds: Mapping[str, tuple[float, float]],
                          values: Mapping[str, float], given: Collection[str] | None = None
                          ) -> list[FreeParameter]:
    """The stage's free parameters (its own, `free`, the recordings' own estimates) with
    their search boxes (free.py; the stage's rules: stage_policy)."""
    return free_parameters(stage_policy(stage, experiments, values, given), experiments, free or (), fix, bounds,
                           values)


def stage_policy(stage: str, experiments: Sequence[Experiment], values: Mapping[str, float],
                 given: Collection[str] | None = None) -> Policy:
    """A stage's rules for its free parameters: its default free set (for its drives), the
    names it knows (its component's parameters, its sensors' offset, scale and delay), and
    its boxes: --bounds, else DEFAULT_BOUNDS narrowed to a decade either side of a given
    value, stiction relative to Coulomb friction, a measurement parameter's box from the
    data (measurement.default_box).

    `given`: the names whose value the user gave (params, a sidecar). A friction
    parameter not among them has no value of its own (`values` then holds the reference
    rig's), and its box is derived from the rig's known sizes and the recordings
    (derived_box). None (the default, as before): every value in `values` counts as given."""
    spec = STAGES[stage]
    component = COMPONENTS[spec.component]
    signals = {column for e in experiments for column in (*e.match.values(), *(c for c, _ in e.setup.drives.values()))}
    drives = {column for experiment in experiments for column, _ in experiment.setup.drives.values()}
    listing = ", ".join(n for n in component.parameters if n != "solver_step")

    def check(option: str, name: str) -> None:
        if not (name in component.parameters or is_measurement(name, signals)):
            raise OptionError(option, f"the {stage} stage fits parameters of {spec.component} and the sensors' "
                                      f"offset, scale and delay (e.g. {spec.fitted[0]}_offset, input_delay); "
                                      f"{name!r} is not one{did_you_mean(name, component.parameters)} (valid: "
                                      f"{listing})")

    def shared_box(name, names, fix, bounds):
        return _box(name, names, fix, bounds, values, experiments, given)

    def own_box(name, bounds, experiment):
        if name in bounds:
            return (*bounds[name], False)
        own_given = None if given is None else {*given, *experiment.recording.parameters}
        low, high, log, _ = _box(name, [], [], {}, {**values, **experiment.fixed}, [experiment], own_given)
        return low, high, log

    def hint(name: str) -> str:
        ripple = stage == "current" and name in ("a_h", "f_h", "phase_h")
        return "; the PWM ripple is fitted where it is found (harmonic 'off' leaves it out)" if ripple else ""

    return Policy(f"the {stage} stage", default_free(stage, sorted(drives)), check, shared_box, own_box,
                  lambda name: _declared(component, name), listing, hint)


def _declared(component, name: str) -> tuple[float | None, float | None]:
    """A parameter's range in the component's table ((None, None) for a sensor's parameter)."""
    row = component.parameters.get(name)
    return (None, None) if row is None else (row.low, row.high)


def _box(name: str, names: Sequence[str], fix: Sequence[str], bounds: Mapping[str, tuple[float, float]],
         values: Mapping[str, float], experiments: Sequence[Experiment], given: Collection[str] | None = None
         ) -> tuple[float, float, bool, str | None]:
    """(low, high, logarithmic, relative_to) of one parameter (stage_free_parameters)."""
    if measurement_signal(name) is not None and name not in DEFAULT_BOUNDS:
        if name in bounds:
            return (*bounds[name], False, None)
        return (*default_box(name, experiments[0].recording), None)
    low, high, log = DEFAULT_BOUNDS.get(name, (None, None, False))
    prior = values.get(name)
    derived = derived_box(name, values, experiments) if given is not None and name not in given else None
    if derived is not None and name not in bounds:
        low, high = derived
    elif log and prior and prior > 0 and name not in bounds:
        # Search a decade either side of the given value: a lab engineer's prior is
        # rarely off by more, and a box of five decades leaves the global search lost.
        low, high = max(low, prior / SEARCH_DECADE), min(high, prior * SEARCH_DECADE)
    relative_to = None
    if name in bounds:
        low, high = bounds[name]
        log = log and low > 0
    elif name in STICTION_OF and STICTION_OF[name] in names and STICTION_OF[name] not in fix:
        ratio = STRIBECK_RATIO if _stribeck(name, names, fix, values) else STICTION_RATIO
        relative_to, (low, high), log = STICTION_OF[name], ratio, True
    elif name in STICTION_OF and not _stribeck(name, names, fix, values):
        low = max(low, values.get(STICTION_OF[name], 0.0))  # below Coulomb friction it has no effect
        if derived is not None and not high > low:  # a given Coulomb friction above the derived box
            high = low * SEARCH_DECADE
    if low is None or not high > low:
        raise OptionError("bounds", f"{name}: no search box of its own; give one: {name}=LOW:HIGH (LOW < HIGH)")
    return low, high, log, relative_to
