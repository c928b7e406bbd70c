"""Drives beyond the paper's model (docs/user-guide/drives.md): a command input u with gain
k_u, the back-EMF k_emf of a voltage-driven motor, an electrical lag tau_e of the command
path, and the screw's back-drive efficiency eta_back apart from eta. All off by default.

    F_u = k_M k_D I + F_cmd,  F_cmd = k_u u - k_emf v            (tau_e = 0)
                              tau_e dF_e/dt = k_u u - k_emf v - F_e,  F_cmd = F_e   (tau_e > 0)
    F_A = eta F_u + A m_p l (w^2 sin(phi) - alpha cos(phi)),  A = A(eta) (eta_back = -1) or eta_back

Checks, each able to fail on its own:
- defaults and explicit zeros change nothing (the bit-identical golden run is
  test_friction_extras' test_outputs_at_defaults_are_bit_identical_to_before_the_extras);
- the Cart FMU against closed forms: terminal speed and time constant of a sliding cart under
  a constant command, the lag's first-order rise on a stuck cart and the breakaway it delays,
  a lagged start from a sliding state (two exponentials);
- the Cart FMU against the independent event-driven reference (tests/reference_rig.py) with
  the command path, and the Modelica Cart (rumoca) against the FMU;
- eta_back: a self-locking screw at eta > 0.5, a back-drivable one at eta < 0.5, refusals;
- the cart stage fits k_u and k_emf (and tau_e) from synthetic u-driven recordings.
"""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest

import reference_rig as rr
from fig3 import OMEGA, PARAMETERS as FIG3
from modelica_runs import assert_cart_bench_matches, edge_time_error, fmu_edges
from pendfmu.components import CART, ETA_BACK_FROM_ETA, rig_defaults
from pendfmu.fitting.stages import COMMAND_FREE
from pendfmu.simulator import ComponentFMU

DRIVE_NAMES = ("k_u", "k_emf", "tau_e", "eta_back")
# The reference rig with the pendulum removed: M = 3 kg, k_fwc = 30 N.s/m, F_Kc = 8 N,
# F_Sc = 12 N, eta = 0.4.
CART_ALONE = {"m_p": 0.0}
M, K_FW, F_K, F_S, ETA = 3.0, 30.0, 8.0, 12.0, 0.4


def run_cart(params: dict, times: np.ndarray, u, du=None, outputs=("x", "v", "a", "F_A", "F_e", "mode", "t_mode"),
             I=0.0, pendulum=None) -> dict[str, np.ndarray]:
    """The Cart FMU under command u(t) (and its derivatives du(t), if given) and current I."""
    def inputs(t):
        values = {"u": u(t), "I": I}
        if pendulum is not None:
            values.update(zip(("phi", "w", "alpha"), pendulum))
        return values

    with ComponentFMU("Cart", params) as cart:
        return cart.run(times, list(outputs), inputs=inputs,
                        derivatives=(lambda t: {"u": du(t)}) if du else None)


# ---------------------------------------------------------------- defaults

def test_defaults_are_off():
    assert [CART.variable(n).start for n in DRIVE_NAMES] == [0.0, 0.0, 0.0, ETA_BACK_FROM_ETA]
    assert [rr.DEFAULTS[n] for n in DRIVE_NAMES] == [0.0, 0.0, 0.0, -1.0]
    assert CART.variable("u").start == 0.0


def test_explicit_defaults_and_a_silent_command_change_nothing():
    """The drive parameters at their defaults given explicitly, and a command u that k_u = 0
    ignores (with its derivatives, which must not cost the cart its exact step), leave every
    output bit for bit as the default run (a current pulse, stick-slip)."""
    times = np.linspace(0.0, 0.6, 601)
    current = lambda t: 1.5 if 0.05 <= t < 0.4 else 0.0  # noqa: E731
    with ComponentFMU("Cart", CART_ALONE) as cart:
        base = cart.run(times, ["x", "v", "a", "F_A", "mode", "t_mode"], inputs=lambda t: {"I": current(t)})
    explicit = {**CART_ALONE, "k_u": 0.0, "k_emf": 0.0, "tau_e": 0.0, "eta_back": -1.0}
    with ComponentFMU("Cart", explicit) as cart:
        same = cart.run(times, ["x", "v", "a", "F_A", "mode", "t_mode"],
                        inputs=lambda t: {"I": current(t), "u": 0.7 * math.sin(9.0 * t)},
                        derivatives=lambda t: {"u": [6.3 * math.cos(9.0 * t), -56.7 * math.sin(9.0 * t)]})
    assert np.count_nonzero(np.diff(base["mode"])) >= 2  # it moves and stops: not a vacuous check
    for name in base:
        assert np.array_equal(base[name], same[name]), name


