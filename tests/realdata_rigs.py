"""Adapters for three more real data sets, as a new user would bring them to today's stages.

Like ``realdata.py``, nothing here copies the files or writes anything derived from them
into the repository: the adapters read ``../shared/realdata/<name>/`` in place and build
pendfmu Recordings in memory; callers skip when a file is absent (:func:`realdata.available`).

* ``friction-identification`` (cart stage, driven by ``I``): a servo carriage, start-up
  and braking to rest. The servo's own torque reading is the drive, its speed integrated
  is the position (:func:`carriage_recording`).
* ``rotary-inverted-pendulum`` (pendulum stage, free decay): a Furuta pendulum's free
  swing with the arm held still (:func:`furuta_recording`).
* ``EMPS`` (cart stage, driven by ``I``): a positioning stage under its own position loop,
  replayed open loop from the recorded controller output (:func:`emps_recording`).

``physical-cartpole`` is not adapted: see :data:`SKIPPED`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.integrate import cumulative_trapezoid

from pendfmu.recording import Recording, RecordingError, SignalInfo

from realdata import REALDATA, angular_rate, turning_points

# ================================================================ friction-identification

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


# ================================================================ rotary-inverted-pendulum

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


# ================================================================ EMPS

EMPS_MAT = REALDATA / "EMPS" / "DATA_EMPS.mat"
EMPS_TRAVEL_PER_REV = 2.5e-3  # m per motor revolution on the load side (SOURCE.txt: 0.05 um per count, 50000 counts)
EMPS_K_D = 2 * math.pi / EMPS_TRAVEL_PER_REV
EMPS_RESOLUTION = 5e-8  # m, one encoder count on the load side
# Published IDIM-LS model (Simulation_EMPS.m): M ddq = gtau vir - Fv dq - Fc sign(dq) - OF
EMPS_PUBLISHED = {"M1": 95.1089, "Fv1": 203.5034, "Fc1": 20.3935, "OF1": -3.1648}
EMPS_START_SAMPLES = 20  # the benchmark's state initialization window (samples)


@dataclass(frozen=True)
class EmpsRecord:
    time: np.ndarray  # s
    qm: np.ndarray  # m, motor encoder on the load side
    vir: np.ndarray  # V, controller output
    gtau: float  # N/V


def read_emps(path: Path = EMPS_MAT) -> EmpsRecord:
    from scipy.io import loadmat

    data = loadmat(path)
    for name in ("t", "qm", "vir", "gtau"):
        if name not in data:
            raise RecordingError(f"{path}: no variable {name!r}")
    return EmpsRecord(np.ravel(data["t"]), np.ravel(data["qm"]), np.ravel(data["vir"]),
                      float(np.ravel(data["gtau"])[0]))


def emps_parameters(record: EmpsRecord | None = None) -> dict[str, float]:
    """The published gains and mass: m_c = M1, k_M k_D = gtau (35.15 N/V) with k_D from
    2.5 mm per revolution, no pendulum; the published friction as the start of the fit.
    eta is free: the published model has no efficiency (gtau already is the force per
    volt), so it should come out near 1, its physical limit."""
    record = record or read_emps()
    return {"m_c": EMPS_PUBLISHED["M1"], "m_p": 0.0, "k_D": EMPS_K_D, "k_M": record.gtau / EMPS_K_D,
            "k_fwc": EMPS_PUBLISHED["Fv1"], "F_Kc": EMPS_PUBLISHED["Fc1"]}


def emps_recording(record: EmpsRecord | None = None) -> Recording:
    """The identification record replayed open loop, as the benchmark does (u = vir,
    y = qm): a cart-stage recording driven by ``I`` = vir in volts, minus the published
    offset force OF1 expressed in volts (the stage has no constant force, and the
    published model subtracts it from the drive), fitted to ``x`` = qm, whose step is
    one encoder count (5e-8 m; every qm value is a multiple of it).

    The record starts in motion, and the cart stage takes its initial state from the
    sidecar: x0 and v0 from a quadratic fit of the first 20 samples (the benchmark's
    initialization window), evaluated at the first sample."""
    record = record or read_emps()
    n = EMPS_START_SAMPLES
    c = np.polyfit(record.time[:n] - record.time[0], record.qm[:n], 2)
    drive = record.vir - EMPS_PUBLISHED["OF1"] / record.gtau
    return Recording(EMPS_MAT.with_name("emps"), record.time, {"I": drive, "x": record.qm},
                     experiment="EMPS identification record, open loop from the controller output",
                     signal_info={"x": SignalInfo(EMPS_RESOLUTION)}, parameters={"m_p": 0.0},
                     initial={"x": float(c[2]), "v": float(c[1])})


# ================================================================ physical-cartpole

CARTPOLE_CSV = REALDATA / "physical-cartpole" / "ICRA_ODE_2.csv"
SKIPPED = {
    "physical-cartpole": (
        "not fitted: today's stages cannot describe this run. (1) The command is a PWM duty to an "
        "H-bridge, a voltage: the force then depends on the motor's back-EMF and the supply, not on a "
        "current the cart stage can take. (2) The cart is belt driven, so back-drivable, and the pole "
        "swings up through the whole circle: the cart stage needs the pole's phi, w and alpha, which "
        "the recording holds only as a potentiometer angle and its finite difference. (3) The pendulum "
        "stage needs the cart's acceleration: the second difference of a 21 ms encoder position with "
        "latency jitter is mostly noise. (4) It is a closed loop (MPC) whose parameters were hand "
        "tuned, so there is no published identification to compare with either."),
}
