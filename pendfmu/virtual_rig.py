"""The virtual rig: the paper's identification experiments, simulated with known truth
and recorded through models of the rig's sensors.

Each experiment runs only the FMUs the real one involves (the current loop alone, the
cart without pendulum, the pendulum with the cart still, or the whole rig), samples the
true signals and passes them through the sensors of the paper's rig (docs/user-guide/model.md):

- motor encoder, 1024 counts per revolution: x in steps of 2 pi / (1024 k_D);
- 10-bit absolute pendulum encoder: phi in steps of 2 pi / 1024;
- current: the PWM ripple is the current loop's harmonic (a_h, f_h, phase_h of the
  truth), read by a 12-bit ADC over +-10 A with Gaussian noise, seeded.

Recordings are written as CSV + sidecar (pendfmu/recording/FORMAT.md) with ``truth.json`` beside.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pendfmu.components import COMPONENTS, back_drivable, rig_defaults
from pendfmu.console import progress
from pendfmu.fitting.labels import is_own
from pendfmu.friction import CART, PENDULUM, STICTION_OF
from pendfmu.parameters import write_parameters
from pendfmu.physics import overlay, settled
from pendfmu.recording import Recording, SignalInfo, quantize, write_recording
from pendfmu.simulator.component import ComponentFMU
from pendfmu.simulator.graph import Wire
from pendfmu.simulator.master import ExternalInput, Master

ENCODER_COUNTS = 1024
ADC_RANGE = 10.0  # +-10 A
ADC_BITS = 12
ADC_NOISE = 4e-3  # A, standard deviation
# The PWM ripple of the virtual converter: the truth differs here from the FMU's default
# (no ripple) on purpose, so that the current stage has a ripple to find.
RIPPLE = {"a_h": 0.03, "f_h": 2000.0, "phase_h": 0.5}
# Communication steps per sample when the rig is a co-simulation: the truth must not carry
# the coupling's own error (the current, linearly interpolated between 0.2 ms samples,
# moved the cart by up to 0.6 encoder steps against an exact event-driven simulator).
TRUTH_SUBSTEPS = 10


# The parameters each stage of the paper identifies: what a drawn truth varies.
# A joint's friction (the paper's law) in the order viscous, Coulomb, stiction: stiction is drawn
# relative to the Coulomb friction drawn before it.
STAGE_PARAMETERS = {"current": ("T_i", "dIdt_max", "a_h", "f_h", "phase_h"),
                    "cart": ("eta", *CART.plain),
                    "pendulum": PENDULUM.plain}
FACTOR = (0.6, 1.6)  # a drawn parameter's factor on the reference value (log-uniform)
SPREADS = {"standard": FACTOR, "wide": (0.5, 2.0)}  # draw_truth's ranges of factors, by name
MIN_STICTION_RATIO = 1.2
RELEASE_ANGLE = 0.6  # rad from hanging: the free decay's release


def reference_truth() -> dict[str, float]:
    """The reference rig (docs/user-guide/model.md; the table's defaults) with the virtual
    converter's RIPPLE."""
    return {**rig_defaults(), **RIPPLE}


def _log_uniform(rng: np.random.Generator, low: float, high: float) -> float:
    return float(math.exp(rng.uniform(math.log(low), math.log(high))))


def draw_truth(seed: int, index: int = 0, spread: str = "standard") -> tuple[dict[str, float], float]:
    """A rig unlike the reference one, and a release angle: truth `index` of the series `seed`.

    Every identified parameter (STAGE_PARAMETERS) is its reference value times a factor
    drawn log-uniformly in SPREADS[spread] (standard: FACTOR, x0.6-1.6; wide: x0.5-2):
    log-uniform because the parameters are scales, the fit searches them on a log scale and
    its errors are relative (a uniform factor would put 60 % of the draws above the
    reference). Stiction is drawn as its Coulomb friction times a ratio, log-uniform within
    what keeps the stiction itself within the same factors of its reference and the ratio at
    least MIN_STICTION_RATIO: near 1 stiction hardly shows (the breakaway is at
    max(F_S, F_K)), a different, ill-posed question. The release angle of the free decay is
    RELEASE_ANGLE times a factor in the same range, to either side.

    Nothing makes the cart break away in its slow ramp: a weak drive (low eta) against high
    stiction leaves it stuck there, with only the steps to tell the cart's friction
    (cart_ramp_breaks_away says which truths).

    `pendfmu rig --seed N` records truth 0 of the standard series N, so that a fit starting
    from the reference values has something to find; the coverage benchmark draws many.
    """
    if spread not in SPREADS:
        raise ValueError(f"spread {spread!r}: one of {', '.join(SPREADS)}")
    factor = SPREADS[spread]
    rng = np.random.default_rng([seed, index])
    reference = reference_truth()
    truth: dict[str, float] = {}
    for name in (n for names in STAGE_PARAMETERS.values() for n in names):
        if name in STICTION_OF:
            coulomb = STICTION_OF[name]
            ratio_ref = reference[name] / reference[coulomb]
            scale = reference[coulomb] / truth[coulomb]  # the drawn Coulomb's factor, inverted
            low = max(MIN_STICTION_RATIO, factor[0] * ratio_ref * scale)
            high = factor[1] * ratio_ref * scale
            truth[name] = truth[coulomb] * _log_uniform(rng, low, high)
        else:
            truth[name] = reference[name] * _log_uniform(rng, *factor)
    angle = RELEASE_ANGLE * _log_uniform(rng, *factor) * float(rng.choice([-1.0, 1.0]))
    return truth, angle


def cart_ramp_breaks_away(truth: Mapping[str, float]) -> bool:
    """Whether the cart of `truth` breaks away in the cart-ramp experiment: the drive force
    eta k_M k_D I at the ramp's last command exceeds the breakaway threshold max(F_Sc, F_Kc)
    (the paper's friction law; the current follows its slow command within T_i, a fraction of
    a sample)."""
    values = {**reference_truth(), **truth}
    ramp = next(e for e in standard_experiments() if e.name == "cart-ramp")
    force = values["eta"] * values["k_M"] * values["k_D"] * ramp.drive(ramp.duration)
    return force > max(values["F_Sc"], values["F_Kc"])


def steps(*levels: tuple[float, float]) -> Callable[[float], float]:
    """A piecewise-constant command: (time from which it holds, value) pairs."""
    times = np.array([t for t, _ in levels])
    values = np.array([v for _, v in levels])
    return lambda t: float(values[max(int(np.searchsorted(times, t, side="right")) - 1, 0)])


@dataclass(frozen=True)
class Trial:
    """One recording to make on the virtual rig: what runs, what drives it, what is recorded
    and how often. (A trial of the rig; a recording prepared for a fit is fitting's Experiment.)"""

    name: str
    kind: str  # current | cart | pendulum | rig
    duration: float
    sample: float
    recorded: tuple[str, ...]
    drive: Callable[[float], float]  # I_c(t), or the cart acceleration a(t) for kind pendulum
    truth_overrides: Mapping[str, float] = field(default_factory=dict)  # e.g. the release angle
    sidecar_parameters: Mapping[str, float] = field(default_factory=dict)
    known_initial: tuple[str, ...] = ()  # initial states the sidecar states (from the sensors)
    description: str = ""


def standard_experiments(release_angle: float = RELEASE_ANGLE) -> list[Trial]:
    """The paper's sequence (docs/user-guide/model.md, 'The identification experiments'); the
    free decay starts `release_angle` from hanging."""
    experiments = [
        Trial("current-steps", "current", 0.022, 20e-6, ("I_c", "I"),
                   steps((0, 0.0), (1e-3, 1.5), (6e-3, 3.0), (11e-3, 0.5), (16e-3, -2.0)),
                   description="steps of the command current; the current loop alone"),
        Trial("cart-startup-2A", "cart", 1.2, 2e-4, ("I_c", "I", "x"),
                   steps((0, 0.0), (0.05, 2.0), (0.6, 0.0)), sidecar_parameters={"m_p": 0.0},
                   known_initial=("x", "v"), description="start-up and braking, pendulum removed"),
        Trial("cart-startup-3A", "cart", 1.2, 2e-4, ("I_c", "I", "x"),
                   steps((0, 0.0), (0.05, 3.0), (0.45, 0.0)), sidecar_parameters={"m_p": 0.0},
                   known_initial=("x", "v"), description="start-up and braking, pendulum removed"),
        Trial("cart-ramp", "cart", 2.0, 2e-4, ("I_c", "I", "x"),
                   lambda t: 0.6 * t, sidecar_parameters={"m_p": 0.0}, known_initial=("x", "v"),
                   description="slow current ramp through breakaway, pendulum removed"),
        Trial("pendulum-decay", "pendulum", 30.0, 2e-4, ("phi",), lambda t: 0.0,
                   truth_overrides={"phi0": math.pi + release_angle, "w0": 0.0}, known_initial=("w",),
                   description="free damped swing from an unknown release angle, cart still"),
        Trial("pendulum-stiction", "pendulum", 12.0, 2e-4, ("a", "phi"),
                   lambda t: 0.5 * math.sin(2 * math.pi * t / 4.0),
                   truth_overrides={"phi0": math.pi, "w0": 0.0}, known_initial=("phi", "w"),
                   description="pendulum at rest, cart rocked slowly (a = 0.5 sin(2 pi t/4) m/s2): "
                               "every stick-slip starts where the tilt torque exceeds T_Sp"),
        Trial("coupled-step", "rig", 3.0, 2e-4, ("I_c", "I", "x", "phi"),
                   steps((0, 0.0), (0.05, 1.5), (0.4, 0.0)), truth_overrides={"phi0": math.pi},
                   known_initial=("x", "v", "phi", "w"),
                   description="current step moves the cart and sets the pendulum swinging"),
    ]
    for k, angle in enumerate((-0.3, 0.0, 0.3)):
        experiments.append(Trial(
            f"bangbang-{k}", "rig", 3.0, 2e-4, ("I_c", "I", "x", "phi"),
            steps((0, 0.0), (0.05, 2.5), (0.35, -2.5), (0.65, 0.0)),
            truth_overrides={"phi0": math.pi + angle}, known_initial=("x", "v", "phi", "w"),
            description=f"bang-bang cart move, pendulum released at pi{angle:+.1f} rad"))
    return experiments


@dataclass
class Sensors:
    """The rig's sensors, seeded: quantizers and the current ADC's noise."""

    k_D: float
    rng: np.random.Generator

    def info(self) -> dict[str, SignalInfo]:
        return {"x": SignalInfo(2 * math.pi / (ENCODER_COUNTS * self.k_D)),
                "phi": SignalInfo(2 * math.pi / ENCODER_COUNTS),
                "I": SignalInfo(2 * ADC_RANGE / 2**ADC_BITS, noise=ADC_NOISE)}

    def read(self, name: str, true: np.ndarray) -> np.ndarray:
        info = self.info().get(name)
        if info is None:
            return true  # commanded signals (I_c, a) are known exactly
        values = true
        if info.noise:
            values = values + self.rng.normal(0.0, info.noise, size=values.shape)
        if name == "I":
            values = np.clip(values, -ADC_RANGE, ADC_RANGE)
        return quantize(values, info.resolution)


def _of(component: str, values: Mapping[str, float]) -> dict[str, float]:
    return {k: v for k, v in values.items() if k in COMPONENTS[component].parameters}


def experiment_truth(experiment: Trial, truth: Mapping[str, float]) -> dict[str, float]:
    """The values an experiment runs with: the truth, its own overrides, its sidecar's (a
    J_cm as J_p), checked together (physics.settled)."""
    where = f"experiment {experiment.name}"
    return settled(overlay({**truth, **experiment.truth_overrides}, experiment.sidecar_parameters, where), where)


def simulate_truth(experiment: Trial, truth: Mapping[str, float]) -> dict[str, np.ndarray]:
    """The true signals of an experiment at its sample times."""
    values = experiment_truth(experiment, truth)
    times = np.arange(int(round(experiment.duration / experiment.sample)) + 1) * experiment.sample
    if experiment.kind == "current":
        with ComponentFMU("CurrentLoop", _of("CurrentLoop", values)) as loop:
            result = loop.run(times, ["I"], inputs=lambda t: {"I_c": experiment.drive(t)})
        return {"time": times, "I_c": np.array([experiment.drive(t) for t in times]), "I": result["I"]}
    if experiment.kind == "pendulum":
        with ComponentFMU("Pendulum", _of("Pendulum", values)) as pendulum:
            result = pendulum.run(times, ["phi", "w"], inputs=lambda t: {"a": experiment.drive(t)},
                                  derivatives=lambda t: {"a": [_slope(experiment.drive, t)]})
        return {"time": times, "a": np.array([experiment.drive(t) for t in times]), **result}
    components = {"CurrentLoop": "CurrentLoop", "Cart": "Cart"}
    connections = [Wire("CurrentLoop", "I_mean", "Cart", "I")]
    outputs = ["CurrentLoop.I", "Cart.x", "Cart.v"]
    if experiment.kind == "rig":
        components["Pendulum"] = "Pendulum"
        connections.append(Wire("Cart", "a", "Pendulum", "a"))
        if back_drivable(values):
            connections += [Wire("Pendulum", v, "Cart", v) for v in ("phi", "w", "alpha")]
        outputs += ["Pendulum.phi", "Pendulum.w"]
    master = Master(components, connections, {name: _of(name, values) for name in components},
                    step=experiment.sample / TRUTH_SUBSTEPS)
    command = np.array([experiment.drive(t) for t in times])
    frame = master.run(times, outputs, {"CurrentLoop.I_c": ExternalInput(times, command, "hold")})
    return {"time": times, "I_c": command, **{c.split(".")[1]: frame[c].to_numpy() for c in outputs}}


def _slope(drive: Callable[[float], float], t: float, h: float = 1e-6) -> float:
    return (drive(t + h) - drive(t - h)) / (2 * h)


def record(experiment: Trial, truth: Mapping[str, float], sensors: Sensors) -> Recording:
    """Simulate an experiment and read it through the sensors."""
    true = simulate_truth(experiment, truth)
    signals = {name: sensors.read(name, true[name]) for name in experiment.recorded}
    initial = {name: float(sensors.read(name, true[name][:1])[0]) if name in sensors.info() else float(true[name][0])
               for name in experiment.known_initial}
    info = {name: i for name, i in sensors.info().items() if name in signals}
    return Recording(path=Path(f"{experiment.name}.csv"), time=true["time"], signals=signals,
                     experiment=f"{experiment.name}: {experiment.description}", signal_info=info,
                     parameters=dict(experiment.sidecar_parameters), initial=initial)


def write_experiments(out: str | Path, truth: Mapping[str, float] | None = None, seed: int = 0,
                      experiments: list[Trial] | None = None, **about: object) -> list[Path]:
    """Write every experiment's recording into `out`, and the truth as truth.json (with
    the noise seed, each recording's own true values such as a release angle under
    "recordings", and `about`, e.g. how the truth was chosen)."""
    values = settled(overlay(reference_truth(), truth or {}, "the rig's parameters"), "the rig's parameters")
    experiments = experiments or standard_experiments()
    for experiment in experiments:  # each rig as it runs, refused before anything is simulated or written
        experiment_truth(experiment, values)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    sensors = Sensors(values["k_D"], np.random.default_rng(seed))
    paths = []
    for experiment in progress(experiments, "recording the virtual rig", label=lambda e: e.name):
        recording = record(experiment, values, sensors)
        paths.append(write_recording(recording, out / f"{experiment.name}.csv"))
    own = {e.name: dict(e.truth_overrides) for e in experiments if e.truth_overrides}
    write_parameters(values, out / "truth.json", seed=seed, recordings=own, **about)
    paths.append(out / "truth.json")
    return paths


@dataclass(frozen=True)
class TruthRow:
    """One fitted parameter against the virtual rig's truth."""

    name: str
    truth: float
    value: float
    low: float  # the 95 % interval (or the set a bounded parameter is confined to); nan if none
    high: float
    method: str

    @property
    def holds(self) -> bool:
        return bool(self.low <= self.truth <= self.high)


def against_truth(estimates: Mapping[str, object], truth: Mapping[str, float]) -> list[TruthRow]:
    """Each estimate of a rig parameter with the truth it should have found. Per-recording
    estimates (``phi0[pendulum-decay]``) are left out: their truth is the recording's own."""
    rows = []
    for name, estimate in estimates.items():
        if is_own(name) or name not in truth:
            continue
        low, high = estimate.ci95 if estimate.ci95 else (math.nan, math.nan)
        rows.append(TruthRow(name, float(truth[name]), float(estimate.value), float(low), float(high),
                             str(estimate.method)))
    return rows


def read_truth(folder: str | Path) -> dict[str, float] | None:
    """The truth.json `pendfmu rig` wrote into `folder`, or None when there is none."""
    from pendfmu.parameters import read_parameters

    path = Path(folder) / "truth.json"
    return read_parameters(path) if path.is_file() else None