def test_eta_back_zero_below_the_switch_is_the_default():
    """eta = 0.4 is self-locking anyway: eta_back = 0 says the same, bit for bit, even with
    the pendulum's inputs swinging."""
    times = np.linspace(0.0, 0.3, 301)
    runs = []
    for extra in ({}, {"eta_back": 0.0}):
        with ComponentFMU("Cart", extra) as cart:
            runs.append(cart.run(times, ["x", "v", "F_A"], inputs=lambda t: {
                "I": 1.5, "phi": math.pi + 0.3 * math.sin(8 * t), "w": 2.4 * math.cos(8 * t),
                "alpha": -19.2 * math.sin(8 * t)}))
    for name in ("x", "v", "F_A"):
        assert np.array_equal(runs[0][name], runs[1][name])


# ---------------------------------------------------------------- closed forms

def test_constant_command_reaches_the_terminal_speed_with_the_time_constant():
    """A constant u = 0.5 from t = 0 on a cart at rest: eta k_u u = 20 N > F_S, so it breaks
    away at once and M dv/dt = eta k_u u - F_K - (k_fwc + eta k_emf) v:
        v(t) = v_inf (1 - e^{-t/T}),  x(t) = v_inf (t - T (1 - e^{-t/T})),
        v_inf = (eta k_u u - F_K)/(k_fwc + eta k_emf) = 0.25 m/s,  T = M/(k_fwc + eta k_emf) = 62.5 ms.
    The exact step applies (self-locking, held input): agreement to rounding (measured 2e-16 m/s)."""
    k_u, k_emf, u = 100.0, 45.0, 0.5
    damping = K_FW + ETA * k_emf
    v_inf, T = (ETA * k_u * u - F_K) / damping, M / damping
    times = np.linspace(0.0, 0.5, 501)
    run = run_cart({**CART_ALONE, "k_u": k_u, "k_emf": k_emf}, times, lambda t: u)
    assert v_inf == pytest.approx(0.25) and T == pytest.approx(0.0625)
    np.testing.assert_allclose(run["v"], v_inf * -np.expm1(-times / T), rtol=0, atol=1e-14)
    np.testing.assert_allclose(run["x"], v_inf * (times + T * np.expm1(-times / T)), rtol=0, atol=1e-14)
    # F_A is the active force after the screw: eta (k_u u - k_emf v); the row at t = 0 is read
    # before the first input is set (u = 0 there)
    np.testing.assert_allclose(run["F_A"][1:], ETA * (k_u * u - k_emf * run["v"][1:]), rtol=1e-14, atol=1e-13)
    # the first row is the state before the command (stuck at rest); no lag: its state stays 0
    assert np.all(run["mode"][1:] == 1) and np.all(run["F_e"] == 0.0)


def test_back_emf_changes_only_the_damping():
    """Without k_emf the same command gives (20 - 8)/30 = 0.4 m/s: the back-EMF is the
    difference, not a test that passes whatever k_emf does."""
    times = np.linspace(0.0, 2.0, 11)  # 20 time constants of M / k_fwc = 0.1 s
    run = run_cart({**CART_ALONE, "k_u": 100.0}, times, lambda t: 0.5)
    assert run["v"][-1] == pytest.approx(0.4, abs=1e-8)


