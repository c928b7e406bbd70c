"""Verification before the rig: the designed controller in closed loop with the identified
model and with every bootstrap replicate of the fit (issue 27, step 3).

A run co-simulates `DIR/ClosedLoop.ssp` (report.py: pendfmu's rig FMUs and the
RigController FMU as designed) with pendfmu's master at the controller's T_s, for
`duration` s, from rest at x = 0 and the task's start: 0.1 rad from upright for balance,
hanging (pi) for swing-up. The rig's values are one rig's: the fit's estimate, or one
replicate of its bootstrap (the result's "replicates": per replicate, the values every
stage's refit found, chained as the fit chains its stages), so the spread of the runs is
the spread of what the recordings allow the true rig to be. The controller reads its
inputs rounded to the encoders' steps (its x_quantum and phi_quantum), samples every T_s,
and its command is limited to its I_max.

Each run is judged by the requirements (the issue's by default): capture within 12 s (the
pendulum within CAPTURED of upright from then to the end), and over the last WINDOW s the
RMS of phi at most one encoder step, of x at most 10 mm, of I_c at most 1 A (chatter), and
|x| within the track throughout. Runs go in parallel on local worker processes or a Dask
cluster (bootstrap.parallel_map), as a fit's refits do.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

CAPTURED = 0.1  # rad: the pendulum counts as caught while within this of upright
WINDOW = 10.0  # s: the RMS figures are over the run's last WINDOW seconds (half the run if shorter)
STARTS = {"balance": 0.1, "swing-up": math.pi}  # rad from upright at rest
PLOT_EVERY = 10  # samples kept for the report's plots: every 10th


@dataclass(frozen=True)
class Requirements:
    """What a closed-loop run must meet: capture time [s], RMS of phi [encoder steps], of x
    [m] and of I_c [A] over the last WINDOW s, and the largest |x| [m] (the track; None: the
    design's x_max)."""

    capture: float = 12.0
    phi_steps: float = 1.0
    x_rms: float = 0.010
    I_rms: float = 1.0
    x_peak: float | None = None


@dataclass(frozen=True)
class Run:
    """One closed-loop run: which rig ("identified" or a replicate's number), the task, the
    compensation, and the system's values (component.parameter -> value)."""

    rig: str
    task: str
    compensation: bool
    values: dict[str, float]
    duration: float
    T_s: float
    ssp: str
    ssp_digest: str  # the file's content: a ClosedLoop.ssp written again in place is another system
    dphi: float


@dataclass
class Outcome:
    """A run's figures (None where the run failed) and a thinned copy of its signals."""

    run: Run
    capture: float | None = None  # s; None: not caught at the end
    phi_steps: float | None = None
    x_rms: float | None = None
    I_rms: float | None = None
    x_peak: float | None = None
    failure: str = ""
    signals: dict[str, list[float]] = field(default_factory=dict)

    def meets(self, requirements: Requirements, track: float) -> bool:
        return shortfall(self, requirements, track) <= 1.0

    def figures(self) -> dict:
        return {k: getattr(self, k) for k in ("capture", "phi_steps", "x_rms", "I_rms", "x_peak")}


MISSED_CAPTURE = 10.0  # the normalized figure of a pendulum never caught: far past any limit


def shortfall(outcome: Outcome, requirements: Requirements, track: float) -> float:
    """How far a run is from its requirements: the largest of its figures over their limits
    (at most 1: it meets them all)."""
    if outcome.failure:
        return math.inf
    peak = requirements.x_peak if requirements.x_peak is not None else track
    ratios = [outcome.phi_steps / requirements.phi_steps, outcome.x_rms / requirements.x_rms,
              outcome.I_rms / requirements.I_rms, outcome.x_peak / peak,
              MISSED_CAPTURE if outcome.capture is None else outcome.capture / requirements.capture]
    return max(ratios)


def judge(time: np.ndarray, x: np.ndarray, phi: np.ndarray, I_c: np.ndarray, dphi: float) -> dict[str, float | None]:
    """The figures of a run's samples (module docstring)."""
    angle = np.mod(phi + math.pi, 2 * math.pi) - math.pi  # from upright, wrapped
    away = np.flatnonzero(np.abs(angle) >= CAPTURED)
    if away.size and away[-1] == len(time) - 1:
        capture = None
    else:
        capture = 0.0 if away.size == 0 else float(time[away[-1] + 1] - time[0])
    window = min(WINDOW, 0.5 * float(time[-1] - time[0]))
    last = time >= time[-1] - window
    rms = {name: float(np.sqrt(np.mean(np.square(values[last])))) for name, values in
           (("phi", angle), ("x", x), ("I", I_c))}
    return {"capture": capture, "phi_steps": rms["phi"] / dphi, "x_rms": rms["x"], "I_rms": rms["I"],
            "x_peak": float(np.max(np.abs(x)))}


_REPLAYS: dict[tuple[str, str, int, float], object] = {}  # per process: the loop's replay, made once


def _replay(run: Run):
    """The closed loop's Replay for this process (the SSP unpacked and its FMUs loaded once),
    known by the file's content (Run.ssp_digest): a ClosedLoop.ssp written again in place
    (another rig's wiring: the back-drive connections are there for a back-drivable screw
    only) is another system."""
    from pendfmu.simulator.model import Model
    from pendfmu.simulator.replay import Drive, Replay

    samples = int(round(run.duration / run.T_s))
    key = (run.ssp, run.ssp_digest, samples, run.T_s)
    if key not in _REPLAYS:
        times = run.T_s * np.arange(samples + 1)
        _REPLAYS[key] = Replay(Model.load(run.ssp), times, {"RigController.x_ref": Drive(np.zeros(samples + 1))})
    return _REPLAYS[key]


OUTPUTS = ("Cart.x", "Pendulum.phi", "RigController.I_c")


def simulate(run: Run) -> Outcome:
    """One run (in a worker process or here); a run that fails is an Outcome saying why."""
    from pendfmu.errors import PendfmuError

    try:
        replay = _replay(run)
        signals = replay.simulate(run.values, OUTPUTS)
    except (PendfmuError, ArithmeticError) as error:
        return Outcome(run, failure=f"{type(error).__name__}: {error}")
    x, phi, I_c = (np.asarray(signals[name], dtype=float) for name in OUTPUTS)
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(phi))):
        return Outcome(run, failure="the simulation left finite numbers")
    figures = judge(replay.times, x, phi, I_c, run.dphi)
    thinned = {"time": replay.times[::PLOT_EVERY].tolist(), "x": x[::PLOT_EVERY].tolist(),
               "phi": phi[::PLOT_EVERY].tolist(), "I_c": I_c[::PLOT_EVERY].tolist()}
    return Outcome(run, signals=thinned, **figures)


