"""Independent estimates to check pendfmu's fits of real recordings against, and the fits
the tests make through the Python API.

The conversions of the raw files into Recordings live in ``examples/realdata/<name>/
convert.py`` (one copy, shared with the examples and ``scripts/realdata_fits.py``), loaded
here as :data:`kord` and :data:`multiarm`. The files live in ``../shared/realdata/<name>/``
(or ``PENDFMU_REALDATA``) with a ``SOURCE.txt`` each. Their licences allow internal testing
only: nothing here copies them or writes anything derived from them. Callers skip when the
files are absent (:func:`available`).

Two data sets, two stages:

* ``kord-stk/LaTest.CSV`` (current stage): a locked-rotor DC motor's R-L current step.
  The step time and level are not recorded, so they are estimated from the current
  itself, first from plain statistics (``kord.first_step_estimate``) and then refined
  together with ``T_i`` (:func:`fit_locked_rotor`).
* ``MultiArm-Pendulum`` (pendulum stage): a 55 s free decay of a single pendulum arm.

Independent checks do not use pendfmu's simulator or optimizer: an analytic exponential
fit and the textbook log-linear fit for the R-L step; for the pendulum a work-energy
balance between turning points (:func:`decay_cycles`, :func:`energy_balance`), which needs
neither the inertia nor the phase of the swing, and the measured period against the
published inertia (:func:`period_ratio`).
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.integrate import trapezoid
from scipy.optimize import least_squares, minimize
from scipy.signal import medfilt

from pendfmu.fitting.identification import fit
from pendfmu.fitting.optimizer import GlobalOptions
from pendfmu.recording import Recording, RecordingError, quantize
from pendfmu.fitting.result import FitResult

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "examples" / "realdata"))
import _common  # noqa: E402
from _common import angular_rate, load_example, turning_points  # noqa: E402

available = _common.available  # the tests' skip condition
REALDATA = _common.REALDATA

kord = load_example("kord-stk")
multiarm = load_example("MultiArm-Pendulum")


# =========================================================================== kord-stk

def fit_current_step(trace: kord.ScopeTrace, step: kord.StepEstimate, uncertainty: str = "bootstrap") -> FitResult:
    """pendfmu's current stage for a given command: T_i free, the slope limit fixed so
    high that it never binds (an R-L circuit has none). The start is the reference rig's
    T_i (0.3 ms), not the published L/R; the global search is off because one time
    constant in a one-decade box is a convex-looking 1-D problem for the local search."""
    return fit("current", [kord.current_step_recording(trace, step)], {"dIdt_max": kord.NEVER_BINDING_SLOPE},
               fix=["dIdt_max"], harmonic="off", global_search=GlobalOptions(enabled=False), progress=False,
               uncertainty=uncertainty)


@dataclass
class LockedRotorFit:
    result: FitResult  # pendfmu's fit of T_i at the refined step
    step: kord.StepEstimate  # refined t0 and level
    first: kord.StepEstimate  # the statistics-only estimate
    evaluations: int  # pendfmu fits run by the refinement


def fit_locked_rotor(trace: kord.ScopeTrace) -> LockedRotorFit:
    """T_i with the step's time and level refined by the same fit.

    The current stage cannot fit t0 and I_final: they are properties of the input I_c,
    not parameters of an FMU. They are refined instead by minimizing pendfmu's own
    least-squares cost over (t0, level), with T_i fitted by pendfmu at every point (a
    profile likelihood), starting from :func:`kord.first_step_estimate`. The baseline stays at
    its statistical estimate: 570 pre-step samples pin it to a few mA, and it is where
    the model's current starts. The result is the joint least-squares estimate of
    (t0, level, T_i) given the baseline; T_i's reported interval is conditional on the
    refined t0 and level.
    """
    first = kord.first_step_estimate(trace)
    span = first.level - first.baseline
    dt = float(np.median(np.diff(trace.time)))
    count = [0]

    def at(x) -> kord.StepEstimate:
        return kord.StepEstimate(first.baseline, first.level + x[1] * span, first.t0 + x[0] * dt, first.noise)

    def cost(x) -> float:  # only the cost: no intervals needed on the way
        count[0] += 1
        return fit_current_step(trace, at(x), uncertainty="jacobian").cost

    # Coordinates: t0 in samples, level in units of the step: both O(1) for the simplex.
    best = minimize(cost, [0.0, 0.0], method="Nelder-Mead",
                    options={"xatol": 0.01, "fatol": 1e-6, "initial_simplex": [[0, 0], [4, 0], [0, 0.02]]})
    step = at(best.x)
    return LockedRotorFit(fit_current_step(trace, step), step, first, count[0])


def exponential_fit(trace: kord.ScopeTrace, first: kord.StepEstimate) -> tuple[float, float, float, float]:
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


def log_linear_tau(trace: kord.ScopeTrace, step: kord.StepEstimate, upper: float = 0.9,
                   lower: float = 0.1) -> tuple[float, float]:
    """The textbook estimate: ln(I_final - I) falls linearly with slope -1/tau. Fitted by
    ordinary least squares over the part of the rise where the remaining current
    I_final - I lies between `upper` and `lower` times the step (above: the start, where
    the step time matters; below: the tail, where a 62.5 mA quantization and the noise
    dominate the logarithm). Despiked current, I_final from the plateau statistics only
    (kord.first_step_estimate), so it shares no fitted quantity with pendfmu's fit. Returns
    (tau, its standard error from the regression)."""
    smooth = medfilt(trace.current, kord.DESPIKE)
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
        bounds["J_p"] = (0.9 * multiarm.PUBLISHED_PENDULUM["J_p"], 1.1 * multiarm.PUBLISHED_PENDULUM["J_p"])
    return fit("pendulum", recordings, multiarm.PUBLISHED_PENDULUM, free=list(free), bounds=bounds,
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
        rows.append((abs(extremes[n + 1] - math.pi), multiarm.MGL * (math.cos(extremes[n]) - math.cos(extremes[n + 2])),
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
    predicted = 4 * np.sqrt(multiarm.PUBLISHED_PENDULUM["J_p"] / multiarm.MGL) * ellipk(np.sin(amplitude / 2) ** 2)
    return amplitude, (instants[2:] - instants[:-2]) / predicted


def requantized(phi: np.ndarray, resolution: float = multiarm.TEN_BIT) -> np.ndarray:
    """What the paper's 10-bit encoder would have read of the same swing."""
    return quantize(phi, resolution)
