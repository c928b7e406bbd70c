"""Adapters from third-party real recordings to pendfmu Recordings, and independent
estimates to check pendfmu's fits against.

The files live in ``<repo>/../shared/realdata/<name>/`` with a ``SOURCE.txt`` each. Their
licences allow internal testing only: nothing here copies them or writes anything derived
from them; the adapters read the originals and build Recordings in memory. Callers skip
when the files are absent (:func:`available`).

Two data sets, two stages:

* ``kord-stk/LaTest.CSV`` (current stage): an oscilloscope capture of a locked-rotor DC
  motor after an open-loop voltage step, measured over a 0.05 ohm shunt. Electrically an
  R-L circuit, ``I(t) = I_final (1 - exp(-(t - t0) R/L))``: in the CurrentLoop model a step
  of ``I_c`` with ``T_i = L/R`` and a slope limit that never binds. The step time and
  level are not recorded (there is no command channel), so they are estimated from the
  current itself, first from plain statistics and then refined together with ``T_i``
  (:func:`fit_locked_rotor`).
* ``MultiArm-Pendulum`` (pendulum stage): a 55 s free decay of a single pendulum arm,
  angle only (the authors' angular rate is denoised, i.e. derived, and not used).

Independent checks do not use pendfmu's simulator or optimizer: an analytic exponential
fit and the textbook log-linear fit for the R-L step; for the pendulum a work-energy
balance between turning points (:func:`decay_cycles`, :func:`energy_balance`), which needs
neither the inertia nor the phase of the swing, and the measured period against the
published inertia (:func:`period_ratio`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.integrate import trapezoid
from scipy.optimize import least_squares, minimize
from scipy.signal import medfilt, savgol_filter
from scipy.stats import trim_mean

from pendfmu.fitting.identification import fit
from pendfmu.fitting.optimizer import GlobalOptions
from pendfmu.recording import Recording, RecordingError, SignalInfo, quantize
from pendfmu.fitting.result import FitResult

REALDATA = Path(__file__).resolve().parents[1] / ".." / "shared" / "realdata"


def available(*paths: Path) -> bool:
    return all(p.is_file() for p in paths)


# =========================================================================== kord-stk

KORD_CSV = REALDATA / "kord-stk" / "LaTest.CSV"
SHUNT_OHM = 0.05  # LaPlot.m: I = V / 0.05
SCOPE_LSB_V = 3.125e-3  # Agilent 54621D, 8 bits on the chosen range (the file's values are multiples of it)
CURRENT_LSB = SCOPE_LSB_V / SHUNT_OHM  # 62.5 mA: the current's quantization step
PUBLISHED_L = 1.56e-4  # H, "commented out" in the project report
PUBLISHED_R = 0.8  # ohm
PUBLISHED_L_OVER_R = PUBLISHED_L / PUBLISHED_R  # 1.95e-4 s
NEVER_BINDING_SLOPE = 1e7  # A/s: with T_i ~ 1e-4 s the slope limit would bind only for steps > 1000 A

# An R-L step is the lag alone. The file has isolated spikes (one or two samples of up to
# +-2 A, pickup from the switching) that are not part of the current; a 9-sample running
# median (22.5 us, a few percent of the time constant) removes them for the *estimates*
# of levels and times. The fit itself sees every raw sample.
DESPIKE = 9


@dataclass(frozen=True)
class ScopeTrace:
    path: Path
    time: np.ndarray  # s, the scope's own time stamps
    current: np.ndarray  # A, shunt voltage / SHUNT_OHM


def read_scope_csv(path: Path = KORD_CSV) -> ScopeTrace:
    """The scope's "CSV": two header lines ("x-axis 1" and "second Volt"), then time and
    shunt voltage, separated by blanks (commas are accepted too). The units line is
    checked so that a different export (other units, other channel) fails here rather
    than producing a wrong time constant."""
    with open(path, encoding="ascii") as f:
        lines = [line.replace(",", " ") for line in f]
    if lines[1].split() != ["second", "Volt"]:
        raise RecordingError(f"{path}: expected the units line 'second Volt', got {lines[1].strip()!r}")
    data = np.loadtxt(lines[2:], ndmin=2)
    if data.shape[1] != 2:
        raise RecordingError(f"{path}: expected 2 columns (time, volts), got {data.shape[1]}")
    return ScopeTrace(Path(path), data[:, 0].copy(), data[:, 1] / SHUNT_OHM)


@dataclass(frozen=True)
class StepEstimate:
    """The unrecorded command of the step: current before it, level after it, and when."""

    baseline: float  # A, the current before the step (the scope's offset: no current flows)
    level: float  # A, the final current I_final
    t0: float  # s, the instant of the voltage step
    noise: float  # A, standard deviation of the reading before the step (robust)


def first_step_estimate(trace: ScopeTrace) -> StepEstimate:
    """Levels and step time from plain statistics, before any fit.

    * baseline: the mean of the samples before the step, trimmed 10 % each side (sub-LSB
      resolution like a mean, but the spikes do not pull it);
    * level: the same trimmed mean over the last 40 % of the record, where the current
      has settled (checked: the despiked current stays within 5 % of the step there; the
      rest of the record still creeps up by ~2 %, one reason the rise is not exactly one
      exponential);
    * t0: the last sample before the half-way crossing at which the despiked current is
      still inside the baseline noise band (baseline + 3 sigma, sigma from the median
      absolute deviation of the pre-step samples): where the current leaves the noise.

    The pre-step samples are those before 80 % of the time from the record's start to the
    half-way crossing, so that the rise itself never enters the baseline.
    """
    time, current = trace.time, trace.current
    smooth = medfilt(current, DESPIKE)
    n = len(time)
    rough_low, rough_high = np.median(current[: n // 10]), np.median(current[-n // 10:])
    half = int(np.argmax(smooth > 0.5 * (rough_low + rough_high)))
    if half == 0 or rough_high - rough_low < 10 * CURRENT_LSB:
        raise RecordingError(f"{trace.path}: no step of the current found")
    pre = current[: int(0.8 * half)]
    baseline = float(trim_mean(pre, 0.1))
    noise = float(1.4826 * np.median(np.abs(pre - np.median(pre))))
    noise = max(noise, CURRENT_LSB / math.sqrt(12))  # never below the quantization's own spread
    tail = current[int(0.6 * n):]
    level = float(trim_mean(tail, 0.1))
    if np.any(np.abs(smooth[int(0.6 * n):] - level) > 0.05 * abs(level - baseline)):
        raise RecordingError(f"{trace.path}: the current has not settled in the last 40 % of the record")
    inside = np.nonzero(smooth[:half] <= baseline + 3 * noise)[0]
    t0 = float(time[inside[-1]]) if len(inside) else float(time[0])
    return StepEstimate(baseline, level, t0, noise)


def step_command(time: np.ndarray, step: StepEstimate) -> np.ndarray:
    """I_c for a step at `step.t0`, which may fall between samples.

    The current stage holds I_c constant from one sample to the next. The sample whose
    hold interval contains t0 gets the fraction of the step that the interval holds after
    t0, so the command carries the same charge as a true step at t0; after that interval
    the response differs from the true one by f(1-f)(dt/T_i)^2/2 relative, below 1e-5
    here. This makes the cost a smooth function of t0 instead of a staircase."""
    command = np.where(time >= step.t0, step.level, step.baseline).astype(float)
    k = int(np.searchsorted(time, step.t0))  # first sample at or after t0
    if 0 < k < len(time):
        fraction = (time[k] - step.t0) / (time[k] - time[k - 1])
        command[k - 1] = step.baseline + (step.level - step.baseline) * fraction
    return command


def current_step_recording(trace: ScopeTrace, step: StepEstimate) -> Recording:
    """The trace as a current-stage Recording: the raw current I (every sample, spikes
    included: the fit is an honest least-squares fit to what the scope recorded), the
    reconstructed command I_c, the scope's quantization as I's resolution, the pre-step
    noise as its noise, and the current before the step as the initial state."""
    return Recording(
        trace.path, trace.time, {"I_c": step_command(trace.time, step), "I": trace.current},
        experiment="locked-rotor voltage step (R-L), command reconstructed",
        signal_info={"I": SignalInfo(CURRENT_LSB, "round", step.noise)},
        initial={"I": step.baseline})


def fit_current_step(trace: ScopeTrace, step: StepEstimate, uncertainty: str = "bootstrap") -> FitResult:
    """pendfmu's current stage for a given command: T_i free, the slope limit fixed so
    high that it never binds (an R-L circuit has none). The start is the reference rig's
    T_i (0.3 ms), not the published L/R; the global search is off because one time
    constant in a one-decade box is a convex-looking 1-D problem for the local search."""
    return fit("current", [current_step_recording(trace, step)], {"dIdt_max": NEVER_BINDING_SLOPE},
               fix=["dIdt_max"], global_search=GlobalOptions(enabled=False), progress=False,
               uncertainty=uncertainty)


@dataclass
class LockedRotorFit:
    result: FitResult  # pendfmu's fit of T_i at the refined step
    step: StepEstimate  # refined t0 and level
    first: StepEstimate  # the statistics-only estimate
    evaluations: int  # pendfmu fits run by the refinement


def fit_locked_rotor(trace: ScopeTrace) -> LockedRotorFit:
    """T_i with the step's time and level refined by the same fit.

    The current stage cannot fit t0 and I_final: they are properties of the input I_c,
    not parameters of an FMU. They are refined instead by minimizing pendfmu's own
    least-squares cost over (t0, level), with T_i fitted by pendfmu at every point (a
    profile likelihood), starting from :func:`first_step_estimate`. The baseline stays at
    its statistical estimate: 570 pre-step samples pin it to a few mA, and it is where
    the model's current starts. The result is the joint least-squares estimate of
    (t0, level, T_i) given the baseline; T_i's reported interval is conditional on the
    refined t0 and level.
    """
    first = first_step_estimate(trace)
    span = first.level - first.baseline
    dt = float(np.median(np.diff(trace.time)))
    count = [0]

    def at(x) -> StepEstimate:
        return StepEstimate(first.baseline, first.level + x[1] * span, first.t0 + x[0] * dt, first.noise)

    def cost(x) -> float:  # only the cost: no intervals needed on the way
        count[0] += 1
        return fit_current_step(trace, at(x), uncertainty="jacobian").cost

    # Coordinates: t0 in samples, level in units of the step: both O(1) for the simplex.
    best = minimize(cost, [0.0, 0.0], method="Nelder-Mead",
                    options={"xatol": 0.01, "fatol": 1e-6, "initial_simplex": [[0, 0], [4, 0], [0, 0.02]]})
    step = at(best.x)
    return LockedRotorFit(fit_current_step(trace, step), step, first, count[0])


def exponential_fit(trace: ScopeTrace, first: StepEstimate) -> tuple[float, float, float, float]:
    """The same model fitted without pendfmu: I = b + (L - b)(1 - exp(-(t - t0)/tau)) for
    t > t0, with b fixed to the baseline and (L, t0, tau) free, plain least squares on
    the raw samples. Returns (tau, its standard error, t0, L). Agreement with pendfmu's
    profile fit checks the simulator, the command reconstruction and the optimizer."""
    time, current = trace.time - trace.time[0], trace.current
    b = first.baseline

    def residual(p):
        level, t0, tau = p
        x = np.clip(time - t0, 0.0, None)
        return b + (level - b) * (1 - np.exp(-x / tau)) - current

    p0 = [first.level, first.t0 - trace.time[0], 3e-4]
    r = least_squares(residual, p0, x_scale=[1.0, 1e-5, 1e-5], method="lm")
    dof = len(current) - 3
    covariance = np.linalg.inv(r.jac.T @ r.jac) * (r.fun @ r.fun) / dof
    return float(r.x[2]), float(math.sqrt(covariance[2, 2])), float(r.x[1] + trace.time[0]), float(r.x[0])


def log_linear_tau(trace: ScopeTrace, step: StepEstimate, upper: float = 0.9,
                   lower: float = 0.1) -> tuple[float, float]:
    """The textbook estimate: ln(I_final - I) falls linearly with slope -1/tau. Fitted by
    ordinary least squares over the part of the rise where the remaining current
    I_final - I lies between `upper` and `lower` times the step (above: the start, where
    the step time matters; below: the tail, where a 62.5 mA quantization and the noise
    dominate the logarithm). Despiked current, I_final from the plateau statistics only
    (first_step_estimate), so it shares no fitted quantity with pendfmu's fit. Returns
    (tau, its standard error from the regression)."""
    smooth = medfilt(trace.current, DESPIKE)
    span = step.level - step.baseline
    remaining = step.level - smooth
    after = trace.time >= step.t0
    use = after & (remaining < upper * span) & (remaining > lower * span)
    # only the first pass through the band: later noise excursions into it are not the rise
    use[int(np.argmax(after & (remaining <= lower * span))):] = False
    if np.count_nonzero(use) < 10:
        raise RecordingError(f"{trace.path}: too few samples in the log-linear band")
    t, y = trace.time[use], np.log(remaining[use])
    A = np.column_stack([t - t.mean(), np.ones_like(t)])
    (slope, _), residual, *_ = np.linalg.lstsq(A, y, rcond=None)
    s2 = float(residual[0]) / (len(t) - 2)
    se_slope = math.sqrt(s2 / float(A[:, 0] @ A[:, 0]))
    tau = -1.0 / slope
    return float(tau), float(se_slope / slope**2)


# =========================================================================== MultiArm

MULTIARM_MAT = REALDATA / "MultiArm-Pendulum" / "SinglePendulumDataForParameterEstimation.mat"
ENCODER_RESOLUTION = 2 * math.pi / 40000  # the rig's high-resolution encoder
TEN_BIT = 2 * math.pi / 1024  # the paper's pendulum encoder (MODEL.md)
# The authors' fit (EstimatedParameters_SinglePendulum.mat): viscous friction only.
A1, M1, I1, G, K1 = 0.147755, 0.147585, 1.09119e-4, 9.81001, 2.23940e-4
PUBLISHED_PENDULUM = {"l": A1, "m_p": M1, "J_p": I1 + M1 * A1**2, "g": G}  # J_p about the pivot
PUBLISHED_K1 = K1
MGL = M1 * G * A1


def read_multiarm_decay(path: Path = MULTIARM_MAT) -> tuple[np.ndarray, np.ndarray]:
    """Time and angle of the whole decay: the cells Y_id{1..4}, Y_vad{1..2} (row 0: the
    angle, 0 upright, pi hanging: pendfmu's phi) with Time_id/Time_vad, concatenated.

    SOURCE.txt says the six cells are consecutive chunks of one decay; this is checked,
    not assumed: every time step, chunk boundaries included, must be the file's dt, and
    the angle's jump across a boundary must be no larger than the largest jump inside a
    chunk (a gap or a reordering would show as a jump).

    The angles are not all multiples of 2 pi/40000: they sit on that grid where the
    pendulum dwells on one count (at turning points) and are interpolated between count
    changes elsewhere (the raw log was evidently resampled to 1 ms). The encoder's step
    is still the right resolution: it bounds the reading's error."""
    from scipy.io import loadmat

    data = loadmat(path)
    times = [np.ravel(c) for c in list(data["Time_id"].flat) + list(data["Time_vad"].flat)]
    angles = [np.asarray(c)[0] for c in list(data["Y_id"].flat) + list(data["Y_vad"].flat)]
    dt = float(np.ravel(data["dt"])[0])
    inner = max(float(np.max(np.abs(np.diff(a)))) for a in angles)
    for k in range(1, len(times)):
        if abs(times[k][0] - times[k - 1][-1] - dt) > 1e-9 or abs(angles[k][0] - angles[k - 1][-1]) > inner:
            raise RecordingError(f"{path}: chunk {k} does not continue chunk {k - 1}")
    time, angle = np.concatenate(times), np.concatenate(angles)
    if np.max(np.abs(np.diff(time) - dt)) > 1e-9:
        raise RecordingError(f"{path}: time steps are not the file's dt = {dt}")
    return time, angle


def smoothing_window(resolution: float) -> int:
    """Samples (odd) of the local cubic fit that gives the angular rate and locates turning
    points. At a turning point the angle dwells on one reading for sqrt(2*delta/alpha):
    with the 40000-count encoder a few ms, with 10 bits up to ~20 ms at small amplitudes
    (alpha ~ 20 rad/s^2). The window must span several readings either side: 21 ms
    resp. 101 ms, both short against the 0.78 s period (the cubic's bias on the rate of a
    sinusoid over +-0.4 rad of phase is ~1e-3 relative)."""
    return 21 if resolution < 1e-3 else 101


def angular_rate(time: np.ndarray, phi: np.ndarray, window: int) -> np.ndarray:
    return savgol_filter(phi, window, 3, deriv=1, delta=float(np.median(np.diff(time))))


def turning_points(time: np.ndarray, phi: np.ndarray, window: int) -> tuple[np.ndarray, np.ndarray]:
    """Indices (the sample of smallest |rate| at each sign change of the smoothed rate)
    and the extreme angles, refined by a parabola through the samples of one smoothing
    window around each (the extreme usually falls between samples)."""
    rate = angular_rate(time, phi, window)
    change = np.nonzero(np.sign(rate[1:]) != np.sign(rate[:-1]))[0]
    half = window // 2
    indices, extremes = [], []
    for i in change:
        i = i if abs(rate[i]) <= abs(rate[i + 1]) else i + 1
        if i < half or i + half >= len(phi):
            continue
        s = slice(i - half, i + half + 1)
        c = np.polyfit(time[s] - time[i], phi[s], 2)
        indices.append(i)
        extremes.append(np.polyval(c, -c[1] / (2 * c[0])))
    return np.array(indices), np.array(extremes)


def decay_windows(path: Path, time: np.ndarray, phi: np.ndarray, resolution: float, starts: list[float],
                  cycles: int) -> list[Recording]:
    """Pendulum-stage Recordings: windows of `cycles` full swings, each from the first
    turning point at or after each of `starts` to the turning point 2*cycles later, with
    the resolution given.

    Why windows: one 55 s output-error fit has to hold the phase of 70 swings, and the
    published inertia and gravity torque make the model swing 0.11 % faster than the rig
    (:func:`period_ratio`): over 55 s that is a tenth of a swing. Short windows spread
    over the whole decay keep the phase error small while covering amplitudes from 1.6
    to 0.3 rad, which is what separates viscous from Coulomb friction. It also bounds
    the run time (14 s of simulated swing instead of 55 s per evaluation).

    Why from turning point to turning point: the pendulum stage estimates the release
    angle phi0 (a release from rest), and a window that ends at a turning point ends
    where a phase error costs least and the amplitude, i.e. the energy lost, shows most.
    The rate at the first sample is not exactly zero (the turning point falls between
    samples): it is measured by the local cubic fit on the same (possibly re-quantized)
    angle and given as the known initial state w, so only the angle is estimated, as the
    stage intends. pendfmu cannot estimate w0 per recording (see the report).

    Each window is named by its start time (a path that is not a file: pendfmu names
    experiments by the path's stem).
    """
    window = smoothing_window(resolution)
    rate = angular_rate(time, phi, window)
    indices, _ = turning_points(time, phi, window)
    recordings = []
    for start in starts:
        n = int(np.argmax(time[indices] >= start))
        if not time[indices[-1]] >= start or n + 2 * cycles >= len(indices):
            raise ValueError(f"a window of {cycles} cycles from {start} s runs past the end of the recording")
        i, j = int(indices[n]), int(indices[n + 2 * cycles]) + 1
        recordings.append(Recording(
            path.with_name(f"{path.stem}_{time[i]:07.3f}s{path.suffix}"), time[i:j], {"phi": phi[i:j]},
            experiment="free decay window from a turning point",
            signal_info={"phi": SignalInfo(resolution)}, initial={"w": float(rate[i])}))
    return recordings


def fit_decay(recordings: list[Recording], free: tuple[str, ...] = ()) -> FitResult:
    """pendfmu's pendulum stage on the windows: k_fwp, T_Kp, T_Sp (and `free`) shared,
    phi0 per window; J_p, l, m_p, g at the published values. Starts from the reference
    rig's friction values, not from the published k1; the search boxes are opened to
    cover every lab pivot (the default box is a decade around the start, which for T_Kp
    would exclude everything below 2e-4 N m). The global search is off to bound the run
    time: from the rig defaults, from a start two decades lower (k_fwp 1e-5, T_Kp 1e-6)
    and after the default differential evolution the local search ends at the same
    optimum (k_fwp and T_Kp equal to 4 digits), at 10 s instead of 38 s.

    The intervals are the fast Jacobian ones: these tests hold the fit to the energy
    balance, not its intervals, and a bootstrap of 11 free parameters (phi0 per window)
    over 8 windows costs minutes."""
    bounds = {"k_fwp": (1e-6, 1e-2), "T_Kp": (1e-7, 1e-2)}
    if "J_p" in free:  # bounds are only for what is fitted (a name not fitted is an error)
        bounds["J_p"] = (0.9 * PUBLISHED_PENDULUM["J_p"], 1.1 * PUBLISHED_PENDULUM["J_p"])
    return fit("pendulum", recordings, PUBLISHED_PENDULUM, free=list(free), bounds=bounds,
               global_search=GlobalOptions(enabled=False), progress=False, uncertainty="jacobian")


@dataclass(frozen=True)
class DecayCycles:
    """The decay cut into full cycles, turning point n to turning point n+2, every other
    one (non-overlapping, so the cycles' errors are independent). Full cycles, because an
    offset of the encoder's zero raises the potential energy of one side and lowers the
    other's: over a full cycle it cancels."""

    amplitude: np.ndarray  # rad, |extreme - pi| at the cycle's middle turning point
    loss: np.ndarray  # J, energy lost: m g l (cos phi_start - cos phi_end), phi from upright
    w1: np.ndarray  # rad, integral |w| dt: the work of a unit Coulomb torque
    w2: np.ndarray  # rad^2/s, integral w^2 dt: the work of a unit viscous coefficient
    w3: np.ndarray  # rad^3/s^2, integral |w|^3 dt: the work of a unit quadratic (air) drag


def decay_cycles(time: np.ndarray, phi: np.ndarray, window: int = 21) -> DecayCycles:
    """Energy lost per cycle and the friction work integrals, without simulating.

    Between two turning points the speed is zero, so the energy lost is the change of
    potential energy alone, and it equals the friction work. The extremes come from a
    parabola through the samples around each turning point (well under one encoder
    count), the rate from a local cubic fit. Needs m g l (published), not J_p, and no
    phase: a model's wrong natural frequency cannot bias it."""
    rate = angular_rate(time, phi, window)
    indices, extremes = turning_points(time, phi, window)
    rows = []
    for n in range(0, len(indices) - 2, 2):
        a, b = indices[n], indices[n + 2]
        w, t = np.abs(rate[a:b + 1]), time[a:b + 1]
        rows.append((abs(extremes[n + 1] - math.pi), MGL * (math.cos(extremes[n]) - math.cos(extremes[n + 2])),
                     trapezoid(w, t), trapezoid(w**2, t), trapezoid(w**3, t)))
    return DecayCycles(*(np.array(column) for column in zip(*rows)))


TERMS = {"k": "w2", "T_K": "w1", "c_q": "w3"}  # friction law coefficient -> its work integral


def energy_balance(cycles: DecayCycles, terms: tuple[str, ...] = ("k", "T_K"),
                   weight_power: float = 0.0) -> dict[str, tuple[float, float]]:
    """Least-squares friction law from the losses of the cycles: loss = sum of
    coefficient * work integral, over the `terms` ("k" viscous, "T_K" Coulomb, "c_q"
    quadratic drag). Cycles weighted by amplitude**weight_power (0: every cycle counts
    alike). Returns name -> (value, standard error), and "rel_rms": the relative rms of the
    losses the law leaves unexplained (as (value, 0))."""
    A = np.column_stack([getattr(cycles, TERMS[t]) for t in terms])
    weight = cycles.amplitude ** weight_power
    x, *_ = np.linalg.lstsq(A * weight[:, None], cycles.loss * weight, rcond=None)
    residual = (cycles.loss - A @ x) * weight
    s2 = float(residual @ residual) / (len(residual) - len(terms))
    se = np.sqrt(np.diag(s2 * np.linalg.inv((A * weight[:, None]).T @ (A * weight[:, None]))))
    result = {t: (float(v), float(e)) for t, v, e in zip(terms, x, se)}
    result["rel_rms"] = (float(np.sqrt(np.mean(((cycles.loss - A @ x) / cycles.loss) ** 2))), 0.0)
    return result


def equivalent_viscous(cycles: DecayCycles, k: float, T_K: float) -> float:
    """The one viscous coefficient that best describes the losses a law (k, T_K) predicts
    over the decay's cycles (least squares, cycles alike). The split between k and T_K is
    what a free decay determines poorly; this sum is what it determines well, and it is
    defined the same way for any friction law, so laws from different fits (or the
    published purely viscous k1) compare on equal terms."""
    predicted = k * cycles.w2 + T_K * cycles.w1
    return float(predicted @ cycles.w2 / (cycles.w2 @ cycles.w2))


def weighting_spread(cycles: DecayCycles, powers=(-2, -1, 0, 1, 2)) -> tuple[float, list[tuple]]:
    """How far the decay-wide dissipation of a viscous + Coulomb law fitted to this decay
    can move just by weighting the amplitudes differently: cycles weighted by
    amplitude**p, p from -2 (small swings count most, as in a fit of many short windows
    late in the decay) to +2 (as an output-error fit, whose residuals grow with the
    amplitude, weighs them). The data's losses do not follow k w^2 + T_K |w|, so each
    weighting gives another (k, T_K); returns the largest relative change of
    :func:`equivalent_viscous` against the unweighted law, and the laws themselves."""
    reference = energy_balance(cycles)
    k0 = equivalent_viscous(cycles, reference["k"][0], reference["T_K"][0])
    laws, spread = [], 0.0
    for p in powers:
        law = energy_balance(cycles, weight_power=p)
        relative = equivalent_viscous(cycles, law["k"][0], law["T_K"][0]) / k0 - 1
        laws.append((p, law["k"][0], law["T_K"][0], relative))
        spread = max(spread, abs(relative))
    return spread, laws


def window_decrement(recordings: list[Recording]) -> float:
    """Mean decrease of the amplitude |phi - pi| from a window's first to its last sample
    (both at turning points). Compared with the phi0 search box, it says how far the
    windows' start angles may move the fitted loss (see the tests)."""
    return float(np.mean([abs(r.signal("phi")[0] - math.pi) - abs(r.signal("phi")[-1] - math.pi)
                          for r in recordings]))


def period_ratio(time: np.ndarray, phi: np.ndarray, window: int = 21) -> tuple[np.ndarray, np.ndarray]:
    """Measured cycle periods over the exact period of a rigid pendulum with the
    published J_p and m g l at the same amplitude, 4 sqrt(J/mgl) K(sin^2(A/2)) (damping
    changes it by ~zeta^2/2 ~ 1e-5, negligible). Returns (amplitudes, ratios): a ratio
    above 1 means the published inertia/gravity-torque pair makes the model swing
    faster than the rig. Turning instants are refined by the same parabola as the
    extremes."""
    from scipy.special import ellipk

    indices, extremes = turning_points(time, phi, window)
    half = window // 2
    instants = []
    for i in indices:
        s = slice(i - half, i + half + 1)
        c = np.polyfit(time[s] - time[i], phi[s], 2)
        instants.append(time[i] - c[1] / (2 * c[0]))
    instants = np.array(instants)
    amplitude = 0.25 * (np.abs(extremes[:-2] - math.pi) + 2 * np.abs(extremes[1:-1] - math.pi)
                        + np.abs(extremes[2:] - math.pi))
    predicted = 4 * np.sqrt(PUBLISHED_PENDULUM["J_p"] / MGL) * ellipk(np.sin(amplitude / 2) ** 2)
    return amplitude, (instants[2:] - instants[:-2]) / predicted


def requantized(phi: np.ndarray, resolution: float = TEN_BIT) -> np.ndarray:
    """What the paper's 10-bit encoder would have read of the same swing."""
    return quantize(phi, resolution)