def failed_run(run: Run, reason: str) -> Outcome:
    """A run whose worker died on every try (parallel_map)."""
    return Outcome(run, failure=reason)


def replicate_rigs(result) -> list[dict[str, float]]:
    """The rig values of each bootstrap replicate the result keeps (none: a fit without a bootstrap)."""
    return [dict(values) for values in getattr(result, "replicates", []) or []]


def system_values(values: Mapping[str, float], rig: Mapping[str, float]) -> dict[str, float]:
    """The ClosedLoop's parameter values of one rig: each rig component's parameters."""
    from pendfmu.components import COMPONENTS

    merged = {**values, **rig}
    return {f"{component}.{name}": float(merged[name]) for component, table in COMPONENTS.items()
            for name in table.parameters if name in merged and name not in ("phi0", "w0", "x0", "v0")}


def plan(design, values: Mapping[str, float], replicates: Sequence[Mapping[str, float]], ssp: Path,
         duration: float, both_compensations: bool = True) -> list[Run]:
    """Every run: the identified rig and each replicate; balance, and swing-up if the design
    swings up; with the design's compensation and, where asked, with it switched; the encoders
    those the design was made for (Design.dx, dphi: the recordings' sidecars). The design
    reaches the controller as parameter values, so any ClosedLoop system will do, whatever
    design its RigController FMU was built with (a tuning tries designs without compiling)."""
    import hashlib

    from pendfmu.control.export import fmu_parameters

    tasks = ["balance"] + (["swing-up"] if design.swing_up else [])
    compensations = [design.compensation] + ([not design.compensation] if both_compensations else [])
    dx, dphi = design.x_quantum or design.dx, design.phi_quantum or design.dphi
    digest = hashlib.sha256(Path(ssp).read_bytes()).hexdigest()
    rigs = [("identified", dict(values))] + [(str(b), dict(r)) for b, r in enumerate(replicates)]
    controller = {f"RigController.{name}": float(value) for name, value in fmu_parameters(design).items()}
    runs = []
    for task in tasks:
        for compensation in compensations:
            for name, rig in rigs:
                given = {**system_values(values, rig), **controller}
                given.update({"Pendulum.phi0": STARTS[task], "Pendulum.w0": 0.0, "Cart.x0": 0.0, "Cart.v0": 0.0,
                              "RigController.swing_up": float(task == "swing-up"),
                              "RigController.compensation": float(compensation),
                              "RigController.x_quantum": dx, "RigController.phi_quantum": dphi})
                runs.append(Run(name, task, compensation, given, duration, design.T_s, str(ssp), digest, dphi))
    return runs


