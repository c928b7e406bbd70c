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
FIRMWARE_STEP = math.radians(1 / FIRMWARE_DIVISOR)  # one count in the printed degrees, in rad
# What the firmware's division predicts for pendfmu's sensor parameters (measurement.py:
# reading = scale * true + offset, phi from the upward vertical). The printed degrees are
# counts / 11 where a true degree is 4000/360 = 11.11 counts, so a printed angle is
# 11.11/11 = 1.0101 times the true one, about the hanging zero of the file. In pendfmu's
# convention phi = pi + angle, so reading = pi + s (true - pi + zero) = s true + pi (1 - s)
# + s zero: the scale s = 400/396 and an offset of pi (1 - s) = -0.0317 rad (-1.82 deg)
# plus the encoder's zero error times s.
FIRMWARE_SCALE = (FURUTA_COUNTS / 360) / FIRMWARE_DIVISOR
FIRMWARE_OFFSET = math.pi * (1 - FIRMWARE_SCALE)
FURUTA_PERIOD = 1e-3  # s, the nominal sample period (not time stamped)
# Published rod (model.py): rod 12.25 g plus half the 6.93 g hinge, over the rod's
# 124 mm plus the 11 mm coupler and 2 mm hinge offsets; centre of mass at half of that.
FURUTA_MASS = 0.01225 + 0.00693 / 2
FURUTA_LENGTH = 0.011 + 0.124 + 0.002
FURUTA_ROD = {"m_p": FURUTA_MASS, "l": FURUTA_LENGTH / 2, "J_p": FURUTA_MASS * FURUTA_LENGTH**2 / 3}
FURUTA_SMOOTHING = 31  # samples of the local cubic for rates and turning points: 31 ms of a 0.6 s swing


def read_furuta_degrees(path: Path = FURUTA_TXT) -> np.ndarray:
    """The printed degrees, as the firmware wrote them. The firmware prints counts / 11
    with two decimals (11 = 4000/360 in integer division, so the printed scale is 1 %
    high); that the file is such a print is checked: every value times 11 must lie within
    the printing's rounding (11 * 0.005) of an integer."""
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
    return degrees


def furuta_recording(path: Path = FURUTA_TXT) -> Recording:
    """The free decay as one pendulum-stage recording.

    Angle: the firmware's printed degrees, converted to pendfmu's convention only: rad,
    from the upward vertical, phi = pi + radians(printed) (0 = hanging in the file, pi in
    pendfmu). Nothing is corrected by hand: the printed scale (1 % high, counts / 11) and
    the encoder's zero error are fitted as phi_scale and phi_offset (OPTIONS; the values
    the firmware predicts are FIRMWARE_SCALE and FIRMWARE_OFFSET). The file is checked to
    be counts / 11 printed to two decimals (read_furuta_degrees); the resolution is one
    count as printed, 1/11 deg. Time: the nominal 1 ms per line.
    Window: from the first turning point after the hand release (the hand takes the
    pendulum from -90 to about -136 deg in the first 0.25 s and lets go there; the first
    half swing after it loses four times what the next ones lose, so the hand was not yet
    clear) to the last turning point in the record, so that the fit starts at rest where the stage estimates the angle, and the
    rate at the first sample (the turning point falls between samples) is the known
    initial state w, from the local cubic fit, in the recording's own (printed) scale."""
    phi = math.pi + np.radians(read_furuta_degrees(path))
    time = np.arange(len(phi)) * FURUTA_PERIOD
    indices, _ = turning_points(time, phi, FURUTA_SMOOTHING)
    released = int(np.argmin(phi[indices]))  # the hand's extreme, -136 deg
    first, last = int(indices[released + 1]), int(indices[-1])
    rate = angular_rate(time, phi, FURUTA_SMOOTHING)
    return Recording(path.with_name("furuta"), time[first:last + 1], {"phi": phi[first:last + 1]},
                     experiment="Furuta pendulum free swing, arm held (rotary-inverted-pendulum run 01)",
                     signal_info={"phi": SignalInfo(FIRMWARE_STEP)}, initial={"w": float(rate[first])})


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
# The encoder's zero and the firmware's scale are fitted (the conversion corrects neither);
# the friction's boxes are pendfmu's, derived from the rod's mass and length (no value given).
OPTIONS = ("--free", "J_p", "phi_offset", "phi_scale", "--bounds", f"J_p={J_P_LOW!r}:{J_P_HIGH!r}")
RUN_OPTIONS = ("--uncertainty", "jacobian")


