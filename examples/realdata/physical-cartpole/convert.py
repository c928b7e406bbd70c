"""physical-cartpole: a belt-driven cart-pole's swing-up and balance under MPC (RPGD, ICRA
2023), converted to a cart recording driven by the motor command and a pendulum recording
driven by the cart's acceleration.

The log (``ICRA_ODE_2.csv``, SOURCE.txt) is one closed-loop run of 16 s at ~21 ms, sampled
irregularly. Every decision about the raw data is made here, from the log's own columns:

* **time**: the ``time`` column as it is (irregular, 19-43 ms steps; the Cart and Pendulum
  FMUs declare ``canHandleVariableCommunicationStepSize``; drives are held or linear between
  samples).
* **the command u**: the driver logs ``Q_prev``, the command computed in the *previous*
  iteration from the previous measurement (Driver/control.py: the CSV row is written before
  ``Q_prev = Q``). Row k+1's ``Q`` is therefore put at row k's time, the instant of the
  measurement it was computed from; what is left, the controller's computation plus the
  serial link and the firmware, is ``input_delay``, fitted, to compare with the ``latency``
  column (the firmware's measured latency). The last row has no command after it and is
  dropped. The firmware adds a friction compensation to the PWM it applies
  (``actualMotorSave``, :func:`pwm_law` measures it); u is Q, the published model's input,
  so that compensation shows in the fit as a smaller Coulomb friction.
* **x**: ``position`` [m] = -9.51e-5 m x ``position_raw`` (checked: the conversion refuses a
  log where it is not), one encoder count as the resolution. Q > 0 moves the cart to +x.
* **phi**: the paper's model (docs/user-guide/model.md) measures phi from the upward vertical
  with T_A = m l (g sin phi - a cos phi), i.e. phi > 0 leans toward +x. The log's ``angle``
  is 0 upright and +-pi hanging, and its swing obeys angleDD = +(g sin(angle) + a
  cos(angle))/(2L/3) (the driver's own model, and measured: :func:`angle_sign`), so
  **phi = -angle**, unwrapped (the swing-up crosses the hanging position's +-pi). Rows the
  firmware flags ``frozen`` (the potentiometer's dead zone: the ADC reads 0 or 4095, the
  angle is a stale value) are missing samples of phi.
  ``invalid_steps`` > 0 without ``frozen`` is the firmware averaging fewer valid readings:
  those angles are kept (they lie on the smooth swing like the others: :func:`angle_outliers`).
* **w, alpha, a**: derivatives of smoothing splines (scipy ``make_smoothing_spline``, the
  smoothing chosen by generalized cross-validation: no tuning by hand, and it takes the
  irregular times as they are). A spline is non-causal (no lag) and penalizes curvature
  of the second derivative only, so a's steps (the command changes every 21 ms) are
  rounded over a few samples but not delayed. phi's spline is fitted to the valid rows only.
* **the measurement column** holds the same text on every row ("Step Response (State:idle
  ...)"): no protocol ran, the MPC drove every row; the conversion refuses a log where a
  protocol is running.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.interpolate import make_smoothing_spline

from pendfmu.fmubuild.compiler import FMUS_DIR
from pendfmu.recording import Recording, RecordingError, SignalInfo

from _common import REALDATA

CARTPOLE_CSV = REALDATA / "physical-cartpole" / "ICRA_ODE_2.csv"
CART_FMU = FMUS_DIR / "Cart.fmu"  # pendfmu's own FMU folder (built by `pendfmu build`)
POSITION_PER_COUNT = 9.51e-5  # m, SOURCE.txt (and the log: position = -9.51e-5 position_raw)
ANGLE_PER_COUNT = 2 * math.pi / 4271.34  # rad, ANGLE_360_DEG_IN_ADC_UNITS of the driver's globals.py
PWM_PERIOD = 7200  # MOTOR_PWM_PERIOD_IN_CLOCK_CYCLES (STM)

# The published "honest set" (SOURCE.txt; the repository's 2026-06 motor investigation) and
# the pole of the controller's parameters.
PUBLISHED = {"m_cart_eff": 2.82, "u_max": 21.7, "M_fric": 36.8, "J_fric": 5e-5, "v_max": 0.59}
POLE_LENGTH = 0.395  # m, full length (L in the driver's parameters)
POLE_MASS = 0.087  # kg
# The pendulum as pendfmu's rod: the centre of mass at half the length, J_p = (4/3) m_p l^2
# (the paper's default): the driver's own model (angleDD = (g sa + a ca)/((1 + 1/3) L/2)).
POLE = {"m_p": POLE_MASS, "l": POLE_LENGTH / 2}


@dataclass(frozen=True)
class CartpoleLog:
    path: Path
    columns: dict[str, np.ndarray]
    measurement: list[str]


def read_log(path: Path = CARTPOLE_CSV) -> CartpoleLog:
    """The driver's CSV: '#' comment lines, a header, numbers (NA where the controller had no
    target) and one text column ``measurement``."""
    with open(path, newline="", encoding="utf-8") as f:
        rows = list(csv.reader(line for line in f if not line.startswith("#")))
    header, body = rows[0], rows[1:]
    if not body:
        raise RecordingError(f"{path}: no data rows")
    columns, measurement = {}, []
    for i, name in enumerate(header):
        if name == "measurement":
            measurement = [row[i].strip() for row in body]
            continue
        text = [row[i] for row in body]
        if name == "stickControl":
            columns[name] = np.array([t == "True" for t in text])
            continue
        columns[name] = np.array([float(t) if t not in ("NA", "") else np.nan for t in text])
    for name in ("time", "Q", "position", "position_raw", "angle", "frozen", "actualMotorSave", "latency"):
        if name not in columns:
            raise RecordingError(f"{path}: no column {name!r}")
    return CartpoleLog(Path(path), columns, measurement)


def check_log(log: CartpoleLog) -> None:
    """What the conversion relies on, checked on the log itself."""
    c = log.columns
    if np.any(np.diff(c["time"]) <= 0):
        raise RecordingError(f"{log.path}: time is not increasing")
    running = [m for m in log.measurement if "State:idle" not in m]
    if running:
        raise RecordingError(f"{log.path}: an experiment protocol drove {len(running)} rows ({running[0]!r}); "
                             f"this conversion takes MPC-driven rows only")
    if np.any(c["stickControl"]):
        raise RecordingError(f"{log.path}: the joystick drove some rows")
    if np.max(np.abs(c["position"] + POSITION_PER_COUNT * c["position_raw"])) > 0.05 * POSITION_PER_COUNT:  # the log scales by 9.5101e-5
        raise RecordingError(f"{log.path}: position is not -{POSITION_PER_COUNT} m x position_raw")
    if np.max(np.abs(c["Q"])) > 1.0 + 1e-12:
        raise RecordingError(f"{log.path}: Q outside -1..1")


def pwm_law(log: CartpoleLog) -> dict[str, float]:
    """The applied PWM duty against the command: duty = gain Q + comp sgn(v_prev) + offset,
    v_prev the previous row's speed (the firmware's friction compensation). Measured, for the
    README: gain 0.502, comp 0.034, offset -0.009, residual 7 PWM counts rms."""
    c = log.columns
    duty = -c["actualMotorSave"] / PWM_PERIOD  # the PWM's sign is the encoder's: -x
    previous = np.sign(np.r_[0.0, c["positionD"][:-1]])
    design = np.c_[c["Q"], previous, np.ones_like(duty)]
    coef, *_ = np.linalg.lstsq(design, duty, rcond=None)
    rms = float(np.std(duty - design @ coef) * PWM_PERIOD)
    return {"gain": float(coef[0]), "compensation": float(coef[1]), "offset": float(coef[2]), "rms_counts": rms}


def valid_angle(log: CartpoleLog) -> np.ndarray:
    return log.columns["frozen"] == 0


def pole_angle(log: CartpoleLog) -> np.ndarray:
    """The paper's phi = -angle, unwrapped over the valid rows; NaN where frozen."""
    ok = valid_angle(log)
    phi = np.full(len(ok), np.nan)
    phi[ok] = -np.unwrap(log.columns["angle"][ok])
    return phi