def test_the_lag_rises_as_a_first_order_response_on_a_stuck_cart():
    """u = 0.2: eta k_u u = 8 N < F_S holds the cart; the lag's state follows
    F_e = k_u u (1 - e^{-t/tau_e}) (RK4 at 1e-4 s on tau_e = 5 ms: a relative global error of
    (h/tau)^4/120 = 1.3e-9 of e^{-t/tau} per unit time tau, measured 1.0e-8 N of the 20 N)."""
    k_u, u, tau = 100.0, 0.2, 5e-3
    times = np.linspace(0.0, 0.05, 501)
    run = run_cart({**CART_ALONE, "k_u": k_u, "tau_e": tau}, times, lambda t: u)
    np.testing.assert_allclose(run["F_e"], k_u * u * -np.expm1(-times / tau), rtol=0, atol=3e-8)
    np.testing.assert_allclose(run["F_A"], ETA * run["F_e"], rtol=1e-15, atol=0)
    assert np.all(run["mode"] == 0) and np.all(run["x"] == 0.0) and np.all(run["v"] == 0.0)


def test_the_lag_delays_the_breakaway_by_the_closed_form():
    """u = 0.5: eta F_e reaches F_S = 12 N of its 20 N at t_b = tau_e ln(20 / (20 - 12)) =
    tau_e ln 2.5; without the lag the cart starts at t = 0. The event is located to 1e-12 s;
    the lag's RK4 error shifts it by ~1e-11 s (measured 4e-12 s)."""
    tau = 5e-3
    times = np.linspace(0.0, 0.02, 201)
    run = run_cart({**CART_ALONE, "k_u": 100.0, "tau_e": tau}, times, lambda t: 0.5)
    edges = fmu_edges(run)
    assert [(old, new) for _, old, new in edges] == [(0, 1)]
    assert edges[0][0] == pytest.approx(tau * math.log(2.5), abs=1e-10)


def test_a_lagged_command_on_a_sliding_cart_follows_two_exponentials():
    """k_emf = 0, v0 = 0.1 m/s, u = 0.5 from t = 0 with F_e(0) = 0:
        M dv/dt = eta F_e - F_K - k_fwc v,  F_e = F (1 - e^{-t/tau}),  F = k_u u,
        v = v_inf + C1 e^{-t/T} + K e^{-t/tau},  v_inf = (eta F - F_K)/k_fwc,  T = M/k_fwc,
        K = -eta F/(k_fwc - M/tau),  C1 = v0 - v_inf - K.
    The cart decelerates first (F_e small), then speeds up: v stays > 0 (no stop)."""
    k_u, u, tau, v0 = 100.0, 0.5, 0.02, 0.1
    F = k_u * u
    v_inf, T = (ETA * F - F_K) / K_FW, M / K_FW
    K = -ETA * F / (K_FW - M / tau)
    C1 = v0 - v_inf - K
    times = np.linspace(0.0, 0.5, 501)
    run = run_cart({**CART_ALONE, "k_u": k_u, "tau_e": tau, "v0": v0}, times, lambda t: u)
    expected = v_inf + C1 * np.exp(-times / T) + K * np.exp(-times / tau)
    assert np.all(run["mode"] == 1) and run["v"].min() < 0.9 * v0  # it slows before the force builds up
    np.testing.assert_allclose(run["v"], expected, rtol=0, atol=1e-10)


# ---------------------------------------------------------------- FMU vs independent reference

def command(t):
    return math.sin(OMEGA * t)


def command_derivatives(t):
    return [OMEGA * math.cos(OMEGA * t), -OMEGA**2 * math.sin(OMEGA * t), -OMEGA**3 * math.cos(OMEGA * t)]


# Fig. 3's mass driven through u (k_u = 1.2 N per unit: the 1 N sine scaled) instead of I,
# with a back-EMF and a lag.
REFERENCE_CASES = {
    "gain": {"k_u": 1.2},
    "back-EMF": {"k_u": 1.2, "k_emf": 1.5},
    "lag": {"k_u": 1.2, "tau_e": 0.02},
    "lag and back-EMF": {"k_u": 1.2, "k_emf": 1.5, "tau_e": 0.02},
}


