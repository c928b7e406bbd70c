"""friction-identification: a servo carriage's start-up and braking to rest, converted to
a cart-stage recording driven by the servo's torque reading (``--drive I``).

The servo's own torque reading is the drive, scaled to force by the load cell
(:func:`force_per_torque`); its speed integrated is the position
(:func:`carriage_recording`). The published friction model is the fit's start.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.integrate import cumulative_trapezoid

from pendfmu.recording import Recording, RecordingError, SignalInfo

from _common import REALDATA

CARRIAGE_MR = REALDATA / "friction-identification" / "a3MR.csv"
CARRIAGE_NI = REALDATA / "friction-identification" / "a3NI.csv"
REDUCED_MASS = 24.7  # kg, extraction.m
TRAVEL_PER_REV = 0.020  # m per motor revolution, acquisition.m (rack and pinion)
CARRIAGE_K_D = 2 * math.pi / TRAVEL_PER_REV  # 1/m
RPM_STEP = 1.0  # the scope's speed channel reads whole r/min
TORQUE_STEP = 0.1  # % of rated torque: the torque channel's step
LOAD_CELL = 200.0  # N/V, acquisition.m
NI_SHIFT = 0.004  # s added to the NI clock (conditioning.m: time_shift = -0.004, t_NI - time_shift)
# Published static friction model (output/coeffs_for_friction_model.mat): dry c1, viscous
# c2, the force c3 the Stribeck term reaches at rest. A user starts the fit there.
PUBLISHED_FRICTION = {"F_Kc": 10.0, "k_fwc": 67.44, "F_Sc": 29.63}


@dataclass(frozen=True)
class ServoScope:
    time: np.ndarray  # s
    speed: np.ndarray  # r/min, as exported (negative: the carriage's forward direction)
    torque: np.ndarray  # % of rated torque, as exported
    droop: np.ndarray  # encoder pulses (saturates at the 16-bit limit)


def read_servo_scope(path: Path = CARRIAGE_MR) -> ServoScope:
    """The servo amplifier's scope export: 5 header lines, the 5th naming the channels.
    The channel names and the sample count are checked, so another export layout fails
    here instead of giving a drive in the wrong unit."""
    with open(path, encoding="ascii") as f:
        header = [next(f) for _ in range(5)]
    names = [n.strip() for n in header[4].split(",")]
    if names[:4] != ["ms", "Servo motor speed", "Torque", "Droop pulses (by 1 pls.)"]:
        raise RecordingError(f"{path}: expected channels ms, speed, torque, droop pulses; got {names[:4]}")
    data = np.loadtxt(path, delimiter=",", skiprows=5, ndmin=2)
    if len(data) != int(header[1].split(",")[1]):
        raise RecordingError(f"{path}: {len(data)} rows, the header announces {header[1].strip()}")
    return ServoScope(data[:, 0] / 1000.0, data[:, 1], data[:, 2], data[:, 3])


def read_load_cell(path: Path = CARRIAGE_NI) -> tuple[np.ndarray, np.ndarray]:
    """The NI record's load-cell force [N] on the servo's clock, as acquisition.m and
    conditioning.m make it: volts minus the mean of the first 10 samples, times -200 N/V,
    time shifted by +4 ms."""
    data = np.loadtxt(path, delimiter=",", skiprows=4, encoding="utf-8-sig", ndmin=2)
    volts = data[:, 1]
    return data[:, 0] + NI_SHIFT, -(volts - volts[:10].mean()) * LOAD_CELL


def carriage_speed(scope: ServoScope) -> np.ndarray:
    """m/s, positive forward (acquisition.m: v = -rpm * 20 mm / 60 s)."""
    return -scope.speed * TRAVEL_PER_REV / 60.0


def force_per_torque(scope: ServoScope, load_cell: tuple[np.ndarray, np.ndarray]) -> tuple[float, float]:
    """N of drive force per unit of the servo's torque reading (fraction of rated), from
    the load cell: an independent sensor, so the scale is not taken from the speed the fit
    is made to. Least squares F_cell = c * tau + b over the samples while the carriage
    moves and the NI record lasts (the authors treat the load-cell force as the force
    that drives the reduced mass: F_fric = F - 24.7 a). Returns (c, rms of the fit's
    residual). The momentum balance from the speed alone (24.7 kg times the acceleration
    against tau, with Coulomb and viscous terms) gives 673 N against the load cell's 691 N
    (:func:`momentum_balance_scale`): the two agree within 3 %."""
    time, force = load_cell
    tau = -scope.torque / 100.0
    use = (carriage_speed(scope) > 0.01) & (scope.time <= time[-1])
    A = np.column_stack([tau[use], np.ones(np.count_nonzero(use))])
    cell = np.interp(scope.time[use], time, force)
    (c, _), residual, *_ = np.linalg.lstsq(A, cell, rcond=None)
    return float(c), float(math.sqrt(residual[0] / np.count_nonzero(use)))


def momentum_balance_scale(scope: ServoScope) -> float:
    """The same scale from the servo alone: m a = c tau - F_K - k v while moving, least
    squares for (c, F_K, k), with a from a local quadratic fit of the speed over 31
    samples (20 ms). Only a cross-check of :func:`force_per_torque`."""
    from scipy.signal import savgol_filter

    v = carriage_speed(scope)
    a = savgol_filter(v, 31, 2, deriv=1, delta=float(np.median(np.diff(scope.time))))
    use = v > 0.02
    A = np.column_stack([-scope.torque[use] / 100.0, -np.ones(np.count_nonzero(use)), -v[use]])
    (c, _, _), *_ = np.linalg.lstsq(A, REDUCED_MASS * a[use], rcond=None)
    return float(c)


def carriage_parameters(scope: ServoScope | None = None) -> dict[str, float]:
    """The cart's known values: the published reduced mass (motor inertia included, as
    m_c is in MODEL.md), k_D from 20 mm per revolution, no pendulum, and k_M such that
    k_M k_D I is the load cell's force for the torque reading I (fraction of rated
    torque): k_M is then the rated torque in N m (2.2 N m; SOURCE.txt names no motor).
    The efficiency eta stays free; with the drive scaled by the load cell it should come
    out near 1, its physical limit."""
    scope = scope or read_servo_scope()
    c, _ = force_per_torque(scope, read_load_cell())
    return {"m_c": REDUCED_MASS, "m_p": 0.0, "k_D": CARRIAGE_K_D, "k_M": c / CARRIAGE_K_D, **PUBLISHED_FRICTION}


def carriage_recording(scope: ServoScope | None = None) -> Recording:
    """The start-up and braking as a cart-stage recording driven by the recorded ``I``.

    Drive: the servo's torque reading, as a fraction of rated torque, sign turned so that
    positive drives the carriage forward. It is the motor's torque itself, so the stage
    runs without the current loop (``--drive I``).

    Position: the speed integrated (trapezoid, from 0 at the first sample). Why not the
    droop pulses: they are the servo's position *error* (command minus position), not the
    position, and they sit at the 16-bit limit -32768 for 94 % of the motion. The speed
    is read in whole r/min (3.3e-4 m/s); its rounding errors integrate to a random walk
    whose rms over the record, dt * (step/sqrt(12)) * sqrt(N/2), is the position's stated
    noise (1.5 um); there is no quantization step in an integral.
    """
    scope = scope or read_servo_scope()
    speed = carriage_speed(scope)
    x = cumulative_trapezoid(speed, scope.time, initial=0.0)
    dt = float(np.median(np.diff(scope.time)))
    speed_step = RPM_STEP * TRAVEL_PER_REV / 60.0
    walk = dt * speed_step / math.sqrt(12) * math.sqrt(len(speed) / 2)
    return Recording(
        CARRIAGE_MR.with_name("carriage"), scope.time, {"I": -scope.torque / 100.0, "x": x},
        experiment="servo carriage start-up and braking (friction-identification a3MR)",
        signal_info={"I": SignalInfo(TORQUE_STEP / 100.0), "x": SignalInfo(None, noise=walk)},
        parameters={"m_p": 0.0}, initial={"x": 0.0, "v": 0.0})



STAGE = "cart"
SOURCES = (CARRIAGE_MR, CARRIAGE_NI)
OPTIONS = ("--drive", "I")  # the torque reading is the motor's torque: no current loop
RUN_OPTIONS = ("--uncertainty", "jacobian")


def build() -> tuple[list[Recording], dict[str, float]]:
    scope = read_servo_scope()
    return [carriage_recording(scope)], carriage_parameters(scope)