def smooth(time: np.ndarray, values: np.ndarray):
    """The GCV smoothing spline through the finite samples."""
    ok = np.isfinite(values)
    return make_smoothing_spline(time[ok], values[ok])


def angle_sign(log: CartpoleLog) -> dict[str, float]:
    """Least squares of the angle's acceleration on g sin(angle), a cos(angle) and the rate
    (all from the splines): the sign of the a-term fixes phi's direction relative to x, and
    the two coefficients give g (about 9.81 if the pole is a rod of the stated length)."""
    time, ok = log.columns["time"], valid_angle(log)
    angle = np.full(len(time), np.nan)
    angle[ok] = np.unwrap(log.columns["angle"][ok])
    s_angle, s_x = smooth(time, angle), smooth(time, log.columns["position"])
    th, w, alpha = s_angle(time), s_angle.derivative(1)(time), s_angle.derivative(2)(time)
    a = s_x.derivative(2)(time)
    design = np.c_[np.sin(th), a * np.cos(th), w]
    coef, *_ = np.linalg.lstsq(design, alpha, rcond=None)
    return {"gravity_term": float(coef[0]), "acceleration_term": float(coef[1]), "rate_term": float(coef[2]),
            "g_implied": float(coef[0] / coef[1])}


def angle_outliers(log: CartpoleLog) -> float:
    """The largest distance (in ADC counts) of a kept angle from the spline through all kept
    angles, over the rows with invalid_steps > 0: they are not outliers if this is a few counts."""
    time, phi = log.columns["time"], pole_angle(log)
    s = smooth(time, phi)
    rows = (log.columns["invalid_steps"] > 0) & np.isfinite(phi)
    return float(np.max(np.abs(phi[rows] - s(time[rows]))) / ANGLE_PER_COUNT)


