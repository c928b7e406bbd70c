"""Residual diagnostics (pendfmu/fitting/diagnostics.py) against analytic cases: white
noise stays within its band, an AR(1) series' autocorrelation is phi^k, binned means
follow a residual that is a known function of the speed or the amplitude; and a long
recording's diagnostics survive the result file, which keeps only its envelope."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.signal import lfilter

from pendfmu.fitting.diagnostics import BINS, MIN_COUNT, Diagnostics, binned_means, diagnose, rate_of
from pendfmu.fitting.result import ExperimentFit, diagnostics_of, read_result, whole
from pendfmu.fitting.statistics import correlation_length
from pendfmu.report.content import white_noise_band
from test_report import result


def ar1(phi: float, samples: int, seed: int) -> np.ndarray:
    """x_t = phi x_{t-1} + e_t, started in its stationary distribution."""
    noise = np.random.default_rng(seed).normal(size=samples)
    noise[0] /= math.sqrt(1 - phi * phi)
    return lfilter([1.0], [1.0, -phi], noise)


def residual_of(series: np.ndarray, dt: float = 1e-3) -> Diagnostics:
    """The diagnostics of a residual `series` on a recording of a slow sine."""
    time = np.arange(len(series)) * dt
    recorded = np.sin(2 * math.pi * time)
    return diagnose(time, recorded, recorded - series)


def test_white_noise_stays_within_its_band():
    found = residual_of(np.random.default_rng(1).normal(size=40_000))
    acf = np.asarray(found.acf)
    assert found.lags[0] == 0 and acf[0] == pytest.approx(1.0)
    band = white_noise_band(found.samples)
    assert band == pytest.approx(1.959963984540054 / math.sqrt(40_000))
    outside = np.mean(np.abs(acf[1:]) > band)
    assert outside <= 0.10  # 5 % expected; 10 % is beyond 3 binomial deviations for 210 lags
    assert np.max(np.abs(acf[1:])) < 2.2 * band
    assert found.correlation_length == 1


@pytest.mark.parametrize("phi, length", [(0.5, 4), (0.7, 7), (0.9, None)])
def test_an_ar1_autocorrelation_is_phi_to_the_lag(phi, length):
    """`length`: one more than the last lag whose phi^k exceeds 0.1, where the next lag's
    falls well below it (0.9^21 = 0.109 lies within sampling reach of 0.1: not asserted)."""
    samples = 200_000
    series = ar1(phi, samples, seed=int(phi * 10))
    found = residual_of(series)
    lags = np.asarray(found.lags)
    acf = np.asarray(found.acf)
    # Bartlett: the sampling deviation of an AR(1)'s autocorrelation at lag k
    k = lags[1:16]
    deviation = np.sqrt(((1 + phi**2) * (1 - phi ** (2 * k)) / (1 - phi**2) - 2 * k * phi ** (2 * k)) / samples)
    assert np.all(np.abs(acf[1:16] - phi**k) < 4 * deviation)
    # the correlation length is statistics' own: the last lag above 0.1, plus one
    assert found.correlation_length == correlation_length(series)
    if length is not None:
        assert found.correlation_length == length == math.floor(math.log(0.1) / math.log(phi)) + 1


def test_binned_means_against_speed_follow_a_quadratic_drag():
    """residual = c v|v| on a sine: each bin's mean is c m|m| at the bin's mean speed m,
    within c times the bin's variance (the curvature of v|v| is bounded by 2)."""
    c, omega, amplitude = 0.03, 2 * math.pi * 0.7, 1.3
    time = np.arange(0.0, 20.0, 1e-3)
    recorded = amplitude * np.sin(omega * time)
    speed = amplitude * omega * np.cos(omega * time)
    drag = c * speed * np.abs(speed)
    for rate in (speed, None):  # a recorded rate, and the central difference
        found = diagnose(time, recorded, recorded - drag, rate, "w (recorded)")
        centre, mean = np.asarray(found.speed.centre), np.asarray(found.speed.mean)
        width = 2 * amplitude * omega / BINS
        assert len(centre) == BINS
        assert np.all(np.abs(mean - c * centre * np.abs(centre)) <= c * width**2 / 4)
        assert np.all(np.asarray(found.speed.count) >= MIN_COUNT)
    assert found.speed_from == "the central difference of the recorded signal"


def test_binned_means_against_amplitude_follow_a_linear_loss_exactly():
    time = np.arange(0.0, 10.0, 1e-3)
    recorded = np.exp(-time / 4) * np.cos(3 * time) + math.pi
    found = diagnose(time, recorded, recorded - 0.02 * (recorded - math.pi))
    centre, mean = np.asarray(found.amplitude.centre), np.asarray(found.amplitude.mean)
    assert mean == pytest.approx(0.02 * (centre - math.pi), abs=1e-12)
    assert np.asarray(found.amplitude.spread) == pytest.approx(np.zeros(len(centre)), abs=0.02 * 2 / BINS)


def test_a_bin_of_too_few_samples_is_left_out_and_missing_samples_are_skipped():
    x = np.concatenate([np.zeros(50), np.ones(MIN_COUNT - 1)])  # the last bin: too few
    residual = np.concatenate([np.full(50, 2.0), np.full(MIN_COUNT - 1, 5.0)])
    residual[3] = np.nan
    binned = binned_means(x, residual, bins=4)
    assert binned.centre == [0.0] and binned.mean == [2.0] and binned.count == [49]
    assert binned_means(np.ones(30), np.ones(30)).centre == []  # no range: no bins


def test_too_short_or_empty_series_have_no_diagnostics():
    time = np.arange(10.0)
    assert diagnose(time, np.sin(time), np.zeros(10)) is None
    assert diagnose(np.arange(40.0), np.full(40, np.nan), np.zeros(40)) is None


def test_the_rate_of_a_signal_is_its_derivative_in_the_components():
    assert rate_of("phi") == "w" and rate_of("x") == "v" and rate_of("qm") is None


def test_a_recorded_rate_is_the_speed_the_residual_is_binned_by():
    time = np.arange(0.0, 5.0, 1e-3)
    phi, w = np.sin(3 * time), 3 * np.cos(3 * time)
    fit = ExperimentFit("run", time, {"phi": phi, "w": w}, {"phi": phi - 0.01 * w, "w": w})
    found = diagnostics_of(fit)
    assert found["phi"].speed_from == "w (recorded)"
    assert np.asarray(found["phi"].speed.mean) == pytest.approx(0.01 * np.asarray(found["phi"].speed.centre))


def long_fit(samples: int = 30_000) -> ExperimentFit:
    time = np.linspace(0.0, 30.0, samples)
    phi = math.pi + np.exp(-time / 10) * np.sin(6 * time)
    residual = 0.002 * np.sign(np.cos(6 * time)) + ar1(0.8, samples, seed=4) * 1e-4
    return ExperimentFit("long", time, {"phi": phi}, {"phi": phi - residual}, {"phi": 1e-3})


def test_a_long_recordings_diagnostics_survive_its_envelope_in_the_result_file(tmp_path):
    fit = long_fit()
    fitted = result("pendulum", [], [fit])
    before = diagnostics_of(fit)["phi"]
    back = read_result(fitted.write_json(tmp_path / "result.json")).experiments[0]
    assert not whole(back) and len(back.time) < len(fit.time)  # the file holds the envelope
    assert diagnostics_of(back)["phi"] == before  # computed from every sample before it was written
    assert before.samples == 30_000
    back.diagnostics = {}  # an older file: the envelope, but no stored diagnostics
    assert diagnostics_of(back) == {}