def build() -> tuple[list[Recording], dict[str, float]]:
    return [furuta_recording()], furuta_parameters()


# ------------------------------------------------------------ the published damping

PUBLISHED_DAMPING = 4.638e-4  # model.py's pendulum "damping coefficient", the average of three runs
DEG = 180 / math.pi  # the published value's hidden factor: its frequency is in deg/s (below)
PEAK_HALF = 15  # samples either side of a maximum in its parabola (the turning points' own window)


def authors_damping(time: np.ndarray, degrees: np.ndarray, refine: bool = True) -> dict[str, float]:
    """The authors' damping figure (their compute.py, re-done here): the first two maxima
    A1, A2 of the printed angle (deg, 0 = hanging) one period T apart, omega_d = 360 / T in
    deg/s, A2 = A1 exp(-zeta omega_n T) with omega_d = omega_n sqrt(1 - zeta^2), solved for
    zeta. With omega in deg/s instead of rad/s that zeta is the damping ratio divided by
    180/pi: the published 4.638e-4 is a damping ratio of 0.0266, not a coefficient in
    N m s. `refine`: each maximum from a parabola through PEAK_HALF samples either side
    (their find_peaks takes the largest sample; the same to 1 % here, and smooth in the
    model's parameters, which the intervals need). A maximum at the first sample counts
    (the fit's window starts at one). Returns the published quantity ("deg_per_s"), the
    damping ratio, the period and the maxima."""
    inner = np.flatnonzero((degrees[1:-1] >= degrees[:-2]) & (degrees[1:-1] > degrees[2:])) + 1
    maxima = [0] if degrees[0] >= degrees[1] and degrees[0] > 0 else []
    for index in inner:  # the largest sample of each swing to the positive side
        if degrees[index] > 0 and (not maxima or time[index] - time[maxima[-1]] > 0.1):
            maxima.append(int(index))
    (t1, a1), (t2, a2) = [_peak(time, degrees, i) if refine else (time[i], degrees[i]) for i in maxima[:2]]
    period = t2 - t1
    rate = math.log(a1 / a2) / period  # zeta omega_n, 1/s
    ratio = rate / (2 * math.pi / period)
    zeta = ratio / math.sqrt(1 + ratio**2)  # omega_d = omega_n sqrt(1 - zeta^2) solved for zeta
    in_degrees = (rate / (360 / period)) / math.sqrt(1 + (rate / (360 / period)) ** 2)
    return {"deg_per_s": in_degrees, "damping_ratio": zeta, "period": period, "A1": a1, "A2": a2}


def _peak(time: np.ndarray, values: np.ndarray, index: int) -> tuple[float, float]:
    low, high = max(0, index - PEAK_HALF), min(len(values), index + PEAK_HALF + 1)
    c = np.polyfit(time[low:high] - time[index], values[low:high], 2)
    at = float(np.clip(-c[1] / (2 * c[0]), time[low] - time[index], time[high - 1] - time[index]))
    return time[index] + at, float(np.polyval(c, at))


def model_reading(parameters: dict[str, float], phi0: float, w0: float, time: np.ndarray) -> np.ndarray:
    """The fitted model's free decay as the firmware prints it: the Pendulum simulated
    from (phi0, w0), read through the fitted sensor (phi_scale * phi + phi_offset), in
    degrees from hanging."""
    from pendfmu.components import COMPONENTS
    from pendfmu.simulator import ComponentFMU

    own = {k: v for k, v in parameters.items() if k in COMPONENTS["Pendulum"].parameters}
    with ComponentFMU("Pendulum", {**own, "phi0": phi0, "w0": w0}) as pendulum:
        phi = pendulum.run(time - time[0], ["phi"])["phi"]
    reading = parameters.get("phi_scale", 1.0) * phi + parameters.get("phi_offset", 0.0)
    return np.degrees(reading - math.pi)


