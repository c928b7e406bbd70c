"""Calibrated intervals: a parametric bootstrap through each recording's sensor model.

Why not the Jacobian. The Jacobian interval, s^2 (J^T J)^-1, treats every sample's error
as independent. A quantized encoder's error is not: while the pendulum swings slowly or
rests, the reading's rounding error stays the same for hundreds or thousands of samples,
and a 30 s decay at 0.2 ms is not 150,000 independent measurements. Measured on the demo's
pendulum stage (data from the same model, grid offsets drawn at random): the estimates'
spread was 50 times the Jacobian standard error (k_fwp 1.5 % against 0.03 %), and for
stiction, whose effect is a threshold, ten times more again.

What this does. The fit's estimate is taken as the truth of a virtual rig: each recording
is simulated at the estimate and read through its own sensor, as the sidecar describes it
(a quantizer whose grid sits at a random offset, since where the true signal falls within
a count is unknown, and Gaussian noise of the stated size), or, where the fit's residuals
stand well above that sensor noise (the model misses something), the fit's own residuals
circularly shifted, which keeps their size and their correlation. Each such replicate is
refitted by the same least squares from the estimate, in parallel on the fit's workers or
a Dask cluster. The spread of the refitted values is the spread of the estimator; the
interval is t-based on it (a replicate count of 24 costs about 1.1 in the quantile).

Chained stages. A stage fitted after another (the cart after the current loop) takes,
in replicate b, the earlier stage's replicate-b values as its known values. So the
interval of eta carries the uncertainty of T_i, which fixed conditional intervals hid.
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.stats import t as student_t

from pendfmu.fitting.cluster import dask_map
from pendfmu.fitting.experiment import Experiment
from pendfmu.fitting.pool import WorkerPool, default_workers
from pendfmu.fitting.optimizer import local_search, snap_to_bounds
from pendfmu.recording import quantize
from pendfmu.fitting.residuals import FreeParameter, Residuals, physical
from pendfmu.fitting.result import Estimate
from pendfmu.fitting.statistics import add_flags, clip_to_range, correlation_table, positive

REPLICATES = 24
GRID = 1e-6  # the estimate is rounded to this in the unit box before the replicates are made
# RMS of a recording's scaled residuals (1 at the truth) above which its errors are taken
# from its residuals rather than from its sensor: the model misses something there.
SENSOR_MATCH = 1.5


@dataclass(frozen=True)
class RefitJob:
    """One replicate: its synthetic experiments, refitted from the estimate."""

    experiments: tuple[Experiment, ...]
    free: tuple[FreeParameter, ...]
    shared: dict[str, float]
    u0: np.ndarray
    cost: str


@dataclass
class Replicates:
    """The refitted values of the bootstrap's replicates (a failed refit is a NaN row)."""

    labels: list[str]
    values: np.ndarray  # replicates x free parameters, physical
    fitted: list[dict[str, float]]  # per replicate: the stage's rig parameters, for later stages
    source: dict[str, str]  # recording -> "sensor model" or "residuals"
    failures: int = 0
    last_failure: str = ""  # why the last refit that failed failed
    incidents: list[str] = field(default_factory=list)  # workers lost on the way, survived


def error_source(experiment: Experiment, residual: np.ndarray) -> str:
    """Where a recording's replicate errors come from: its sensor, or its own residuals
    when they stand well above that sensor's noise."""
    residual = residual[np.isfinite(residual)]  # missing samples have none
    rms = float(np.sqrt(np.mean(residual**2))) if len(residual) else 0.0
    return "residuals" if rms > SENSOR_MATCH else "sensor model"


