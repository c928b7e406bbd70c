"""EMPS through its own position loop: the benchmark's closed loop as an SSP system of
pendfmu's Controller and Cart, fitted to the identification record and run on the test
record (the done-when of issue 14).

The loop (SOURCE.txt "Controller", Simulink_EMPS_Rigide*.slx): the controller samples the
motor encoder qm every millisecond, computes nu = kv (kp (qg - qm) - dq_hat) with dq_hat
the difference of qm over two samples divided by 2 ms, delays it one sample, saturates it
at +-10 V and adds the test record's pulses; the drive turns volts into gtau = 35.15 N/V.
In pendfmu's terms:

    Controller  T_s 1 ms, K_p = kv kp, K_d = kv on the measurement, n_d 2, delay 1, +-10 V,
                u_ff = pulses                          (README "The controller")
    Cart        u = the controller's output, k_u = gtau, eta 1, eta_back 0 (nothing pushes
                back), no pendulum; m_c = M, k_fwc = Fv, F_Kc = Fc, F_Sc 0 (no stiction
                beyond Coulomb, as the benchmark's sign(dq)), F_Oc = -offset
                (the benchmark subtracts OF from the drive; the Cart adds F_Oc).

The recordings (conversion, the only place the data are touched):

* time is the sample index times 1 ms: the controller's own clock. The stored stamps
  deviate from k ms by up to 3e-8 s; the Controller takes a communication point within
  1 % of T_s of a sample as that sample (README, "Jittered time stamps"), so the stored
  stamps would do as well, but the nominal grid is what the controller ran on.
* qg drives Controller.r, the pulses Controller.u_ff (zero in DATA_EMPS). In DATA_EMPS_PULSES
  the pulses act one sample before pulses_N shows them: see :func:`protocols`.
* qm is matched by Cart.x (one encoder count, 5e-8 m); vir, one sample late, by Controller.u:
  the recorded vir(k) is the value computed from qm(k) (the Controller's test (5) reproduces
  it to 3.7e-3 V rms from qm and qg), which the loop applies during the next sample; its
  noise is that 3.7e-3 V (one encoder count through the velocity estimate).
* The initial position and speed: a quadratic through the first 20 samples (the benchmark's
  initialization window), in the sidecar's "initial" (qm and qm', which the fit's
  `--initial qm=Cart.x0 qm'=Cart.v0` names), so that they belong to the first sample only:
  the fit's validation starts its late half from that half's own readings. As "parameters"
  they held for every window, and the late half began at the file's start position, 66
  times the whole fit's squared error (fitting/validation.py, Started). The drives-only
  files for `pendfmu simulate` keep them as parameters (Cart.x0, Cart.v0).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from pendfmu.recording import Recording, SignalInfo

from _common import REALDATA

EMPS_DIR = REALDATA / "EMPS"
TRAIN = EMPS_DIR / "DATA_EMPS.mat"
TEST = EMPS_DIR / "DATA_EMPS_PULSES.mat"
SAMPLE = 1e-3  # s, the controller's sample time
ENCODER = 5e-8  # m per count, on the load side
VIR_NOISE = 3.7e-3  # V rms: vir against the controller law on the recorded qm (one count in dq_hat)
INIT_SAMPLES = 20
PUBLISHED = {"M": 95.1089, "Fv": 203.5034, "Fc": 20.3935, "offset": -3.1648}
# PDF sec. 3.5, the reference model simulated in closed loop on DATA_EMPS_PULSES (relative errors, %)
PUBLISHED_ERRORS = {"velocity": 0.47888, "force": 8.9409}
FREE = ("Cart.m_c", "Cart.k_fwc", "Cart.F_Kc", "Cart.F_Oc")
BOUNDS = ("Cart.m_c=20:400", "Cart.k_fwc=10:1000", "Cart.F_Kc=1:100", "Cart.F_Oc=-20:20")
# The fit's start: round numbers, not the published model (the fit must find its own way there)
START = {"Cart.m_c": 80.0, "Cart.k_fwc": 150.0, "Cart.F_Kc": 15.0, "Cart.F_Oc": 0.0}
DRIVE = ("Controller.r=qg", "Controller.u_ff=pulses")
MATCH = ("Cart.x=qm", "Controller.u=vir_applied")
INITIAL = ("qm=Cart.x0", "qm'=Cart.v0")
COMPONENTS = ("Controller", "Cart")
CONNECT = ("Controller.u=Cart.u", "Cart.x=Controller.y")


def read(path: Path) -> dict[str, np.ndarray | float]:
    from scipy.io import loadmat

    data = loadmat(path)
    record = {name: np.ravel(data[name]).astype(float) for name in ("qm", "qg", "vir")}
    record["pulses"] = np.ravel(data["pulses_N"]).astype(float) if "pulses_N" in data else np.zeros_like(record["qm"])
    record.update({name: float(np.ravel(data[name])[0]) for name in ("kp", "kv", "gtau")})
    record["time"] = np.arange(len(record["qm"])) * SAMPLE  # the controller's clock (module docstring)
    return record


def start_state(record) -> tuple[float, float]:
    """(x0, v0): a quadratic through the first INIT_SAMPLES positions, at the first sample."""
    n = INIT_SAMPLES
    c = np.polyfit(record["time"][:n], record["qm"][:n], 2)
    return float(c[2]), float(c[1])


def recording(record, path: Path, pulses_ahead: int = 1, measured: bool = True) -> Recording:
    """The closed-loop recording (module docstring); `pulses_ahead` samples earlier than
    pulses_N shows them, the pulses drive u_ff. Without `measured`, only the drives (what
    `pendfmu simulate` reads)."""
    applied = np.concatenate([[record["vir"][0]], record["vir"][:-1]])
    pulses = np.roll(record["pulses"], -pulses_ahead) if pulses_ahead else record["pulses"]
    if pulses_ahead:
        pulses[-pulses_ahead:] = record["pulses"][-1]
    x0, v0 = start_state(record)
    columns = {"qg": record["qg"], "pulses": pulses}
    if measured:
        columns.update(qm=record["qm"], vir_applied=applied)

    if not measured:
        return Recording(path, record["time"], columns, experiment="EMPS under its position loop",
                         parameters={"Cart.x0": x0, "Cart.v0": v0}, vocabulary=_vocabulary(columns))
    return Recording(path, record["time"], columns, experiment="EMPS under its position loop",
                     signal_info={"qm": SignalInfo(ENCODER), "vir_applied": SignalInfo(noise=VIR_NOISE)},
                     initial={"qm": x0, "qm'": v0}, vocabulary=_vocabulary(columns))


def _vocabulary(columns):
    """A recording of the loop may name its own columns and the loop's parameters."""
    from pendfmu.recording.schema import Vocabulary

    return Vocabulary(tuple(columns), lambda name, value: None if math.isfinite(value) else "not finite",
                      lambda name, value: None)


