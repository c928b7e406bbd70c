"""The display envelope (pendfmu/fitting/envelope.py): long signals reduced for plotting
and storing without hiding a sample.

Checked against its definition, bucket by bucket, with a brute-force loop: the kept
samples of each bucket span exactly the range of all its samples, for every array."""

from __future__ import annotations

import numpy as np
import pytest

from pendfmu.fitting.envelope import BUCKETS, FULL_RESOLUTION_UP_TO, bucket_edges, envelope_indices


def within_each_bucket(values: np.ndarray, kept: np.ndarray, buckets: int) -> None:
    """Every original sample lies within its bucket's kept minimum and maximum, and both
    extremes are kept samples of that bucket."""
    edges = bucket_edges(len(values), buckets)
    for a, b in zip(edges[:-1], edges[1:]):
        mine = kept[(kept >= a) & (kept < b)]
        assert mine.size, f"bucket [{a}, {b}) keeps nothing"
        finite = values[a:b][np.isfinite(values[a:b])]
        if finite.size:
            assert np.nanmin(values[mine]) == finite.min() and np.nanmax(values[mine]) == finite.max()


@pytest.mark.parametrize("samples", [FULL_RESOLUTION_UP_TO + 1, 150_001, 333_337])
def test_every_sample_lies_within_the_envelope_of_its_bucket(samples):
    rng = np.random.default_rng(samples)
    time = np.linspace(0.0, 30.0, samples)
    recorded = np.round(np.exp(-time / 8) * np.sin(9 * time) / 0.006) * 0.006 + rng.normal(0, 1e-3, samples)
    simulated = np.exp(-time / 8) * np.sin(9 * time)
    kept = envelope_indices([recorded, simulated, recorded - simulated])
    assert np.all(np.diff(kept) > 0) and kept[0] == 0 and kept[-1] == samples - 1
    assert kept.size <= 6 * BUCKETS + 2
    for values in (recorded, simulated, recorded - simulated):
        within_each_bucket(values, kept, BUCKETS)


def test_a_single_sample_spike_survives():
    samples = 200_000
    values = np.zeros(samples)
    for where, height in ((12_345, 5.0), (150_001, -3.0), (samples - 1, 7.0)):
        values[where] = height
    kept = envelope_indices([values])
    assert {12_345, 150_001, samples - 1} <= set(kept.tolist())
    assert values[kept].max() == 7.0 and values[kept].min() == -3.0


def test_short_recordings_are_kept_whole():
    for samples in (0, 1, 10, FULL_RESOLUTION_UP_TO):
        assert envelope_indices([np.arange(samples, dtype=float)]).tolist() == list(range(samples))


def test_missing_samples_are_never_chosen_over_numbers():
    samples = 50_000
    values = np.sin(np.arange(samples) / 100.0)
    values[::3] = np.nan
    values[1000:1100] = np.nan  # two whole buckets (50 samples each) missing: each keeps its first sample
    kept = envelope_indices([values])
    within_each_bucket(values, kept, BUCKETS)
    edges = bucket_edges(samples, BUCKETS)
    for a, b in zip(edges[:-1], edges[1:]):
        mine = kept[(kept >= a) & (kept < b)]
        if np.isfinite(values[a:b]).any():
            assert np.isfinite(values[mine]).any()


def test_arrays_of_different_lengths_are_an_error():
    with pytest.raises(ValueError, match="different lengths"):
        envelope_indices([np.zeros(10), np.zeros(11)])