def synthetic_experiment(experiment: Experiment, simulated: dict[str, np.ndarray], residual: dict[str, np.ndarray],
                         source: str, rng: np.random.Generator, upstream: dict[str, float]) -> Experiment:
    """The experiment as a replicate sees it: the simulation at the estimate, read through
    the sensor (or perturbed by the shifted residuals), with the earlier stages' replicate
    values as known values (where the recording's sidecar does not state them)."""
    recording = experiment.recording
    signals = dict(recording.signals)
    for output, column in experiment.match.items():
        exact = simulated[output]
        missing = ~np.isfinite(recording.signals[column])  # a replicate misses the same samples
        if source == "residuals":
            errors = np.nan_to_num(residual[column] * experiment.scales[column])
            signals[column] = np.where(missing, np.nan, exact + np.roll(errors, int(rng.integers(len(errors)))))
            continue
        info = recording.signal_info.get(column)
        resolution = info.resolution if info else None
        noise = info.noise if info and info.noise else (0.0 if resolution else experiment.scales[column])
        value = exact + rng.normal(0.0, noise, len(exact)) if noise else exact
        if resolution:
            offset = float(rng.uniform(-0.5, 0.5)) * resolution
            value = quantize(value + offset, resolution, recording.quantizer(column)) - offset
        signals[column] = np.where(missing, np.nan, value) if missing.any() else value
    fixed = dict(experiment.fixed)
    fixed.update({k: v for k, v in upstream.items() if k not in recording.parameters})
    return replace(experiment, recording=replace(recording, signals=signals), fixed=fixed)


def refit(job: RefitJob) -> tuple[np.ndarray, int, str]:
    """The fit's own local refinement on one replicate, from the estimate: (physical
    values, failed simulations, why the last failure failed: "" if none). The same least
    squares with the same tolerances and budget as the fit (one round of it: a refit starts
    at the optimum), so that the replicates' spread is the estimator's; a looser refit
    stopped early on the real carriage and its spread followed the stopping point.
    Runs in a worker process or on a Dask worker; never raises for a failed simulation
    (Residuals penalizes it), and a refit that fails altogether gives NaN."""
    residuals = Residuals(job.experiments, job.free, job.shared, job.cost)
    try:
        u, jacobian, residual, _ = local_search(residuals, job.u0, rounds=1)
        u, _, _ = snap_to_bounds(residuals, u, jacobian, residual)
        return physical(job.free, u), residuals.failures, residuals.last_failure
    except Exception as error:  # a replicate must never stop the fit; it is counted as failed
        return failed_refit(job, f"{type(error).__name__}: {error}")
    finally:
        residuals.close()


def failed_refit(job: RefitJob, reason: str) -> tuple[np.ndarray, int, str]:
    """The result of a refit that failed altogether (or never came back from its worker)."""
    return np.full(len(job.free), np.nan), 1, reason


def parallel_map(function: Callable, jobs: Sequence, workers: int = 0, scheduler: str | None = None,
                 done: Callable[[], None] = lambda: None, failed: Callable[[object, str], object] | None = None,
                 incidents: list[str] | None = None) -> list:
    """`function` over `jobs` in order: on a Dask cluster, in local processes, or here;
    `done` is called as each job finishes (the progress bar's count). A job whose worker
    died on every try gives `failed(job, reason)` (pool.py, cluster.py); `incidents`
    receives what happened to workers that the map survived."""
    if scheduler:
        from distributed import Client

        with Client(scheduler, set_as_default=False) as client:
            return dask_map(client, function, jobs, done, failed, incidents)
    workers = min(workers or default_workers(), len(jobs))
    if workers <= 1:
        return [_counted(function(job), done) for job in jobs]
    with WorkerPool(workers, function, failed=failed) as pool:
        results = [_counted(result, done) for result in pool.map(jobs)]
    if pool.deaths and incidents is not None:
        incidents.append(f"{len(pool.deaths)} worker process(es) died (last: {pool.deaths[-1]}); their jobs ran "
                         f"again on fresh workers")
    return results


def _counted(result, done: Callable[[], None]):
    done()
    return result


def data_seed(residuals: Residuals) -> int:
    """The bootstrap's seed, from the recordings themselves: not the fit's --seed, which
    steers only the global search. The same data then get the same intervals whatever the
    seed, as an interval describes the data, not the search."""
    digest = hashlib.sha256()
    for experiment in residuals.experiments:
        digest.update(experiment.name.encode())
        digest.update(np.ascontiguousarray(experiment.time).tobytes())
        for column in experiment.match.values():
            digest.update(np.ascontiguousarray(experiment.recorded(column)).tobytes())
    return int.from_bytes(digest.digest()[:8], "little")


