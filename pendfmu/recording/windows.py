"""Fit windows and segments: the parts of a recording a fit uses.

A recording may be longer than a model can follow: a closed-loop or unstable run drifts
in open loop, a rig leaves its model's range between manoeuvres, a sensor drops out.
The user names the parts that count, as windows (--window T0:T1, any number) and/or
as segments of a fixed length (--segment SECONDS: each window, or the whole recording,
split into consecutive pieces). Each part becomes a recording of its own
(Recording.window), so a fit gives each its own initial states (multiple shooting
without continuity constraints: every segment starts from estimated or measured
states; experiment.prepare).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from pendfmu.recording.model import Recording
from pendfmu.recording.schema import RecordingError


def parse_window(text: str) -> tuple[float, float]:
    """'T0:T1' (seconds; either side may be empty: from the start, to the end)."""
    first, colon, last = text.partition(":")
    try:
        window = (float(first) if first.strip() else -math.inf, float(last) if last.strip() else math.inf)
    except ValueError:
        window = None
    if not colon or window is None or not window[1] > window[0]:
        raise RecordingError(f"window {text!r}: give it as T0:T1 in seconds with T0 < T1 (e.g. 2.5:7)")
    return window


def cut(recording: Recording, windows: Sequence[tuple[float, float]] = (), segment: float | None = None
        ) -> list[Recording]:
    """The parts of `recording` a fit uses: each window (all of it when none is given),
    split into segments of `segment` seconds where given (a last piece shorter than half
    a segment joins the one before). A window outside the recording is an error."""
    if segment is not None and not (math.isfinite(segment) and segment > 0):
        raise RecordingError(f"segment length {segment!r}: must be a positive number of seconds")
    start, end = float(recording.time[0]), float(recording.time[-1])
    spans = []
    for low, high in windows or [(start, end)]:
        low, high = max(low, start), min(high, end)
        if not high > low:
            raise RecordingError(f"{recording.source}: the window {low:g}:{high:g} s is outside the recording "
                                 f"({start:g} to {end:g} s)")
        if segment is None:
            spans.append((low, high))
            continue
        count = max(1, round((high - low) / segment))
        edges = [low + k * segment for k in range(count)] + [high]
        half = 0.5 * float(recording.time[1] - recording.time[0])  # a sample at an edge opens the next piece
        spans += [(a, b - half if k < count - 1 else b) for k, (a, b) in enumerate(zip(edges[:-1], edges[1:]))]
    if not windows and segment is None:
        return [recording]
    return [recording.window(low, high) for low, high in spans]
