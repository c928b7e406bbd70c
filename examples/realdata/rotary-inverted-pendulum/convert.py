"""rotary-inverted-pendulum: a Furuta pendulum's free swing with the arm held still,
converted to one pendulum-stage recording (:func:`furuta_recording`).

The published rod gives mass and length; its inertia J_p is fitted with the friction
(:func:`furuta_parameters` says why).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from pendfmu.recording import Recording, RecordingError, SignalInfo

from _common import REALDATA, angular_rate, turning_points

FURUTA_TXT = REALDATA / "rotary-inverted-pendulum" / "pendulum_free_swing_data_01.txt"
FURUTA_COUNTS = 4000  # encoder pulses per revolution
FIRMWARE_DIVISOR = 11  # PULSES_PER_DEGREE = 4000/360 in integer arithmetic: degrees printed = counts / 11
FURUTA_RESOLUTION = 2 * math.pi / FURUTA_COUNTS
FURUTA_PERIOD = 1e-3  # s, the nominal sample period (not time stamped)
# Published rod (model.py): rod 12.25 g plus half the 6.93 g hinge, over the rod's
# 124 mm plus the 11 mm coupler and 2 mm hinge offsets; centre of mass at half of that.
FURUTA_MASS = 0.01225 + 0.00693 / 2
FURUTA_LENGTH = 0.011 + 0.124 + 0.002
FURUTA_ROD = {"m_p": FURUTA_MASS, "l": FURUTA_LENGTH / 2, "J_p": FURUTA_MASS * FURUTA_LENGTH**2 / 3}
FURUTA_SMOOTHING = 31  # samples of the local cubic for rates and turning points: 31 ms of a 0.6 s swing


def read_furuta_counts(path: Path = FURUTA_TXT) -> np.ndarray:
    """The encoder counts behind the printed degrees. The firmware prints counts / 11
    with two decimals (11 = 4000/360 in integer division, so the printed scale is 1 %
    off); the counts are recovered exactly: every value times 11 must lie within the
    printing's rounding (11 * 0.005) of an integer, which is checked."""
    with open(path, encoding="ascii") as f:
        names, values = next(f), next(f)
    if names.split(",")[0].strip() != "trigger_start_deg" or "sample_rate" not in names:
        raise RecordingError(f"{path}: expected the header 'trigger_start_deg, sample_rate, duration_sec'")
    if float(values.split(",")[1]) != 1.0 / FURUTA_PERIOD:
        raise RecordingError(f"{path}: sample_rate is {values.split(',')[1].strip()}, the adapter assumes 1000")
    degrees = np.loadtxt(path, skiprows=2)
    counts = np.rint(degrees * FIRMWARE_DIVISOR)
    if np.max(np.abs(degrees * FIRMWARE_DIVISOR - counts)) > FIRMWARE_DIVISOR * 0.005 + 1e-9:
        raise RecordingError(f"{path}: values are not counts/{FIRMWARE_DIVISOR} printed to two decimals")
    return counts


def furuta_recording(path: Path = FURUTA_TXT) -> Recording:
    """The free decay as one pendulum-stage recording.

    Angle: phi = pi + counts * 2 pi / 4000 (0 = hanging in the file, pi in pendfmu; the
    true encoder scale, not the printed one). Time: the nominal 1 ms per line.
    Window: from the first turning point after the hand release (the hand takes the
    pendulum from -90 to about -136 deg in the first 0.25 s and lets go there; the first
    half swing after it loses four times what the next ones lose, so the hand was not yet
    clear) to the last turning point in the record, so that the fit starts at rest where the stage estimates the angle, and the
    rate at the first sample (the turning point falls between samples) is the known
    initial state w, from the local cubic fit."""
    counts = read_furuta_counts(path)
    phi = math.pi + counts * FURUTA_RESOLUTION
    time = np.arange(len(phi)) * FURUTA_PERIOD
    indices, _ = turning_points(time, phi, FURUTA_SMOOTHING)
    released = int(np.argmin(phi[indices]))  # the hand's extreme, -136 deg
    first, last = int(indices[released + 1]), int(indices[-1])
    rate = angular_rate(time, phi, FURUTA_SMOOTHING)
    return Recording(path.with_name("furuta"), time[first:last + 1], {"phi": phi[first:last + 1]},
                     experiment="Furuta pendulum free swing, arm held (rotary-inverted-pendulum run 01)",
                     signal_info={"phi": SignalInfo(FURUTA_RESOLUTION)}, initial={"w": float(rate[first])})


def furuta_parameters() -> dict[str, float]:
    """The published rod. J_p is fitted as well (with bounds from a point mass at the
    centre of mass, m l^2, the least inertia any body of that mass and l has, to twice
    the rod's): the rod predicts a swing ~6 % slower than recorded (the fit's J_p is
    0.89 times the rod's), the authors themselves had to add 80 g and scale the gravity
    torque to match their model, and the 1 ms sample period is nominal; J_p absorbs all
    three."""
    return dict(FURUTA_ROD)


STAGE = "pendulum"
SOURCES = (FURUTA_TXT,)
J_P_LOW = 1.001 * FURUTA_MASS * (FURUTA_LENGTH / 2) ** 2  # just above a point mass at l
J_P_HIGH = 2 * FURUTA_ROD["J_p"]
# The friction boxes opened as for MultiArm (the default excludes small pivots).
OPTIONS = ("--free", "J_p", "--bounds", "k_fwp=1e-7:1e-2", "T_Kp=1e-7:1e-2", f"J_p={J_P_LOW!r}:{J_P_HIGH!r}")
RUN_OPTIONS = ("--uncertainty", "jacobian")


def build() -> tuple[list[Recording], dict[str, float]]:
    return [furuta_recording()], furuta_parameters()