def cart_recording(log: CartpoleLog) -> Recording:
    """time, u (row k+1's Q at row k), x, and the pole's phi, w, alpha for the back-drive:
    for the Cart FMU (--fmu), which takes them as inputs when it is back-drivable."""
    c = log.columns
    time = c["time"][:-1]
    phi_spline = smooth(c["time"], pole_angle(log))
    signals = {"u": c["Q"][1:], "x": c["position"][:-1],
               "phi": phi_spline(time), "w": phi_spline.derivative(1)(time), "alpha": phi_spline.derivative(2)(time)}
    return Recording(log.path.with_name("cartpole_cart"), time, signals,
                     experiment="physical-cartpole ICRA_ODE_2: MPC swing-up and balance, cart driven by Q",
                     signal_info={"x": SignalInfo(POSITION_PER_COUNT)})


def pendulum_recording(log: CartpoleLog) -> Recording:
    """time, a (the position spline's second derivative), phi with the frozen rows missing."""
    c = log.columns
    time = c["time"]
    a = smooth(time, c["position"]).derivative(2)(time)
    return Recording(log.path.with_name("cartpole_pendulum"), time, {"a": a, "phi": pole_angle(log)},
                     experiment="physical-cartpole ICRA_ODE_2: the pole driven by the cart's acceleration",
                     signal_info={"phi": SignalInfo(ANGLE_PER_COUNT, missing="nan")}, parameters=dict(POLE))



SEGMENT = 1.5  # s, the cart's pieces: the MPC run is closed loop; open loop the cart drifts off
POLE_SEGMENT = 0.5  # s, the pole's pieces: near upright it falls away open loop (e-fold in 0.16 s)
UPRIGHT = 0.5  # rad: the swing-up ends where |phi| first stays below this (the balance begins)


