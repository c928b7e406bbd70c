"""The Controller FMU: a discrete PID controller with sample time, derivative over n_d samples,
output delay, saturation and feedforward (pendfmu/csrc/Controller/model.c, docs/user-guide/pid-controller.md).

What each test compares against:
- (1) an independent plain-Python implementation of the EMPS controller written here from
  /work/shared/realdata/EMPS/SOURCE.txt's formula (qf, dq_hat, unit delay, +/-10 V, + pulses),
  on a recorded-like encoder signal: equal sample by sample up to rounding;
- (2) closed forms: a P step, the unit delay and a longer one, saturation, the integrator's
  ramp, clamping anti-windup, the derivative on the error or on the measurement;
- (3) the FMU through fmpy: Co-Simulation with a communication step of T_s and of 5 T_s, and
  Model Exchange (fmpy.simulate_fmu) whose time events fall at t_k = k T_s;
- (4) invalid parameters end in fmi2Error with a message, never a crash;
- (5) the recorded EMPS run (skipped without the data): the FMU fed the recorded qm and qg
  with the EMPS gains reproduces the recorded controller output vir.

Tolerances of (1) and (3): the FMU computes kv*kp*(qr - q) - kv*(q_k - q_{k-2})/(2 dt), the
reference kv*(kp*(qr - q) - (qf_k - qf_{k-1})/dt) with qf the half sums: the same numbers
in another order. One rounding of a position (0.25 m: 2.8e-17 m) divided by dt = 1e-3 s and
multiplied by kv = 243 is 7e-12 V, so the two agree to a few 1e-11 V, not to the last bit;
5e-11 V is allowed (measured: 3.4e-12 V on the synthetic signal, 6.8e-12 V on DATA_EMPS).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from pendfmu.components import CONTROLLER, CONTROLLER_MAX_SAMPLES
from pendfmu.simulator import ComponentFMU
from pendfmu.simulator.component import FMUError

EMPS_DIR = Path("/work/shared/realdata/EMPS")
KP, KV, DT = 160.18, 243.45, 1e-3  # EMPS's gains (SOURCE.txt) and its sample time
EMPS = {"T_s": DT, "K_p": KV * KP, "K_i": 0.0, "K_d": KV, "derivative_on_measurement": True, "n_d": 2,
        "delay": 1, "u_max": 10.0, "u_min": -10.0}
ROUNDING = 5e-11  # V: see the module docstring


def emps_reference(qr, qm, pulses, dt=DT, kp=KP, kv=KV, viradm=10.0, nu0=0.0):
    """SOURCE.txt, "Controller": nu = kv*(kp*(qr - q) - dq_hat) with qf(k) = 0.5 qm(k) +
    0.5 qm(k-1) and dq_hat(k) = (qf(k) - qf(k-1))/dt; then a one-sample unit delay, the
    +/-viradm saturation, + pulses_N. Before the first sample the position is taken as at
    rest (qm(-1) = qm(0), qf(-1) = qf(0)) and the delay holds nu0."""
    out = np.empty(len(qm))
    nu_delayed = nu0
    qm_prev = qm[0]
    qf_prev = None
    for k in range(len(qm)):
        qf = 0.5 * qm[k] + 0.5 * qm_prev
        dq_hat = 0.0 if qf_prev is None else (qf - qf_prev) / dt
        nu = kv * (kp * (qr[k] - qm[k]) - dq_hat)
        out[k] = min(viradm, max(-viradm, nu_delayed)) + pulses[k]
        nu_delayed, qm_prev, qf_prev = nu, qm[k], qf
    return out


def recorded_like(n=3000, seed=0):
    """A position reference (trapezoidal speed, back and forth) and an encoder-like
    measurement: a lagging, noisy follower quantized to 5e-8 m, with a few jumps large
    enough to drive the controller into saturation; pulses of 5 V as the feedforward."""
    t = np.arange(n) * DT
    speed = np.interp(t, [0, 0.3, 1.0, 1.3, 1.6, 2.3, 2.6, 3.0], [0, 0.12, 0.12, 0, 0, -0.12, -0.12, 0])
    qr = np.concatenate([[0.0], np.cumsum(speed[1:] * DT)])
    rng = np.random.default_rng(seed)
    q = np.interp(t - 1.0 / KP, t, qr) + 2e-6 * rng.standard_normal(n)  # kp (qr - q) ~ dq: tracking
    q[(t > 0.5) & (t < 0.52)] += 4e-4  # disturbances: |kv kp e| > 10 V
    q[(t > 2.0) & (t < 2.03)] -= 5e-4
    qm = np.round(q / 5e-8) * 5e-8
    pulses = np.where((t % 1.0 > 0.344) & (t % 1.0 < 0.844), 5.0, 0.0)
    return t, qr, qm, pulses


def cosimulate(parameters, r, y, u_ff=None, steps_per_communication=1, t0=0.0):
    """The FMU in Co-Simulation, inputs set at each communication point (every
    `steps_per_communication` samples; held over the step), u read after setting them.
    Returns u at every communication point."""
    T_s = parameters.get("T_s", 1e-3)
    h = steps_per_communication * T_s
    u_ff = np.zeros(len(r)) if u_ff is None else u_ff
    out = []
    with ComponentFMU("Controller", parameters, start_time=t0) as fmu:
        for k in range(0, len(r), steps_per_communication):
            fmu.set(r=r[k], y=y[k], u_ff=u_ff[k])
            out.append(fmu.get("u")[0])
            fmu.time = t0 + k * T_s  # communication points by multiplication, as masters do
            fmu.step(h)
    return np.array(out)


# ---------------------------------------------------------------- (1) EMPS, independent reference

def test_emps_controller_against_the_benchmark_formula():
    t, qr, qm, pulses = recorded_like()
    reference = emps_reference(qr, qm, pulses)
    u = cosimulate(EMPS, qr, qm, pulses)
    saturated = np.abs(reference - pulses) >= 10.0
    assert saturated.sum() > 20 and (~saturated).sum() > 2000  # both regimes are exercised
    np.testing.assert_allclose(u, reference, rtol=0, atol=ROUNDING)


# ---------------------------------------------------------------- (2) closed forms

def test_p_step():
    n = 20
    u = cosimulate({"K_p": 2.5, "T_s": 0.01}, np.ones(n), np.full(n, 0.2))
    assert np.all(u == 2.5 * 0.8)


def test_unit_delay_and_longer_delays():
    n = 10
    r = np.arange(n, dtype=float)  # a new reference every sample
    for delay in (1, 3):
        u = cosimulate({"K_p": 1.0, "delay": delay, "u0": -7.0, "T_s": 0.01}, r, np.zeros(n))
        np.testing.assert_array_equal(u[:delay], -7.0)
        np.testing.assert_array_equal(u[delay:], r[:-delay])


def test_saturation_then_feedforward():
    n = 6
    r = np.array([1.0, -1.0, 0.01, 1.0, -1.0, 0.0])
    u_ff = np.array([0.0, 0.0, 0.0, 5.0, 5.0, 5.0])
    u = cosimulate({"K_p": 100.0, "u_max": 10.0, "u_min": -4.0}, r, np.zeros(n), u_ff)
    np.testing.assert_array_equal(u, [10.0, -4.0, 1.0, 15.0, 1.0, 5.0])


def test_integrator_ramp():
    """K_i alone on a constant error: u_k = K_i T_s e k (forward Euler, I_0 = 0)."""
    n, T_s, K_i, e = 50, 0.02, 3.0, 0.5
    u = cosimulate({"K_p": 0.0, "K_i": K_i, "T_s": T_s}, np.full(n, e), np.zeros(n))
    np.testing.assert_allclose(u, K_i * T_s * e * np.arange(n), rtol=1e-13, atol=1e-15)


def test_anti_windup_clamps_the_integrator():
    """I grows by 0.1 a sample up to 0.4 > u_max = 0.35, then holds while saturated; when the
    error turns, it unwinds at once from 0.4 (without clamping it would be at 1.9)."""
    T_s, K_i = 0.01, 10.0
    r = np.r_[np.ones(20), -np.ones(3)]
    params = {"K_p": 0.0, "K_i": K_i, "T_s": T_s, "u_max": 0.35, "u_min": -1.0}
    with ComponentFMU("Controller", params) as fmu:
        u, integrator = [], []
        for k, r_k in enumerate(r):
            fmu.set(r=r_k)
            u.append(fmu.get("u")[0])
            fmu.step(T_s)
            integrator.append(fmu.get("u_I")[0])
    np.testing.assert_allclose(u[:4], [0.0, 0.1, 0.2, 0.3], atol=1e-15)
    assert np.all(np.array(u[4:20]) == 0.35)
    np.testing.assert_allclose(integrator[3:20], 0.4, atol=1e-15)  # held from sample 4 on
    np.testing.assert_allclose(u[20:], [0.35, 0.3, 0.2], atol=1e-15)  # v = 0.4, 0.3, 0.2


@pytest.mark.parametrize("on_measurement", [False, True])
@pytest.mark.parametrize("n_d", [1, 3])
def test_derivative_on_error_or_measurement(on_measurement, n_d):
    """A reference step at sample 5 with y = 0: on the error, a kick K_d/(n_d T_s) for n_d
    samples; on the measurement, nothing. Then y ramps by 0.01 a sample: -K_d 0.01/T_s."""
    T_s, K_d, n = 0.01, 0.2, 20
    r = np.where(np.arange(n) >= 5, 1.0, 0.0)
    y = np.where(np.arange(n) >= 12, 0.01 * (np.arange(n) - 12), 0.0)
    u = cosimulate({"K_p": 0.0, "K_d": K_d, "n_d": n_d, "T_s": T_s, "derivative_on_measurement": on_measurement},
                   r, y)
    kick = np.zeros(n)
    if not on_measurement:
        kick[5:5 + n_d] = K_d / (n_d * T_s)
    ramp = np.zeros(n)
    for k in range(12, n):
        ramp[k] = -K_d * (y[k] - y[k - n_d]) / (n_d * T_s)
    np.testing.assert_allclose(u, kick + ramp, rtol=1e-12, atol=1e-12)


# ---------------------------------------------------------------- (3) Co-Simulation and Model Exchange

def test_cosimulation_with_steps_of_several_samples():
    """A step of 5 T_s takes the 5 samples in [t, t + 5 T_s), the inner ones with the inputs
    held from t: the same as the reference fed the held sequence; u read at each
    communication point is that point's sample."""
    t, qr, qm, pulses = recorded_like(n=1000)
    held = (np.arange(len(t)) // 5) * 5
    reference = emps_reference(qr[held], qm[held], pulses[held])
    u = cosimulate(EMPS, qr, qm, pulses, steps_per_communication=5)
    np.testing.assert_allclose(u, reference[::5], rtol=0, atol=ROUNDING)


def test_cosimulation_with_inputs_interpolated_inside_the_step():
    """Input derivatives make the inner samples see the ramp, not the held value."""
    T_s = 0.01
    with ComponentFMU("Controller", {"K_p": 1.0, "T_s": T_s}) as fmu:
        fmu.step(5 * T_s, inputs={"r": 0.0}, derivatives={"r": [2.0]})  # samples 0..4 at r = 2 t
        u_inner = fmu.get("v")[0]  # the last sample taken: t = 4 T_s
        fmu.step(5 * T_s, inputs={"r": 0.5})
        assert fmu.get("t_sample")[0] == pytest.approx(9 * T_s, abs=1e-15)
    assert u_inner == pytest.approx(2.0 * 4 * T_s, abs=1e-15)


def test_sample_at_a_communication_point_sees_the_inputs_set_there():
    """After a step, u previews the sample at the end point with the inputs held; setting
    new inputs there changes it; the next step takes the sample with them."""
    with ComponentFMU("Controller", {"K_p": 2.0, "T_s": 0.1}) as fmu:
        fmu.step(0.1, inputs={"r": 1.0})
        assert fmu.get("u")[0] == 2.0  # preview of sample 1 with r = 1 (held)
        fmu.set(r=3.0)
        assert fmu.get("u")[0] == 6.0  # the master's new input at t = 0.1
        assert fmu.get("t_sample")[0] == 0.0  # not taken yet
        fmu.step(0.05)
        assert fmu.get("u", "t_sample") == [6.0, 0.1]  # taken with r = 3, held inside the sample
        fmu.set(r=5.0)  # t = 0.15 is no sample: the output holds
        assert fmu.get("u")[0] == 6.0


def test_fmu_state_restores_the_sample_history():
    t, qr, qm, pulses = recorded_like(n=200)
    with ComponentFMU("Controller", EMPS) as fmu:
        for k in range(100):
            fmu.step(DT, inputs={"r": qr[k], "y": qm[k]})
        state, time = fmu.get_state(), fmu.time
        first = []
        for k in range(100, 200):
            first.append(fmu.get("u")[0])
            fmu.step(DT, inputs={"r": qr[k], "y": qm[k]})
        fmu.set_state(state, time)
        again = []
        for k in range(100, 200):
            again.append(fmu.get("u")[0])
            fmu.step(DT, inputs={"r": qr[k], "y": qm[k]})
    assert first == again


def test_model_exchange_time_events_at_the_samples():
    """fmpy's Model Exchange loop with the integrator ramp: u is a staircase whose steps are
    at k T_s exactly (time events announced by fmi2NewDiscreteStates)."""
    from fmpy import simulate_fmu

    from pendfmu.fmubuild import ensure_fmu

    T_s, K_i = 0.01, 2.0
    result = simulate_fmu(str(ensure_fmu("Controller")), fmi_type="ModelExchange", start_time=0.0, stop_time=0.1,
                          output_interval=T_s / 4, start_values={"K_p": 0.0, "K_i": K_i, "T_s": T_s},
                          input=np.array([(0.0, 1.0), (1.0, 1.0)], dtype=[("time", float), ("r", float)]),
                          output=["u", "t_sample"])
    t = result["time"]
    # After the event at k T_s, u = K_i T_s k; fmpy records the left and the right limit.
    k_after = np.floor(t / T_s + 1e-9)
    left = np.r_[False, np.diff(t) == 0]  # the second of two equal times is after the event
    at_event = np.isclose(t / T_s, np.round(t / T_s), atol=1e-9)
    expected = np.where(at_event & ~left, K_i * T_s * (k_after - 1), K_i * T_s * k_after)
    expected[0] = 0.0
    np.testing.assert_allclose(result["u"], expected, atol=1e-14)
    samples = np.unique(result["t_sample"])
    np.testing.assert_allclose(samples, T_s * np.arange(len(samples)), atol=1e-12)
    assert len(samples) == 11  # t = 0, 0.01, ..., 0.1


# ---------------------------------------------------------------- (4) invalid parameters

@pytest.mark.parametrize("parameters, says", [
    ({"n_d": 0}, "n_d = 0"),
    ({"n_d": CONTROLLER_MAX_SAMPLES + 1}, f"1..{CONTROLLER_MAX_SAMPLES}"),
    ({"delay": -1}, "delay = -1"),
    ({"delay": CONTROLLER_MAX_SAMPLES + 1}, f"0..{CONTROLLER_MAX_SAMPLES}"),
    ({"u_min": 1.0, "u_max": 0.5}, "u_min = 1 is above u_max = 0.5"),
    ({"T_s": 0.0}, "T_s = 0"),
    ({"T_s": -1e-3}, "T_s = -0.001"),
])
def test_invalid_parameters_are_refused(parameters, says):
    with pytest.raises(FMUError) as error:
        ComponentFMU("Controller", parameters)
    assert says in str(error.value)


def test_table_defaults_are_a_valid_controller():
    assert CONTROLLER.variable("u_max").start > 1e299 and CONTROLLER.variable("u_min").start < -1e299
    with ComponentFMU("Controller") as fmu:
        fmu.step(1e-3, inputs={"r": 2.0, "y": 0.5})
        assert fmu.get("u")[0] == 1.5


# ---------------------------------------------------------------- (5) the recorded EMPS run

@pytest.fixture(scope="module")
def emps_record():
    path = EMPS_DIR / "DATA_EMPS.mat"
    if not path.exists():
        pytest.skip(f"{path} is not here")
    from scipy.io import loadmat

    data = loadmat(str(path))
    return {k: np.asarray(data[k], dtype=float).ravel() for k in ("t", "qm", "qg", "vir", "kp", "kv")}


def test_recorded_emps_controller_output(emps_record):
    """The FMU with EMPS's gains, fed the recorded qg (reference) and qm (measurement),
    against the recorded controller output vir (DATA_EMPS has no pulses).

    Alignment: vir(k) is the value computed from qm(k) and qg(k), before the unit delay
    (the recording logs the controller's value of sample k; the .slx's delay is the sample
    by which the drive applies it). So the FMU's u at t_{k+1} is vir(k). Measured over
    samples 2..24838 (the first two need qm(-1), qm(-2), which precede the record): RMS
    3.66e-3 V, max 1.23e-2 V, against vir's RMS of 1.54 V. Shifted by one sample either way
    the RMS is 5.4e-2 V: the alignment is unambiguous.

    The residual is not noise but quantized: 64 % of the samples agree to 1.4e-4 V (RMS
    8.6e-5 V), the others differ by exactly kv * 5e-8 m / (2 dt) = 6.09e-3 V (a dozen by twice
    that), which is one encoder count in the derivative term. One count in the proportional
    term would be kv kp 5e-8 m = 1.95e-3 V, and no residual has that size. So at those
    samples the controller's velocity estimate used a position one count away from the logged
    qm (the logged position and the one in the derivative are not the same reading; rounding
    the filtered position or the difference to whole counts was tried and fits worse). The
    plain-Python formula leaves the same residual to 1e-11 V: it belongs to the recording.
    The limits: RMS and max at 1.5x the measured values, and the quantized structure itself
    (every residual within 5e-4 V of a multiple of 6.09e-3 V)."""
    rec = emps_record
    assert float(rec["kp"][0]) == KP and float(rec["kv"][0]) == KV
    u = cosimulate(EMPS, rec["qg"], rec["qm"])
    n = len(u)

    def residual(lag):  # u(t_{k+lag}) - vir(k) over k = 2 .. n-3
        return u[2 + lag:n - 2 + lag] - rec["vir"][2:n - 2]

    error = residual(1)
    rms, worst = float(np.sqrt(np.mean(error ** 2))), float(np.max(np.abs(error)))
    assert rms < 5.5e-3 and worst < 1.9e-2, (rms, worst)
    count = KV * 5e-8 / (2 * DT)  # one encoder count in the derivative term, V
    assert np.all(np.abs(error - count * np.round(error / count)) < 5e-4)
    assert np.mean(np.abs(error) < 5e-4) > 0.6
    for lag in (0, 2):  # other alignments are much worse
        assert float(np.sqrt(np.mean(residual(lag) ** 2))) > 10 * rms
    # The plain-Python formula leaves the same residual: the FMU adds nothing.
    reference = emps_reference(rec["qg"], rec["qm"], np.zeros(n))
    np.testing.assert_allclose(u, reference, rtol=0, atol=ROUNDING)


# ---------------------------------------------------------------- the Modelica block

def test_modelica_block_matches_the_fmu():
    """modelica/PendulumID/Controller.mo (`when sample(0, T_s)` with an algorithm) in the test
    bench tests/modelica/ControllerBench.mo, simulated by rumoca, against the FMU driven by
    the same input functions at the samples: the same numbers up to rounding (measured
    1.8e-15; mode equal), at every sample of 1 s, with the delay, the integrator and both
    saturations active (57 samples above u_max, 4 below u_min). The inputs' edges fall between samples, so both read the same values."""
    from modelica_runs import simulate

    T_s = 0.01
    result = simulate("ControllerBench", 1.0, T_s)
    time = np.asarray(result.time)
    samples = T_s * np.arange(101)
    # After the sample at t_k: rumoca has a row before and a row after each event; take the last.
    rows = np.array([np.flatnonzero(np.abs(time - t) < 1e-9)[-1] for t in samples])
    modelica = {name: np.asarray(result[f"c.{name}"])[rows] for name in ("u", "u_I", "v", "e", "mode")}

    parameters = {"T_s": T_s, "K_p": 2.0, "K_i": 5.0, "K_d": 0.05, "derivative_on_measurement": True, "n_d": 2,
                  "delay": 1, "u_max": 2.5, "u_min": -0.5, "u0": 0.25}
    fmu_values = {name: [] for name in modelica}
    with ComponentFMU("Controller", parameters) as fmu:
        for t in samples:
            fmu.set(r=1.0 if t >= 0.105 else 0.0, y=0.4 * np.sin(7.0 * t), u_ff=0.5 if 0.505 <= t < 0.705 else 0.0)
            fmu_values["u"].append(fmu.get("u")[0])  # the sample at t, previewed
            fmu.time = t
            fmu.step(T_s)  # takes it: the locals now describe it
            for name in ("u_I", "v", "e", "mode"):
                fmu_values[name].append(fmu.get(name)[0])
    v = np.array(fmu_values["v"])
    assert np.any(v > 2.5) and np.any(v < -0.5)  # both saturations, and the anti-windup, act
    for name, values in modelica.items():
        np.testing.assert_allclose(values, fmu_values[name], rtol=0, atol=1e-12, err_msg=name)
