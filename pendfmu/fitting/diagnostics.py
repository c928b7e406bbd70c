"""Residual diagnostics of one recorded signal, as a statistician reads them: whether the
residuals are white noise, and whether they follow the amplitude or the speed.

A model that misses a term leaves a residual with a structure: it stays correlated over
many samples (the autocorrelation stands outside the white-noise band +-1.96/sqrt(N) long
after lag 0; the correlation length is the one the sandwich intervals' batches follow,
statistics.sandwich_covariance), and its mean changes with the state that drives the missing
term (air drag with the speed squared, amplitude-dependent losses with the angle). So,
per signal: the autocorrelation, and the residual's mean in bins of the recorded value
(amplitude) and of its rate (speed: the recording's own rate signal where the result
holds it, else the central difference of the recorded signal over its own times).

The residual is recorded − simulated (as the report's plots draw it), in the signal's
unit. What it is computed from: every sample of the recording (missing ones, NaN, left
out: the autocorrelation joins the samples on either side of a gap). A result file holds
a long recording only as its display envelope (envelope.py): those samples are each
bucket's extremes, unevenly spaced, from which neither an autocorrelation nor an unbiased
bin mean follows. So the summary is computed from every sample when the result is written
and stored beside the envelope (result.experiment_dict, as the RMS is); a result read back
uses the stored summary (result.diagnostics_of), and an older file without one has
diagnostics only for the recordings it holds whole. The summary is small whatever the recording's length:
at most ACF_LAGS + ACF_POINTS lags and 2 * BINS bins per signal.

The autocorrelation and the correlation length have their one home here, not in
statistics.py, which uses them for the sandwich intervals' batches: the result file
(result.py) computes these diagnostics, and statistics imports result.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from collections.abc import Mapping

import numpy as np

from pendfmu.components import COMPONENTS

CORRELATED = 0.1  # |autocorrelation| above which residuals count as correlated at that lag
MIN_BATCHES = 8  # a series holds this many sandwich batches at least (the correlation length looks this far)
ACF_LAGS = 60  # every lag up to this one is kept
ACF_POINTS = 150  # beyond it, this many lags spread evenly up to the longest
BINS = 20  # equal-width bins over the range of the amplitude, and of the speed
MIN_COUNT = 10  # a bin holding fewer samples is left out (its mean says little)
MIN_SAMPLES = 2 * MIN_BATCHES  # fewer finite residuals: no diagnostics (correlation_length's own minimum)


@dataclass(frozen=True)
class Binned:
    """The residual's mean in bins of another quantity, each bin with the mean of that
    quantity in it (where its samples lie, not the bin's middle), the residuals' standard
    deviation within it and its count. Bins with fewer than MIN_COUNT samples are left out."""

    centre: list[float]
    mean: list[float]
    spread: list[float]
    count: list[int]


@dataclass(frozen=True)
class Diagnostics:
    """One signal's residual diagnostics (module docstring).

    Attributes:
        samples: the finite residuals they are computed from (N of the white-noise band).
        step: the median time between samples [s], to read lags as time.
        lags: the lags (samples) at which the autocorrelation is kept: every one up to
            ACF_LAGS, then ACF_POINTS spread evenly up to a MIN_BATCHES-th of the series
            (as far as correlation_length looks).
        acf: the autocorrelation at those lags (`autocorrelation`).
        correlation_length: `correlation_length` of the residuals.
        amplitude: the residual's mean in bins of the recorded signal.
        speed: the residual's mean in bins of its rate.
        speed_from: where the rate came from (a recorded rate signal, or the central difference).
    """

    samples: int
    step: float
    lags: list[int]
    acf: list[float]
    correlation_length: int
    amplitude: Binned
    speed: Binned
    speed_from: str

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, entry: dict) -> Diagnostics:
        return cls(**{**entry, "amplitude": Binned(**entry["amplitude"]), "speed": Binned(**entry["speed"])})


def autocorrelation(residual: np.ndarray, max_lag: int) -> np.ndarray:
    """The sample autocorrelation of a series at lags 0..max_lag: its autocovariance (the
    sum of products over the overlap, divided by the series' length for every lag, which
    keeps the estimate positive definite) over its variance. Zeros for a constant series."""
    n = len(residual)
    centred = residual - residual.mean()
    spectrum = np.fft.rfft(centred, 2 * n)
    autocovariance = np.fft.irfft(spectrum * np.conj(spectrum), 2 * n)[: min(max_lag, n - 1) + 1]
    if autocovariance[0] <= 0:
        return np.zeros_like(autocovariance)
    return autocovariance / autocovariance[0]


def correlation_length(residual: np.ndarray) -> int:
    """How many samples a series of residuals stays correlated: one more than the largest
    lag (up to a MIN_BATCHES-th of the series) at which its autocorrelation exceeds
    CORRELATED. 1 for independent residuals; a model error that comes and goes with the
    swing gives about a period's worth."""
    n = len(residual)
    if n < 2 * MIN_BATCHES:
        return 1
    correlated = np.flatnonzero(np.abs(autocorrelation(residual, n // MIN_BATCHES)[1:]) > CORRELATED)
    return int(correlated[-1]) + 2 if len(correlated) else 1


def acf_lags(longest: int) -> np.ndarray:
    """The lags kept: all up to ACF_LAGS, then ACF_POINTS spread evenly up to `longest`."""
    if longest <= ACF_LAGS + ACF_POINTS:
        return np.arange(longest + 1)
    spread = np.linspace(ACF_LAGS, longest, ACF_POINTS).round().astype(int)
    return np.unique(np.concatenate([np.arange(ACF_LAGS + 1), spread]))


def binned_means(x: np.ndarray, residual: np.ndarray, bins: int = BINS) -> Binned:
    """The residual's mean in `bins` equal-width bins over the range of `x` (pairs with a
    NaN on either side left out). Equal widths, not equal counts: the extremes, where drag
    and amplitude losses show most, keep bins of their own."""
    keep = np.isfinite(x) & np.isfinite(residual)
    x, residual = x[keep], residual[keep]
    if not x.size or x.max() == x.min():
        return Binned([], [], [], [])
    which = np.clip(((x - x.min()) / (x.max() - x.min()) * bins).astype(int), 0, bins - 1)
    count = np.bincount(which, minlength=bins)
    full = count >= MIN_COUNT
    safe = np.maximum(count, 1)
    centre = np.bincount(which, x, bins) / safe
    mean = np.bincount(which, residual, bins) / safe
    square = np.bincount(which, residual**2, bins) / safe
    spread = np.sqrt(np.clip(square - mean**2, 0.0, None))
    return Binned(*(values[full].tolist() for values in (centre, mean, spread)), count[full].tolist())


def diagnose(time: np.ndarray, recorded: np.ndarray, simulated: np.ndarray, rate: np.ndarray | None = None,
             rate_name: str = "") -> Diagnostics | None:
    """The diagnostics of one signal from its every sample (module docstring); `rate` is
    the recording's own rate of it (named `rate_name`), if it has one. None when fewer
    than MIN_SAMPLES residuals are finite."""
    time, recorded = np.asarray(time, float), np.asarray(recorded, float)
    residual = recorded - np.asarray(simulated, float)
    finite = residual[np.isfinite(residual)]
    if finite.size < MIN_SAMPLES:
        return None
    if rate is None:
        with np.errstate(divide="ignore", invalid="ignore"):  # a repeated time: no rate there (inf, left out)
            rate = np.gradient(recorded, time)
        rate_name = "the central difference of the recorded signal"
    lags = acf_lags(finite.size // MIN_BATCHES)
    acf = autocorrelation(finite, int(lags[-1]))[lags]
    return Diagnostics(int(finite.size), float(np.median(np.diff(time))), lags.tolist(), acf.tolist(),
                       correlation_length(finite), binned_means(recorded, residual),
                       binned_means(np.asarray(rate, float), residual), rate_name)


def rate_of(signal: str) -> str | None:
    """The variable that is the rate of `signal` in pendfmu's components (w of phi, v of x)."""
    for component in COMPONENTS.values():
        for variable in component.variables:
            if variable.derivative_of == signal:
                return variable.name
    return None


def of_signals(time: np.ndarray, recorded: Mapping[str, np.ndarray], simulated: Mapping[str, np.ndarray]
               ) -> dict[str, Diagnostics]:
    """Each recorded signal's diagnostics from every sample, binned by the recording's own
    rate of it where it holds one (w for phi), else by its central difference; a signal
    with too few finite residuals has none."""
    found = {}
    for name, values in recorded.items():
        rate = rate_of(name)
        own = recorded.get(rate) if rate else None
        found[name] = diagnose(time, values, simulated[name], own, f"{rate} (recorded)" if rate else "")
    return {name: d for name, d in found.items() if d is not None}