def pieces(whole: Recording, spline, states: dict[str, tuple[str, int]], seconds: float,
           end: float | None = None) -> list[Recording]:
    """`whole` (up to `end`) cut into pieces of `seconds` (the last joined to its predecessor
    when shorter than half a piece), each a recording of its own whose sidecar states its
    initial states (signal: (name, derivative order) of `spline` at the piece's first
    sample). They are the start of the fit's per-piece estimates (--per-recording x0 v0):
    an FMU's fit takes a piece's initial speed from its sidecar or its parameters only (the
    FMU has no recorded speed to read it from), and a quadratic through 20 readings (0.4 s
    here) misses the speed of this cart and pole, which reverse every few tenths of a second."""
    time = whole.time
    stop = time[-1] if end is None else end
    edges = list(np.arange(time[0], stop, seconds))
    if stop - edges[-1] < seconds / 2 and len(edges) > 1:
        edges.pop()
    edges.append(stop + 1e-9)
    result = []
    for k, (start, finish) in enumerate(zip(edges[:-1], edges[1:])):
        rows = (time >= start) & (time < finish)
        t0 = float(time[rows][0])
        result.append(Recording(
            whole.path.with_name(f"{whole.path.name}_{k:02d}"), time[rows],
            {name: values[rows] for name, values in whole.signals.items()},
            experiment=f"{whole.experiment}; {t0:.3f}-{time[rows][-1]:.3f} s", signal_info=whole.signal_info,
            parameters=whole.parameters,
            initial={signal: float(spline.derivative(order)(t0) if order else spline(t0))
                     for signal, (_, order) in states.items()}))
    return result


def cart_segments(log: CartpoleLog, seconds: float = SEGMENT) -> list[Recording]:
    """The cart recording in pieces with their initial x and v from the position spline."""
    spline = smooth(log.columns["time"], log.columns["position"])
    return pieces(cart_recording(log), spline, {"x": ("x0", 0), "v": ("v0", 1)}, seconds)


def swing_up_end(log: CartpoleLog) -> float:
    """The time from which |phi| stays below UPRIGHT: the balance; before it, the swing-up."""
    phi = pole_angle(log)
    far = np.flatnonzero(~(np.abs(phi) < UPRIGHT) & np.isfinite(phi))
    return float(log.columns["time"][far[-1] + 1])


def pendulum_segments(log: CartpoleLog, seconds: float = POLE_SEGMENT) -> list[Recording]:
    """The swing-up of the pendulum recording in pieces with their initial phi and w from
    the angle's spline."""
    spline = smooth(log.columns["time"], pole_angle(log))
    return pieces(pendulum_recording(log), spline, {"phi": ("phi0", 0), "w": ("w0", 1)}, seconds,
                  end=swing_up_end(log))


# ------------------------------------------------------------------ the fits

PENDULUM_FMU = CART_FMU.with_name("Pendulum.fmu")
# The cart: eta = 1 (k_u is then the force at Q = 1, the published u_max's meaning), the belt
# back-drivable with eta_back = 1 (the pole's reaction reaches the cart undiminished), no
# back-EMF term of its own: without a lag it acts exactly as k_fwc does (README, Drives), so
# k_fwc is the total damping, the published M_fric's meaning. F_Sc = F_Kc: no stiction.
CART_PARAMS = {"m_c": PUBLISHED["m_cart_eff"], **POLE, "eta": 1.0, "eta_back": 1.0, "k_emf": 0.0,
               "k_u": PUBLISHED["u_max"], "k_fwc": PUBLISHED["M_fric"], "F_Kc": 1.0, "F_Sc": 0.0,
               "input_delay": 0.018}
CART_FREE = ("k_u", "k_fwc", "F_Kc", "input_delay")
# Per piece x0 and v0, started from the sidecar's spline values; v0's box is the cart's speeds.
CART_PIECES = ("--per-recording", "x0", "v0", "--bounds", "v0=-1.5:1.5")
POLE_PARAMS = {**POLE, "J_p": 4 / 3 * POLE_MASS * (POLE_LENGTH / 2) ** 2, "g": 9.81,
               "k_fwp": PUBLISHED["J_fric"], "T_Kp": 0.0, "T_Sp": 0.0}