@dataclass
class Verification:
    """Every run's outcome and, per task and compensation, the replicates' success rate."""

    requirements: Requirements
    track: float
    outcomes: list[Outcome]
    seconds: float = 0.0

    def groups(self) -> dict[tuple[str, bool], list[Outcome]]:
        found: dict[tuple[str, bool], list[Outcome]] = {}
        for outcome in self.outcomes:
            found.setdefault((outcome.run.task, outcome.run.compensation), []).append(outcome)
        return found

    def summary(self) -> list[dict]:
        rows = []
        for (task, compensation), outcomes in self.groups().items():
            identified = next(o for o in outcomes if o.run.rig == "identified")
            replicates = [o for o in outcomes if o.run.rig != "identified"]
            met = [o for o in replicates if o.meets(self.requirements, self.track)]
            worst = {key: _worst([o.figures()[key] for o in replicates]) for key in identified.figures()}
            rows.append({"task": task, "compensation": compensation,
                         "identified": {**identified.figures(), "meets": identified.meets(self.requirements,
                                                                                          self.track),
                                        "failure": identified.failure},
                         "replicates": len(replicates), "replicates_meeting": len(met),
                         "success_rate": len(met) / len(replicates) if replicates else None,
                         "worst_replicate": worst})
        return rows

    def to_dict(self) -> dict:
        return {"requirements": asdict(self.requirements), "track": self.track, "seconds": self.seconds,
                "summary": self.summary(),
                "runs": [{"rig": o.run.rig, "task": o.run.task, "compensation": o.run.compensation,
                          **o.figures(), "meets": o.meets(self.requirements, self.track), "failure": o.failure}
                         for o in self.outcomes]}


def _worst(values: list[float | None]) -> float | None:
    """The largest of the replicates' figure; None if a run has none (an uncaught pendulum's
    capture, a failed run's every figure): that run is the worst."""
    if not values or any(v is None for v in values):
        return None
    return float(max(values))


def parallel_runs(runs: Sequence[Run], workers: int = 0, scheduler: str | None = None,
                  done: Callable[[], None] = lambda: None) -> list[Outcome]:
    """The runs' outcomes, in order: on a Dask cluster, local worker processes, or here."""
    from pendfmu.fitting.bootstrap import parallel_map

    return parallel_map(simulate, runs, workers, scheduler, done, failed_run)


@contextmanager
def runner(workers: int = 0, scheduler: str | None = None):
    """parallel_runs for many batches (a tuning's designs): the local worker processes start
    once and keep their loaded closed loop (_replay) from one batch to the next."""
    from pendfmu.fitting.pool import WorkerPool, default_workers

    workers = workers or default_workers()
    if scheduler or workers <= 1:
        yield lambda runs: parallel_runs(runs, workers, scheduler)
        return
    with WorkerPool(workers, simulate, failed=failed_run) as pool:
        yield lambda runs: list(pool.map(runs))


def verify(design, values: Mapping[str, float], replicates: Sequence[Mapping[str, float]], ssp: Path,
           duration: float = 20.0, requirements: Requirements = Requirements(), workers: int = 0,
           scheduler: str | None = None, done: Callable[[], None] = lambda: None) -> Verification:
    """The closed-loop runs of `plan`, in parallel; their outcomes judged by `requirements`."""
    import time

    start = time.perf_counter()
    outcomes = parallel_runs(plan(design, values, replicates, ssp, duration), workers, scheduler, done)
    return Verification(requirements, design.x_max, outcomes, time.perf_counter() - start)