def bootstrap(residuals: Residuals, u: np.ndarray, replicates: int = REPLICATES,
              upstream: Sequence[dict[str, float]] | None = None, workers: int = 0,
              scheduler: str | None = None, done: Callable[[], None] = lambda: None) -> Replicates:
    """Refit `replicates` synthetic copies of the stage's recordings (module docstring).

    The replicates' rig is the estimate rounded to GRID of the search box: far finer than
    any interval, coarser than where different seeds' searches end (1e-8 apart on the real
    carriage). A refit on a rugged cost is sensitive to its start, and without the rounding
    one seed's replicates found a stiction interval twice as wide as the four others'."""
    rng = np.random.default_rng(data_seed(residuals))
    u = np.clip(np.round(np.asarray(u, dtype=float) / GRID) * GRID, 0.0, 1.0)
    simulated = residuals.simulate(u)
    scaled = _scaled_residuals(residuals, u, simulated)
    sources = {e.name: error_source(e, np.concatenate(list(scaled[k].values())))
               for k, e in enumerate(residuals.experiments)}
    jobs = []
    for b in range(replicates):
        above = dict(upstream[b]) if upstream else {}
        experiments = tuple(synthetic_experiment(e, simulated[k], scaled[k], sources[e.name], rng, above)
                            for k, e in enumerate(residuals.experiments))
        jobs.append(RefitJob(experiments, tuple(residuals.free), {**residuals.shared, **above}, np.array(u),
                             residuals.cost))
    incidents: list[str] = []
    results = parallel_map(refit, jobs, workers, scheduler, done, failed_refit, incidents)
    values = np.array([r[0] for r in results]).reshape(replicates, len(residuals.free))
    estimate = physical(residuals.free, u)
    # a failed refit hands the estimate to later stages: they must have a value to run with
    fitted = [{p.name: float(v) for p, v in zip(residuals.free, estimate if np.isnan(row).any() else row)
               if p.experiment is None} for row in values]
    failed = np.isnan(values).any(axis=1)
    reasons = [r[2] for r, bad in zip(results, failed) if bad and r[2]]
    return Replicates([p.label for p in residuals.free], values, fitted, sources, int(failed.sum()),
                      reasons[-1] if reasons else "", incidents)


def _scaled_residuals(residuals: Residuals, u: np.ndarray, simulated) -> list[dict[str, np.ndarray]]:
    """Each experiment's scaled residual per fitted signal at the estimate."""
    result = []
    for experiment, simulation in zip(residuals.experiments, simulated):
        result.append({column: (experiment.recorded(column) - simulation[output]) / experiment.scales[column]
                       for output, column in experiment.match.items()})
    return result


def bootstrap_estimates(free: Sequence[FreeParameter], u: np.ndarray, replicates: Replicates
                        ) -> tuple[dict[str, Estimate], dict[str, dict[str, float | None]]]:
    """Estimates with t-based 95 % intervals from the replicates' spread, taken on the log
    scale for positive quantities; correlations from the replicates."""
    values = physical(free, u)
    rows = replicates.values[~np.isnan(replicates.values).any(axis=1)]
    count = len(rows)
    quantile = float(student_t.ppf(0.975, count - 1)) if count > 1 else math.inf
    transformed = np.empty_like(rows)
    estimates: dict[str, Estimate] = {}
    for k, p in enumerate(free):
        value = float(values[k])
        log = positive(p) and value > 0 and count > 0 and bool(np.all(rows[:, k] > 0))
        transformed[:, k] = np.log(rows[:, k]) if log else rows[:, k]
        centre = math.log(value) if log else value
        spread = float(np.std(transformed[:, k], ddof=1)) if count > 1 else math.inf
        bias = float(np.mean(transformed[:, k]) - centre) if count else 0.0
        half = quantile * math.hypot(spread, bias) if math.isfinite(spread) else math.inf
        if log:
            low, high = (math.exp(centre - half), math.exp(centre + half)) if half < 700 else (0.0, math.inf)
        else:
            low, high = centre - half, centre + half
        stderr = float(np.std(rows[:, k], ddof=1)) if count > 1 else None
        estimates[p.label] = Estimate(p.label, value, stderr, clip_to_range(p.name, (low, high)), p.low, p.high,
                                      method="bootstrap")
    covariance = np.cov(transformed, rowvar=False) if count > 2 else np.full((len(free), len(free)), np.nan)
    correlation = correlation_table(list(free), np.atleast_2d(covariance))
    add_flags(estimates, correlation, list(free), u)
    return estimates, correlation