def fig3_command_run(extra: dict) -> dict[str, np.ndarray]:
    times = np.linspace(0.0, 2.0, 2001)
    return run_cart({**FIG3, **extra}, times, command, command_derivatives)


@pytest.mark.parametrize("case", sorted(REFERENCE_CASES))
def test_cart_with_a_command_matches_the_reference(case):
    """2 s of stick-slip under a sine command; the reference (DOP853, rtol 1e-10, stopped at
    each event) against the FMU (exact steps, or RK4 at 1e-4 s with the lag). Measured over
    the four cases: edges within 9.4e-12 s, x 6.6e-12 m, v 2.5e-11 m/s, F_e 9.9e-11 N. The
    limits are test_friction_extras' (edges 1e-9 s, x 1e-9 m, v 2e-9 m/s), 1e-9 N for F_e:
    ~10-100x the measured, far below what a model difference gives (test_each_drive_case_differs:
    > 1e-3 m)."""
    extra = REFERENCE_CASES[case]
    fmu = fig3_command_run(extra)
    reference = rr.simulate_cart({**FIG3, **extra}, 0.0, fmu["time"], u=command)
    reference_edges = [(e.time, e.old, e.new) for e in reference.attrs["events"]]
    assert len(reference_edges) >= 6
    assert edge_time_error(reference_edges, fmu_edges(fmu)) < 1e-9
    assert np.max(np.abs(fmu["x"] - reference["x"].to_numpy())) < 1e-9
    assert np.max(np.abs(fmu["v"] - reference["v"].to_numpy())) < 2e-9
    assert np.max(np.abs(fmu["F_e"] - reference["F_e"].to_numpy())) < 1e-9


def test_each_drive_case_differs():
    """Guard against a vacuous comparison: every case moves the cart differently."""
    runs = {case: fig3_command_run(extra)["x"] for case, extra in REFERENCE_CASES.items()}
    cases = sorted(runs)
    for i, a in enumerate(cases):
        for b in cases[i + 1:]:
            assert np.max(np.abs(runs[a] - runs[b])) > 1e-3, (a, b)


def test_modelica_cart_with_a_lagged_command_matches_the_fmu():
    """tests/modelica/CartDrive.mo (Fig. 3's mass driven through u, k_u = 1.2, k_emf = 1.5,
    tau_e = 0.02 s) against the FMU: the same mode sequence, edges within 1e-6 s as the other
    Modelica comparisons, and the difference grows when rumoca's tolerance does. Measured:
    edges 6.2e-11 s (2.1e-9 s at the loose tolerance), x 8.2e-10 of its range."""
    assert_cart_bench_matches("CartDrive", fig3_command_run(REFERENCE_CASES["lag and back-EMF"]), min_edges=6)


# ---------------------------------------------------------------- eta's two roles

SWING = (math.pi + 0.3, 2.0, -5.0)  # phi, w, alpha held: a pendulum push on the cart


def pendulum_push(A: float) -> float:
    phi, w, alpha = SWING
    return A * 0.2 * 0.3 * (w * w * math.sin(phi) - alpha * math.cos(phi))


@pytest.mark.parametrize("eta, eta_back, A", [
    (0.4, -1.0, 0.0),                   # the paper's: self-locking
    (0.7, -1.0, (2 * 0.7 - 1) / 0.7),   # the paper's: back-drivable, A(eta)
    (0.7, 0.0, 0.0),                    # never back-driven: eta is only the drive's efficiency
    (0.4, 0.3, 0.3),                    # back-drivable with its own efficiency below 0.5
])
def test_the_pendulum_push_follows_eta_back(eta, eta_back, A):
    """F_A = eta k_M k_D I + A m_p l (w^2 sin phi - alpha cos phi) under held inputs (read at
    the second point: the first is before the inputs are set)."""
    I = 0.5
    run = run_cart({"eta": eta, "eta_back": eta_back}, np.array([0.0, 1e-3]), lambda t: 0.0, I=I,
                   pendulum=SWING)
    expected = eta * 0.06 * 628.3 * I + pendulum_push(A)
    assert run["F_A"][1] == pytest.approx(expected, rel=1e-14)
    assert (pendulum_push(A) != 0.0) == (A > 0)