POLE_FREE = ("k_fwp", "J_p", "phi_offset")

SOURCES = (CARTPOLE_CSV,)
STAGE = ("--fmu", CART_FMU)  # a model fit: the Cart FMU, back-driven by the recorded pole
# The mass fixed at the published 2.82 kg: the motion fixes k_u/m and k_fwc/m, not m (README).
# Local refinement from the published set: the global search (measured) ends at the same optimum.
OPTIONS = ("--free", *CART_FREE, *CART_PIECES, "--no-global")
RUN_OPTIONS = ("--uncertainty", "jacobian")


def build() -> tuple[list[Recording], dict[str, float]]:
    return cart_segments(read_log()), dict(CART_PARAMS)


def pendulum_arguments(folder: Path) -> list[str]:
    """``fit --fmu Pendulum.fmu PIECE... --params P OPTIONS`` for the swing-up's pieces."""
    from _common import write_inputs

    *files, params = write_inputs(pendulum_segments(read_log()), POLE_PARAMS, folder)
    return ["fit", "--fmu", str(PENDULUM_FMU), *files, "--params", params, "--free", *POLE_FREE,
            "--per-recording", "phi0", "w0", "--bounds", "w0=-20:20", "--interpolation", "linear", "--no-global"]


# ------------------------------------------------------------------ what the data fix

PROFILE_MASSES = (0.5, 1.0, 2.0, 2.82, 5.0, 20.0)  # kg, m_c fixed at each, the rest refitted


def _cart_fit(recordings, **changes):
    import pendfmu

    params = {**CART_PARAMS, **changes}
    scale = (params["m_c"] + params["m_p"]) / (PUBLISHED["m_cart_eff"] + POLE_MASS)
    params.update(k_u=params["k_u"] * scale, k_fwc=params["k_fwc"] * scale)  # start on the published ratios
    free = list(CART_FREE) + (["m_c"] if changes.get("free_mass") else [])
    params.pop("free_mass", None)
    bounds = {"v0": (-1.5, 1.5)}
    if "m_c" in free:
        bounds.update(m_c=(0.3, 100.0), k_u=(2.0, 1e4), k_fwc=(3.0, 2e4), F_Kc=(0.01, 100.0))
    return pendfmu.fit(str(CART_FMU), recordings, params=params, free=free, bounds=bounds,
                       per_recording=["x0", "v0"], global_search=pendfmu.GlobalOptions(enabled=False),
                       uncertainty="jacobian", warn=lambda message: None)


def piece_ratios(recordings, fitted: dict[str, float]) -> dict:
    """k_u and k_fwc of each piece on its own (input_delay and F_Kc shared), at the published
    mass, from the joint fit's values (`fitted`): their spread is an interval that the
    residuals' correlation cannot shrink (each piece one sample): the mean's 95 % t-interval
    over the pieces, as ratios to M = m_c + m_p."""
    import pendfmu
    from scipy.stats import t as student

    params = {**CART_PARAMS, **{k: fitted[k] for k in CART_FREE}}
    r = pendfmu.fit(str(CART_FMU), recordings, params=params, free=["F_Kc", "input_delay"],
                    bounds={"v0": (-1.5, 1.5), "k_u": (3.0, 300.0), "k_fwc": (6.0, 600.0)},
                    per_recording=["x0", "v0", "k_u", "k_fwc"], global_search=pendfmu.GlobalOptions(enabled=False),
                    uncertainty="jacobian", warn=lambda message: None)
    M = params["m_c"] + params["m_p"]
    result = {"pieces": [piece.path.name for piece in recordings], "input_delay": r.parameters["input_delay"]}
    for name in ("k_u", "k_fwc"):
        values = np.array([r.estimates[f"{name}[{piece.path.name}]"].value for piece in recordings]) / M
        half = student.ppf(0.975, len(values) - 1) * values.std(ddof=1) / np.sqrt(len(values))
        result[f"{name}/M"] = values.tolist()
        result[f"{name}/M mean ci95"] = [float(values.mean() - half), float(values.mean() + half)]
    return result


