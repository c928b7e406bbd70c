"""Long recordings made small enough to plot and to store, without hiding a sample.

A 30 s decay sampled at 5 kHz is 150 000 points per signal: a browser plotting several
of them slows to a crawl, and a result file holding them grows to megabytes. Plain
decimation (every k-th sample) would be small but could drop the one spike that matters.
The envelope keeps, for each of `buckets` equal runs of samples, the sample with the
lowest and the one with the highest value of every array given (recorded, simulated,
residual), at their own times: every original sample lies between its bucket's kept
minimum and maximum, so a spike survives and the band the plot draws is the true range.

Arrays are reduced together (one set of indices for all) so that a reduced recorded and
simulated signal still pair sample by sample, and their residual is still their difference.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

BUCKETS = 1000
"""Display buckets of a long recording: at most 2 samples per bucket and array, so at most
6000 kept samples for recorded, simulated and residual together (typically far fewer, as
their extremes coincide), against the ~1400 pixels of a wide plot."""
FULL_RESOLUTION_UP_TO = 4 * BUCKETS
"""A recording this short (samples) is kept whole: the envelope would save little."""


def bucket_edges(samples: int, buckets: int = BUCKETS) -> np.ndarray:
    """The first index of each bucket and, last, `samples`: buckets of equal length (+-1)."""
    return np.linspace(0, samples, min(buckets, samples) + 1).astype(int)


def envelope_indices(arrays: Sequence[np.ndarray], buckets: int = BUCKETS,
                     full_up_to: int = FULL_RESOLUTION_UP_TO) -> np.ndarray:
    """Sorted indices of the samples to keep: all of them for a short recording; else the
    first, the last, and per bucket the minimum and maximum of each array (missing
    samples, NaN, aside; a bucket of an array that is all NaN keeps its first sample)."""
    arrays = [np.asarray(a, float) for a in arrays]
    samples = len(arrays[0]) if arrays else 0
    if any(len(a) != samples for a in arrays):
        raise ValueError(f"arrays of different lengths: {[len(a) for a in arrays]}")
    if samples <= max(full_up_to, 2 * buckets):
        return np.arange(samples)
    edges = bucket_edges(samples, buckets)
    keep = [np.array([0, samples - 1])]
    for values in arrays:
        # NaN ranks last for the minimum and first for the maximum: never kept over a number
        low = np.where(np.isnan(values), np.inf, values)
        high = np.where(np.isnan(values), -np.inf, values)
        keep.append(edges[:-1] + np.array([np.argmin(low[a:b]) for a, b in zip(edges[:-1], edges[1:])]))
        keep.append(edges[:-1] + np.array([np.argmax(high[a:b]) for a, b in zip(edges[:-1], edges[1:])]))
    return np.unique(np.concatenate(keep))
