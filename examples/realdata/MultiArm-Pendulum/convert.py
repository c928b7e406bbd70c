"""MultiArm-Pendulum: a 55 s free decay of a single pendulum arm, angle only, converted to
pendulum-stage recordings (windows of a few swings, see :func:`decay_windows`).

The authors' angular rate is denoised, i.e. derived, and not used. The inertia, lengths
and gravity are the authors' published fit (EstimatedParameters_SinglePendulum.mat), given
as known values; the fit finds the pivot's friction.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from pendfmu.recording import Recording, RecordingError, SignalInfo

from _common import REALDATA, angular_rate, turning_points

MULTIARM_MAT = REALDATA / "MultiArm-Pendulum" / "SinglePendulumDataForParameterEstimation.mat"
ENCODER_RESOLUTION = 2 * math.pi / 40000  # the rig's high-resolution encoder
TEN_BIT = 2 * math.pi / 1024  # the paper's pendulum encoder (docs/user-guide/model.md)
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



STAGE = "pendulum"
SOURCES = (MULTIARM_MAT,)
# The friction boxes are opened: the default, a decade around the reference rig's values,
# excludes small pivots (T_Kp below 2e-4 N m).
PENDULUM_BOUNDS = ("k_fwp=1e-7:1e-2", "T_Kp=1e-7:1e-2")
OPTIONS = ("--bounds", *PENDULUM_BOUNDS)
# The Jacobian intervals: a bootstrap of 11 free parameters over 8 windows costs minutes
# (tests/realdata.py's fit_decay says why the intervals are not what is checked here).
RUN_OPTIONS = ("--uncertainty", "jacobian")
WINDOWS, CYCLES = 8, 2  # windows of two full swings (about 1.7 s), spread evenly over the decay


def build(windows: int = WINDOWS) -> tuple[list[Recording], dict[str, float]]:
    """`windows` decay windows spread evenly over the decay, at the encoder's resolution,
    with the published inertia and lengths as known values."""
    time, phi = read_multiarm_decay()
    starts = list(np.linspace(0.0, time[-1] - 5.0, windows))
    return decay_windows(MULTIARM_MAT, time, phi, ENCODER_RESOLUTION, starts, CYCLES), dict(PUBLISHED_PENDULUM)
