"""Residual diagnostics of one recorded signal, as a statistician reads them: whether the
residuals are white noise, and whether they follow the amplitude or the speed.

A model that misses a term leaves a residual with a structure: it stays correlated over
many samples (the autocorrelation stands outside the white-noise band +-Z95/sqrt(N) long
after lag 0; the correlation length is statistics.correlation_length's, the one the
sandwich intervals use), and its mean changes with the state that drives the missing
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
uses the stored summary (`summaries`), and an older file without one has diagnostics only
for the recordings it holds whole. The summary is small whatever the recording's length:
at most ACF_LAGS + ACF_POINTS lags and 2 * BINS bins per signal.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING

import numpy as np

from pendfmu.components import COMPONENTS
from pendfmu.fitting.statistics import MIN_BATCHES, Z95, autocorrelation, correlation_length

if TYPE_CHECKING:
    from pendfmu.fitting.result import ExperimentFit

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
        acf: the autocorrelation at those lags (statistics.autocorrelation).
        correlation_length: statistics.correlation_length of the residuals.
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

    @property
    def band(self) -> float:
        """Half-width of the 95 % band an autocorrelation of white noise stays within."""
        return Z95 / math.sqrt(self.samples)

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, entry: dict) -> Diagnostics:
        return cls(**{**entry, "amplitude": Binned(**entry["amplitude"]), "speed": Binned(**entry["speed"])})


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


def whole(fit: ExperimentFit) -> bool:
    """Whether a recording's arrays hold every sample (not a file's display envelope)."""
    return fit.samples is None or len(fit.time) >= fit.samples


def summaries(fit: ExperimentFit) -> dict[str, Diagnostics]:
    """Each recorded signal's diagnostics: the ones stored with the result if it holds
    them (read back from a file), else computed from the arrays if they hold every sample;
    a signal of an envelope without a stored summary (an older file) has none."""
    if fit.diagnostics:
        return {name: Diagnostics.from_dict(entry) for name, entry in fit.diagnostics.items() if entry}
    if not whole(fit):
        return {}
    found = {}
    for name, recorded in fit.recorded.items():
        rate = rate_of(name)
        own = fit.recorded.get(rate) if rate else None
        found[name] = diagnose(fit.time, recorded, fit.simulated[name], own, f"{rate} (recorded)" if rate else "")
    return {name: d for name, d in found.items() if d is not None}