def test_the_rig_feeds_the_pendulum_back_only_to_a_back_drivable_screw():
    from pendfmu.ssp.rig import rig_connections

    assert len(rig_connections(0.4)) == 2 and len(rig_connections(0.7)) == 5
    assert len(rig_connections(0.7, 0.0)) == 2  # eta_back = 0: self-locking whatever eta
    assert len(rig_connections(0.4, 0.3)) == 5  # its own back-drive efficiency


RIG_TIMES = np.arange(0, 10001) * 2e-4
RIG_PULSE = ([0.0, 0.05, 0.4], [0.0, 1.5, 0.0])  # command current: a 1.5 A pulse


@pytest.mark.parametrize("eta, eta_back", [(0.7, 0.0), (0.4, 0.3)], ids=["self-locking at 0.7", "back-drivable at 0.4"])
def test_the_rig_with_eta_back_matches_the_reference(eta, eta_back):
    """Current loop -> cart (<-> pendulum), a current pulse from the pendulum released at
    pi + 0.3, co-simulated with rig_system (which connects the pendulum back exactly when
    A > 0) against the reference rig with the same eta_back, within test_friction_extras' rig
    bounds (2e-5 m, 1e-3 rad; measured 7.1e-6 m and 1.0e-4 rad self-locking at 0.7, 4.5e-6 m
    and 1.2e-5 rad back-drivable at 0.4, the co-simulation's coupling error as there); and
    the two differ from the paper's switch at the same eta."""
    from pendfmu.fmubuild.compiler import FMUS_DIR
    from pendfmu.simulator.master import ExternalInput, Master
    from pendfmu.ssp import rig_system

    def cosimulate(parameters):
        system = rig_system(eta, FMUS_DIR, {"eta": eta, "phi0": math.pi + 0.3, **parameters})
        pulse = ExternalInput(np.array(RIG_PULSE[0]), np.array(RIG_PULSE[1]), "hold")
        return Master.from_system(system).run(RIG_TIMES, ["Cart.x", "Pendulum.phi"], {"CurrentLoop.I_c": pulse})

    frame = cosimulate({"eta_back": eta_back})
    reference = rr.simulate_rig({"eta": eta, "eta_back": eta_back}, rr.Steps(*RIG_PULSE), RIG_TIMES,
                                {"phi0": math.pi + 0.3})
    assert np.max(np.abs(frame["Cart.x"] - reference["x"].to_numpy())) <= 2e-5
    assert np.max(np.abs(frame["Pendulum.phi"] - reference["phi"].to_numpy())) <= 1e-3
    switch = cosimulate({})
    assert np.max(np.abs(frame["Cart.x"] - switch["Cart.x"])) > 1e-4


def test_a_self_locking_screw_at_high_eta_takes_the_exact_step():
    """eta = 0.7 with eta_back = 0 is self-locking: the cart is linear in its inputs and takes
    the exact step, which equals the closed form of a constant current to rounding (RK4 would
    differ by ~1e-12 here)."""
    times = np.linspace(0.0, 0.4, 401)
    I = 1.0
    gain = 0.7 * 0.06 * 628.3
    run = run_cart({**CART_ALONE, "eta": 0.7, "eta_back": 0.0}, times, lambda t: 0.0, I=I, pendulum=SWING)
    v_inf, T = (gain * I - F_K) / K_FW, M / K_FW
    np.testing.assert_allclose(run["v"], v_inf * -np.expm1(-times / T), rtol=0, atol=1e-14)


@pytest.mark.parametrize("name, value, word", [
    ("eta_back", -0.5, "eta_back = -0.5 is neither -1"),
    ("eta_back", 1.5, "eta_back"),
    ("k_emf", -1.0, "k_emf"),
    ("tau_e", -1e-3, "tau_e"),
])
def test_invalid_drive_parameters_are_refused(name, value, word):
    """The FMU refuses them with fmi2Error and a logged message; Python's range check too."""
    from pendfmu.parameters import ParameterFileError, check_parameters

    with pytest.raises(Exception, match=word):
        with ComponentFMU("Cart", {name: value}):
            pass
    with pytest.raises(ParameterFileError, match=name):
        check_parameters({name: value})