def effective_samples(result) -> float:
    """The residuals' number of independent values: per piece n (1 - r1)/(1 + r1), r1 the
    lag-one autocorrelation of its residuals (an AR(1) approximation). The closed-loop
    residuals are slow drifts, so far fewer than the samples: a cost threshold for an
    interval must use this, not the sample count."""
    total = 0.0
    for fit in result.experiments:
        for name, recorded in fit.recorded.items():
            r = fit.simulated[name] - recorded
            r = r[np.isfinite(r)] - np.mean(r[np.isfinite(r)])
            r1 = float(np.sum(r[1:] * r[:-1]) / np.sum(r * r)) if np.sum(r * r) > 0 else 0.0
            r1 = min(max(r1, 0.0), 0.999)
            total += len(r) * (1 - r1) / (1 + r1)
    return total


def mass_evidence(recordings=None) -> dict:
    """What the motion says about the cart's mass, measured:

    * ``free``: m_c fitted with k_u, k_fwc, F_Kc (boxes wide open): its 95 % interval and its
      correlation with k_u;
    * ``profile``: m_c fixed at each of PROFILE_MASSES, the rest refitted: the cost and the
      ratios k_u/M, k_fwc/M, F_Kc/M (M = m_c + m_p), which stay put while m_c moves 40-fold;
    * ``no_pole``: m_p = 0 (the pole's reaction neglected) at the published mass;
    * ``lower_bound``: the lightest mass whose cost stays within the 95 % likelihood-ratio
      threshold of the best profile point, chi2(1) = 3.84 over the residuals' effective
      number of independent samples (:func:`effective_samples`), log-interpolated on the
      profile. There is no upper bound: the cost keeps falling slowly as the pole's
      reaction fades against a heavier cart."""
    recordings = recordings or cart_segments(read_log())
    free = _cart_fit(recordings, free_mass=True)
    profile = []
    for mass in PROFILE_MASSES:
        r = _cart_fit(recordings, m_c=mass)
        p = r.parameters
        M = p["m_c"] + p["m_p"]
        profile.append({"m_c": mass, "cost": r.cost, "k_u/M": p["k_u"] / M, "k_fwc/M": p["k_fwc"] / M,
                        "F_Kc/M": p["F_Kc"] / M, "input_delay": p["input_delay"],
                        "effective_samples": effective_samples(r)})
    nopole = _cart_fit(recordings, m_p=0.0).parameters
    at_published = _cart_fit(recordings, m_c=PUBLISHED["m_cart_eff"]).parameters
    best = min(point["cost"] for point in profile)
    n_eff = next(point["effective_samples"] for point in profile if point["m_c"] == PUBLISHED["m_cart_eff"])
    threshold = best * (1 + 3.84 / n_eff)
    masses = np.log([point["m_c"] for point in profile])
    costs = np.array([point["cost"] for point in profile])
    inside = np.flatnonzero(costs <= threshold)
    k = inside[0]
    lower = float(np.exp(np.interp(threshold, [costs[k], costs[k - 1]], [masses[k], masses[k - 1]]))) if k > 0 else None
    e = free.estimates
    return {
        "free": {"m_c": free.parameters["m_c"], "ci95": list(e["m_c"].ci95),
                 "k_u": free.parameters["k_u"], "k_u_ci95": list(e["k_u"].ci95),
                 "correlation_m_c_k_u": free.correlation["m_c"]["k_u"],
                 "correlation_m_c_k_fwc": free.correlation["m_c"]["k_fwc"],
                 "k_u/M": free.parameters["k_u"] / (free.parameters["m_c"] + POLE_MASS),
                 "k_fwc/M": free.parameters["k_fwc"] / (free.parameters["m_c"] + POLE_MASS)},
        "profile": profile,
        "no_pole": {"k_u": nopole["k_u"], "k_fwc": nopole["k_fwc"], "F_Kc": nopole["F_Kc"],
                    "input_delay": nopole["input_delay"], "k_u/M": nopole["k_u"] / nopole["m_c"],
                    "k_fwc/M": nopole["k_fwc"] / nopole["m_c"]},
        "threshold": {"effective_samples": n_eff, "relative_cost": 3.84 / n_eff},
        "lower_bound": lower,
        "pieces": piece_ratios(recordings, at_published),
    }