def system_parameters(record) -> dict[str, float]:
    """The loop's known values: the controller's gains from the file, the drive gain, a
    cart with nothing pushing back (module docstring); the fitted ones' start."""
    return {"Controller.T_s": SAMPLE, "Controller.K_p": record["kv"] * record["kp"], "Controller.K_d": record["kv"],
            "Controller.derivative_on_measurement": 1, "Controller.n_d": 2, "Controller.delay": 1,
            "Controller.u_max": 10.0, "Controller.u_min": -10.0,
            "Cart.k_u": record["gtau"], "Cart.eta": 1.0, "Cart.eta_back": 0.0, "Cart.m_p": 0.0,
            "Cart.F_Sc": 0.0, **START}


def benchmark(parameters: dict[str, float]) -> dict[str, float]:
    """Cart parameters in the benchmark's terms: M = m_c, Fv = k_fwc, Fc = F_Kc,
    offset = -F_Oc (eta 1, k_u = gtau: the cart's force is the benchmark's gtau vir)."""
    return {"M": parameters["Cart.m_c"], "Fv": parameters["Cart.k_fwc"], "Fc": parameters["Cart.F_Kc"],
            "offset": -parameters["Cart.F_Oc"]}


def published_parameters() -> dict[str, float]:
    return {"Cart.m_c": PUBLISHED["M"], "Cart.k_fwc": PUBLISHED["Fv"], "Cart.F_Kc": PUBLISHED["Fc"],
            "Cart.F_Oc": -PUBLISHED["offset"]}


def velocity(position: np.ndarray) -> np.ndarray:
    """The benchmark's velocity from positions: butter(4, 100 Hz / 500 Hz) forwards and
    backwards (filtfilt), then central differences (Simulation_EMPS.m, diffcent.m)."""
    from scipy.signal import butter, filtfilt

    b, a = butter(4, 100 / 500)
    smooth = filtfilt(b, a, position)
    speed = np.empty_like(smooth)
    speed[1:-1] = (smooth[2:] - smooth[:-2]) / (2 * SAMPLE)
    speed[0], speed[-1] = speed[1], speed[-2]
    return speed


def relative_error(measured: np.ndarray, simulated: np.ndarray) -> float:
    """The benchmark's 100 ||y - y_s|| / ||y||, in %."""
    return float(100 * np.linalg.norm(measured - simulated) / np.linalg.norm(measured))


def errors(record, simulated_x, simulated_v, simulated_u, force_lag: int) -> dict[str, float]:
    """Relative position, velocity and force errors of a closed-loop simulation; the force
    is gtau times the recorded vir(k) against the simulated output at sample k + force_lag."""
    n = len(record["vir"]) - force_lag
    return {"position": relative_error(record["qm"], simulated_x),
            "velocity": relative_error(velocity(record["qm"]), simulated_v),
            "force": relative_error(record["gtau"] * record["vir"][:n], record["gtau"] * simulated_u[force_lag:])}


def friction_difference(parameters: dict[str, float], record) -> dict[str, float]:
    """The fitted and the published friction (viscous, Coulomb and offset together:
    Fv v + Fc sign(v) + offset) compared at the speeds the record visits (the benchmark's
    velocity at every sample): RMS and largest difference [N], and the RMS of the
    published friction itself, for scale. Fv and Fc trade against each other over a
    narrow speed range; this is what the data see of them."""
    speed = velocity(record["qm"])
    fit, pub = benchmark(parameters), PUBLISHED

    def friction(p):
        return p["Fv"] * speed + p["Fc"] * np.sign(speed) + p["offset"]

    difference = friction(fit) - friction(pub)
    return {"rms": float(np.sqrt(np.mean(difference**2))), "max": float(np.max(np.abs(difference))),
            "published_rms": float(np.sqrt(np.mean(friction(pub) ** 2)))}


PROTOCOLS = {"pulses 1 sample ahead, force at the same sample": (1, 0),
             "pulses as recorded, force one sample later": (0, 1),
             "pulses as recorded, force at the same sample": (0, 0)}
"""How a simulation is set against the recording: (pulses_ahead, force_lag). The published
figures do not say; the protocol is the one under which the *published* model's errors
are smallest (measured below, protocols()), and the same one then judges the fit."""