# ---------------------------------------------------------------- the cart stage, --drive u

RESOLUTION = 2 * math.pi / (1024 * 628.3)  # the motor encoder's step along x [m]
# The command: a slow ramp from rest (the breakaway on it measures F_Sc / (eta k_u)), a hold,
# a lower level, a reversal and a stop, each sample's value held (a converter's command).
RAMP = (0.02, 0.22, 0.6)  # from t0 to t1 the command rises linearly to its level
COMMAND_STEPS = ((0.45, 0.3), (0.7, -0.6), (0.95, 0.0))


def held(t):
    t0, t1, level = RAMP
    value = 0.0 if t < t0 else level * min(1.0, (t - t0) / (t1 - t0))
    for start, step in COMMAND_STEPS:
        if t >= start:
            value = step
    return value


def write_u_recording(path, truth: dict, stop: float = 1.3):
    """A u-driven cart run (pendulum removed) of the Cart FMU, x quantized by the encoder."""
    times = np.round(np.arange(0.0, stop + 1e-9, 2e-4), 10)
    run = run_cart({**CART_ALONE, **truth}, times, held, outputs=("x",))
    x = RESOLUTION * np.round(run["x"] / RESOLUTION)
    u = np.array([held(t) for t in times])
    from pendfmu.recording.writer import write_signals

    write_signals(path, times, {"u": u, "x": x})
    path.with_suffix(".json").write_text(json.dumps({
        "experiment": "cart driven by a command u",
        "signals": {"x": {"resolution": RESOLUTION, "quantizer": "round"}},
        "parameters": {"m_p": 0.0}, "initial": {"x": 0.0, "v": 0.0}}))
    return path


DRIVE_TRUTH = {"k_u": 80.0, "k_emf": 40.0}
LAG_TRUTH = {"k_u": 80.0, "k_emf": 40.0, "tau_e": 8e-3}


def fit_u(path, start: dict, **options):
    from pendfmu.fitting.identification import fit

    return fit("cart", [path], {**start}, drive="u", seed=3, progress=False, uncertainty="jacobian", **options)


def test_the_cart_stage_takes_a_command_drive(tmp_path):
    """--drive u: the Cart alone, u held between samples; its own default free parameters
    (eta and k_fwc kept: only eta*k_u, and k_fwc + eta*k_emf without a lag, show in x)."""
    from pendfmu.fitting.stages import make_experiment, stage_free_parameters
    from pendfmu.recording import read_recording

    path = write_u_recording(tmp_path / "u.csv", DRIVE_TRUTH, stop=0.1)
    values = rig_defaults()
    experiment = make_experiment(read_recording(path), "cart", values)  # chosen by its columns
    assert dict(experiment.setup.drives) == {"u": ("u", "hold")}
    free = {p.name: p for p in stage_free_parameters("cart", [experiment], ["tau_e"], [], {}, values)}
    assert sorted(free) == ["F_Kc", "F_Sc", "k_emf", "k_u", "tau_e"]
    assert (free["k_u"].low, free["k_u"].high, free["k_u"].log) == (1e-2, 1e5, True)
    assert (free["tau_e"].low, free["tau_e"].high, free["tau_e"].log) == (1e-4, 1.0, True)