def published_comparison(cart: dict, pendulum: dict, mass: dict) -> dict:
    """Fitted against published, from the two result documents and :func:`mass_evidence`.
    The cart's fit holds m_c at the published 2.82 kg, so its k_u and k_fwc are that mass
    times the ratios the motion fixes; the ratios are given beside them, against the
    published ratios (with the pole: M = m_c + m_p)."""
    p, ci = cart["parameters"], cart["ci95"]
    M = p["m_c"] + p["m_p"]
    published_M = PUBLISHED["m_cart_eff"] + POLE_MASS
    latency = read_log().columns["latency"][1:]  # the first row's 0.57 s is the logger starting
    q, qci = pendulum["parameters"], pendulum["ci95"]
    return {
        "mass_kg": {"published": PUBLISHED["m_cart_eff"], "fitted": None,
                    "note": "not determined: the fit holds m_c at the published value (mass_evidence)",
                    "free_fit": mass["free"]["m_c"], "free_fit_ci95": mass["free"]["ci95"],
                    "lower_bound_95": mass["lower_bound"], "upper_bound_95": None},
        "force_at_full_command_N": {"published": PUBLISHED["u_max"], "fitted": p["eta"] * p["k_u"],
                                    "ci95": [p["eta"] * v for v in ci["k_u"]], "at_mass_kg": p["m_c"]},
        "damping_N_s_per_m": {"published": PUBLISHED["M_fric"], "fitted": p["k_fwc"] + p["eta"] * p["k_emf"],
                              "ci95": ci["k_fwc"], "at_mass_kg": p["m_c"]},
        "acceleration_per_command_m_per_s2": {"published": PUBLISHED["u_max"] / published_M,
                                              "fitted": p["eta"] * p["k_u"] / M,
                                              "ci95": [p["eta"] * v / M for v in ci["k_u"]],
                                              "pieces_mean_ci95": mass["pieces"]["k_u/M mean ci95"]},
        "damping_per_mass_1_per_s": {"published": PUBLISHED["M_fric"] / published_M, "fitted": p["k_fwc"] / M,
                                     "ci95": [v / M for v in ci["k_fwc"]],
                                     "pieces_mean_ci95": mass["pieces"]["k_fwc/M mean ci95"]},
        "terminal_speed_m_per_s": {"published": PUBLISHED["v_max"], "fitted": p["k_u"] / p["k_fwc"]},
        "coulomb_per_mass_m_per_s2": {"published": 0.0, "fitted": p["F_Kc"] / M,
                                      "note": "net of the firmware's friction compensation (pwm_law)"},
        "delay_s": {"fitted": p["input_delay"], "ci95": ci["input_delay"],
                    "with_gains_per_piece": mass["pieces"]["input_delay"],
                    "latency_column_median": float(np.median(latency)),
                    "latency_column_p5_p95": [float(np.percentile(latency, 5)), float(np.percentile(latency, 95))]},
        "pendulum_damping_N_m_s": {"published": PUBLISHED["J_fric"], "fitted": q["k_fwp"], "ci95": qci["k_fwp"]},
        "pendulum_inertia_kg_m2": {"published": POLE_PARAMS["J_p"], "fitted": q["J_p"], "ci95": qci["J_p"],
                                   "note": "published: the 0.395 m, 0.087 kg pole as a uniform rod"},
    }