def published_comparison(document: dict, recording: Recording | None = None) -> dict:
    """The fit's damping against the published figure, in the published quantity's own
    terms, with 95 % intervals from the fit's standard errors and correlations (linear
    propagation; central differences of one standard error).

    * "published": 4.638e-4 as computed (omega in deg/s), and converted to the damping
      ratio it is (x 180/pi);
    * "authors_method_this_run": the authors' procedure on this run's file (their sample
      maxima, as compute.py: 4.35e-4, the published 4.638e-4 averages three runs) and
      with refined maxima on the fitted window;
    * "fitted_model": the authors' procedure applied to pendfmu's fitted model (simulated
      over the window from the fitted phi0 through the fitted sensor): the like-for-like
      figure, viscous and Coulomb friction and the large swing together;
    * "viscous_only": k_fwp as a small-swing damping ratio k_fwp / (2 sqrt(J_p m_p g l))
      (and in the published units, / (180/pi)); "coulomb_equivalent": the Coulomb
      torque's damping ratio at the authors' mean amplitude A (rad, linearized: a loss of
      4 T_Kp / (m_p g l) per period, zeta = 2 T_Kp / (pi m_p g l A));
    * "as_coefficient": model.py uses the number as a viscous torque coefficient in
      N m s (its pendulum equation has -DC_pendulum * theta_dot): 4.638e-4 N m s against
      k_fwp."""
    recording = recording or furuta_recording()
    p = document["parameters"]
    time = recording.time
    phi0 = document["initial"][recording.label]["phi0"]
    w0 = recording.initial["w"]
    names = [n for n in ("k_fwp", "T_Kp", "J_p", "phi_offset", "phi_scale") if document["stderr"].get(n)]
    sigma = np.array([document["stderr"][n] for n in names])
    correlation = np.array([[1.0 if a == b else (document.get("correlation", {}).get(a, {}).get(b) or 0.0)
                             for b in names] for a in names])
    covariance = correlation * np.outer(sigma, sigma)

    def figure(values: dict[str, float]) -> dict[str, float]:
        return authors_damping(time, model_reading(values, phi0, w0, time))

    def interval(function) -> dict[str, float | list[float]]:
        value = function(p)
        gradient = np.array([(function({**p, n: p[n] + s}) - function({**p, n: p[n] - s})) / (2 * s)
                             for n, s in zip(names, sigma)])
        spread = 1.96 * math.sqrt(max(float(gradient @ covariance @ gradient), 0.0))
        return {"value": value, "ci95": [value - spread, value + spread]}

    g = p.get("g", 9.81)
    stiffness = p["m_p"] * g * p["l"]  # m_p g l, N m
    data = authors_damping(time, np.degrees(recording.signal("phi") - math.pi))
    raw = read_furuta_degrees()
    raw_figure = authors_damping(np.arange(len(raw)) * FURUTA_PERIOD, raw, refine=False)
    amplitude = 0.5 * (data["A1"] + data["A2"]) / DEG / p.get("phi_scale", 1.0)  # true, rad
    viscous = interval(lambda v: v["k_fwp"] / (2 * math.sqrt(v["J_p"] * stiffness)))
    coulomb = interval(lambda v: 2 * v["T_Kp"] / (math.pi * stiffness * amplitude))
    model = interval(lambda v: figure(v)["deg_per_s"])
    in_published = {k: (v / DEG if k == "value" else [b / DEG for b in v]) for k, v in viscous.items()}
    return {
        "published": {"value": PUBLISHED_DAMPING, "unit": "1 (a damping ratio computed with omega in deg/s)",
                      "damping_ratio": PUBLISHED_DAMPING * DEG},
        "authors_method_this_run": {"sample_maxima": raw_figure["deg_per_s"], "refined_maxima": data["deg_per_s"],
                                    "damping_ratio": data["damping_ratio"], "period_s": data["period"],
                                    "A1_deg": data["A1"], "A2_deg": data["A2"]},
        "fitted_model": {**model, "damping_ratio": {"value": model["value"] * DEG,
                                                    "ci95": [b * DEG for b in model["ci95"]]},
                         "against_published": model["value"] / PUBLISHED_DAMPING,
                         "against_this_run": model["value"] / data["deg_per_s"]},
        "viscous_only": {"damping_ratio": viscous, "published_units": in_published,
                         "against_published": in_published["value"] / PUBLISHED_DAMPING},
        "coulomb_equivalent": {"damping_ratio": coulomb, "amplitude_rad": amplitude},
        "as_coefficient": {"published_N_m_s": PUBLISHED_DAMPING, "k_fwp_N_m_s": p["k_fwp"],
                           "ratio": PUBLISHED_DAMPING / p["k_fwp"]},
        "stiffness_N_m": stiffness,
        "propagated_from": names,
    }