def test_the_cart_stage_recovers_the_command_gain_and_back_emf(tmp_path):
    """A u-driven start on a slow ramp, a hold, a lower level, a reversal and a stop (1.3 s,
    encoder-quantized x) of a cart with k_u = 80 N, k_emf = 40 N.s/m; fitted with k_fwc
    known, from a start 25 % off (k_u 60, k_emf 30) and the friction's own values given (their
    boxes a decade either side; without a value, the box derived from the drive's force spans
    three decades and the global search, seed 3, ends in another basin, k_u 86.5). The only error in the data is the
    encoder's rounding (9.8 um over ~0.1 m of travel). Measured: k_u within 2.4e-6 relative,
    k_emf within 1.3e-4, F_Kc 4.4e-5. The limit, 1e-3, is ten times the worst; a model error
    does not hide under it: 1e-3 of k_u is 0.02 N of force, which moves x by ~6 encoder
    steps by the end of the hold, and the cost at the truth's 1.001 k_u is checked to be far
    above the fit's.

    (From a start a factor 2 off, the default global search, 8 candidates per parameter for
    25 generations, did not find this minimum: the cost stayed 2e4 times higher. Priors for a
    drive's gain and back-EMF come from data sheets, good to well within 25 %.)"""
    path = write_u_recording(tmp_path / "u.csv", DRIVE_TRUTH)
    result = fit_u(path, {"k_u": 60.0, "k_emf": 30.0, "F_Kc": F_K, "F_Sc": F_S})
    for name, truth in {**DRIVE_TRUTH, "F_Kc": F_K}.items():
        estimate = result.estimates[name]
        print(f"{name}: {estimate.value:.10g} (truth {truth}), stderr {estimate.stderr:.3g}")
        assert abs(estimate.value - truth) < 1e-3 * truth, name
    assert result.parameters["k_fwc"] == 30.0 and result.parameters["eta"] == 0.4  # kept
    assert cost_at(path, {**result.parameters, "k_u": 1.001 * result.parameters["k_u"]}) > 10 * result.cost


def cost_at(path, values: dict) -> float:
    """The cost (½ Σ r², as a fit reports it) of the u-driven cart stage at `values`, nothing
    fitted: the problem a fit would solve, evaluated once (a fit of nothing is refused)."""
    from pendfmu.fitting.problem import build_problem
    from pendfmu.fitting.residuals import Residuals
    from pendfmu.fitting.spec import FitSpec

    problem = build_problem(FitSpec("cart", [path], params=values, drive="u", fix=list(COMMAND_FREE)))
    assert problem.free == []
    residuals = Residuals(problem.experiments, problem.free, problem.values)
    try:
        residual = residuals(np.zeros(0))
    finally:
        residuals.close()
    return 0.5 * float(residual @ residual)


def test_the_cart_stage_recovers_an_electrical_lag(tmp_path):
    """The same run with tau_e = 8 ms: the lag delays each breakaway and rounds each change of
    speed. --free tau_e, from a start 25 % off. Measured: k_u within 1.9e-4 relative, k_emf
    5e-5, tau_e 5.9e-4; limits as without the lag, 1 % for tau_e (a time constant of 8 ms
    seen through 0.2 ms samples)."""
    path = write_u_recording(tmp_path / "lag.csv", LAG_TRUTH)
    result = fit_u(path, {"k_u": 60.0, "k_emf": 30.0, "tau_e": 6e-3}, free=["tau_e"])
    for name, truth in LAG_TRUTH.items():
        estimate = result.estimates[name]
        print(f"{name}: {estimate.value:.10g} (truth {truth}), stderr {estimate.stderr:.3g}")
        assert abs(estimate.value - truth) < (1e-2 if name == "tau_e" else 1e-3) * truth, name


def test_a_fit_warns_when_eta_straddles_the_self_locking_switch(tmp_path, capsys):
    """eta free over a box across 0.5 with a pendulum on the cart: the warning names the fix;
    with eta_back = 0 or the pendulum removed there is none."""
    from pendfmu.fitting.plausibility import self_locking_switch
    from pendfmu.fitting.stages import make_experiment, stage_free_parameters
    from pendfmu.recording import read_recording

    path = write_u_recording(tmp_path / "u.csv", DRIVE_TRUTH, stop=0.1)
    recording = read_recording(path)
    for parameters, warned in (({"m_p": 0.2}, True), ({"m_p": 0.2, "eta_back": 0.0}, False),
                               ({"m_p": 0.0}, False)):
        recording = replace(recording, parameters=parameters)
        values = rig_defaults()
        experiment = make_experiment(recording, "cart", values, "u")
        free = stage_free_parameters("cart", [experiment], ["eta"], [], {"eta": (0.3, 0.8)}, values)
        warnings = self_locking_switch(free, [experiment])
        assert bool(warnings) == warned, parameters
        if warned:
            assert "eta_back=0" in warnings[0] and "0.5" in warnings[0]
    narrow = stage_free_parameters("cart", [experiment], ["eta"], [], {"eta": (0.3, 0.45)}, values)
    assert self_locking_switch(narrow, [experiment]) == []


def test_a_fit_warns_when_back_emf_and_viscous_friction_are_both_free(tmp_path):
    """Without a lag only k_fwc + eta k_emf shows in x: freeing both is warned about; with
    tau_e free (or set) the two separate and there is no warning."""
    from pendfmu.fitting.plausibility import viscous_twins
    from pendfmu.fitting.stages import make_experiment, stage_free_parameters
    from pendfmu.recording import read_recording

    path = write_u_recording(tmp_path / "u.csv", DRIVE_TRUTH, stop=0.1)
    values = {**rig_defaults(), "k_u": 60.0, "k_emf": 30.0, "tau_e": 0.0}
    experiment = make_experiment(read_recording(path), "cart", values, "u")
    both = stage_free_parameters("cart", [experiment], ["k_fwc"], [], {}, values)
    assert "k_fwc + eta*k_emf" in viscous_twins(both, [experiment])[0]
    assert viscous_twins(stage_free_parameters("cart", [experiment], [], [], {}, values), [experiment]) == []
    lagged = stage_free_parameters("cart", [experiment], ["k_fwc", "tau_e"], [], {"tau_e": (1e-4, 1.0)}, values)
    assert viscous_twins(lagged, [experiment]) == []


def test_model_exchange_integrates_the_lag_as_co_simulation_does():
    """The lag's state is a state of the Model Exchange interface too (der(F_e)): CVode at
    rtol 1e-10 under a command step at t_on (an input step, so that fmpy sets it at a time
    event: between output points it applies inputs only when it evaluates the indicators,
    TOOL-NOTES) finds the breakaway the lag delays, t_on + tau_e ln 2.5, and the motion of
    Co-Simulation. Measured: breakaway 3.3e-12 s from the closed form (CS 6.1e-12 s), x
    within 4.9e-11 m, F_e within 3.9e-8 N of CS (RK4's error on the lag, 1e-8 N above);
    limits 1e-9 s, 1e-9 m and 2e-7 N."""
    from fmpy import simulate_fmu

    from pendfmu.fmubuild import ensure_fmu

    tau, stop, t_on = 5e-3, 0.3, 0.05
    params = {**CART_ALONE, "k_u": 100.0, "k_emf": 45.0, "tau_e": tau}
    steps = np.array([(0.0, 0.0), (t_on, 0.0), (t_on, 0.5), (stop, 0.5)], dtype=[("time", float), ("u", float)])
    me = simulate_fmu(str(ensure_fmu("Cart")), fmi_type="ModelExchange", solver="CVode", stop_time=stop,
                      output_interval=1e-3, relative_tolerance=1e-10, start_values=params, input=steps,
                      output=["x", "F_e", "mode", "t_mode"])
    grid = np.linspace(0.0, stop, 301)
    cs = run_cart(params, grid, lambda t: 0.5 if t >= t_on else 0.0)
    changed = np.flatnonzero(np.diff(me["mode"])) + 1
    assert [(int(me["mode"][k - 1]), int(me["mode"][k])) for k in changed] == [(0, 1)]
    assert abs(me["t_mode"][-1] - (t_on + tau * math.log(2.5))) < 1e-9
    time = np.asarray(me["time"])
    assert np.max(np.abs(np.interp(grid, time, me["x"]) - cs["x"])) < 1e-9
    on = grid > t_on
    assert np.max(np.abs(np.interp(grid[on], time, me["F_e"]) - cs["F_e"][on])) < 2e-7
    assert cs["F_e"][-1] > 10.0  # the lag did act
