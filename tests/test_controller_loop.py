"""A controller in the loop: an SSP system of Controller + Cart (Controller.u -> Cart.I,
Cart.x -> Controller.y, Controller.r driven by a recorded column), simulated by pendfmu's
master through the model layer (`pendfmu simulate --system`), against an independent
plain-Python closed loop.

The reference: the controller's law written out here (PD on the measurement, n_d = 2, one
sample of delay, saturation), its output held over each sample, and the cart's sliding law
m_c a = eta k_M k_D I - k_fwc v integrated by scipy's DOP853 (rtol 1e-12) from sample to
sample. The case has no stiction and no Coulomb friction (F_Sc = F_Kc = 0, m_p = 0, eta 0.4),
so the cart is a linear plant the FMU steps exactly; the reference speed reaches 0.3 m/s and
the controller saturates on the way (u_max 0.7 A, 344 of 2000 samples).

Tolerance. Both sides solve the same equations; the FMU's cart takes its exact solution for a
held current, DOP853 errs by ~1e-13 of x. Measured: positions agree to 2.2e-16 m and the
currents to 1.1e-13 A over 2000 samples (4006 loop iterations, two per step). 1e-10 m is
allowed: 500x below the encoder's 5e-8 m. Interpolating the controller's held output over a
step (what the master did before it held discrete outputs) applies each new current early:
it moves the positions by 4.1e-5 m on this case (the currents by 3.4e-3 A), and a test checks
that this difference is still visible, so the held coupling is what makes the agreement.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from pendfmu.components import CART
from pendfmu.fmubuild import ensure_fmu
from pendfmu.simulator.master import ExternalInput, Master
from pendfmu.ssp import Connection, DefaultExperiment, ParameterValue, System, describe_fmu, fmu_component, write_ssp

T_S = 1e-3
CONTROLLER = {"T_s": T_S, "K_p": 80.0, "K_d": 3.6, "derivative_on_measurement": True, "n_d": 2, "delay": 1,
              "u_max": 0.7, "u_min": -0.7}
CART_VALUES = {"m_p": 0.0, "F_Kc": 0.0, "F_Sc": 0.0, "eta": 0.4}
TOLERANCE = 1e-10  # m (module docstring)


def reference_signal(n=2000):
    """A recorded-like position reference: trapezoidal speed, out and back."""
    t = np.arange(n) * T_S
    speed = np.interp(t, [0, 0.15, 0.55, 0.7, 1.0, 1.15, 1.55, 1.7], [0, 0.3, 0.3, 0, 0, -0.3, -0.3, 0])
    return t, np.concatenate([[0.0], np.cumsum(speed[1:] * T_S)])


def python_closed_loop(t, r, c=CONTROLLER):
    """The independent closed loop (module docstring)."""
    m = CART.variable("m_c").start + CART_VALUES["m_p"]
    force_per_ampere = CART_VALUES["eta"] * CART.variable("k_M").start * CART.variable("k_D").start
    k_fwc = CART.variable("k_fwc").start
    state = np.zeros(2)
    measured = []  # -y at each sample
    delayed = 0.0  # the delay line's one slot (u0 = 0)
    xs, us = np.empty(len(t)), np.empty(len(t))
    for j in range(len(t)):
        x = state[0]
        measured.append(-x)
        past = measured[-1 - c["n_d"]] if len(measured) > c["n_d"] else measured[0]
        v = c["K_p"] * (r[j] - x) + c["K_d"] * (measured[-1] - past) / (c["n_d"] * T_S)
        current, delayed = delayed, min(c["u_max"], max(c["u_min"], v))
        xs[j], us[j] = x, current
        if j + 1 < len(t):
            sol = solve_ivp(lambda _, z: [z[1], (force_per_ampere * current - k_fwc * z[1]) / m], (t[j], t[j + 1]),
                            state, method="DOP853", rtol=1e-12, atol=1e-15)
            state = sol.y[:, -1]
    return xs, us


def loop_system(values=None) -> System:
    paths = {name: ensure_fmu(name) for name in ("Controller", "Cart")}
    components = {}
    for name, path in paths.items():
        c = fmu_component(name, path)
        components[name] = type(c)(c.name, c.source, c.connectors, "CoSimulation", path)
    units = {}
    for path in paths.values():
        units.update(describe_fmu(path).units)
    kinds = {"Real": float, "Integer": int, "Boolean": bool}
    parameters = {}
    for name, given in (("Controller", values or CONTROLLER), ("Cart", CART_VALUES)):
        declared = {c.name: c for c in components[name].connectors}
        parameters[name] = {key: ParameterValue(kinds[declared[key].type](value), declared[key].unit,
                                                declared[key].type) for key, value in given.items()}
    used = {c.unit for comp in components.values() for c in comp.connectors if c.unit}
    return System("ControlledCart", components,
                  [Connection.between("Controller.u", "Cart.I"), Connection.between("Cart.x", "Controller.y")],
                  parameters, {u: units[u] for u in sorted(used) if u in units},
                  experiment=DefaultExperiment(0.0, 2.0, T_S),
                  description="A discrete PD position controller driving the cart")


@pytest.fixture(scope="module")
def loop_ssp(tmp_path_factory) -> Path:
    return write_ssp(loop_system(), tmp_path_factory.mktemp("loop") / "ControlledCart.ssp")


@pytest.fixture(scope="module")
def reference():
    t, r = reference_signal()
    x, u = python_closed_loop(t, r)
    return t, r, x, u


def test_closed_loop_through_the_model_layer(loop_ssp, reference):
    """What `pendfmu simulate --system` runs: the SSP read back, the recorded column driving
    Controller.r, the master stepping the coupled pair at the recording's samples."""
    from pendfmu.simulator.model import Model
    from pendfmu.fitting.models import simulate_model
    from pendfmu.recording import Recording

    t, r, x, u = reference
    model = Model.load(loop_ssp)
    assert model.order == [["Cart", "Controller"]]  # they feed each other: one coupled group
    assert model.defaults()["n_d"] == 2 and model.defaults()["derivative_on_measurement"] == 1.0
    recording = Recording(loop_ssp.parent / "reference.csv", t, {"qg": r}, vocabulary=model.vocabulary(["qg"]))
    out = simulate_model(model, recording, {}, drive={"Controller.r": "qg"})
    assert np.sum(np.abs(u) >= CONTROLLER["u_max"]) > 100  # the saturation is exercised
    np.testing.assert_allclose(out["x"], x, rtol=0, atol=TOLERANCE)
    np.testing.assert_allclose(out["u"], u, rtol=0, atol=1e-9)
    error = np.abs(out["x"].to_numpy() - r)
    assert error.max() < 0.03 and error[-1] < 1e-4  # and it does control (a P loop lags 2.3 cm at speed)


def test_cli_simulates_the_system(loop_ssp, reference, tmp_path):
    import pandas as pd

    from pendfmu.cli import main

    t, r, x, _ = reference
    csv = tmp_path / "reference.csv"
    pd.DataFrame({"time": t, "qg": r}).to_csv(csv, index=False, float_format="%.17g")
    out = tmp_path / "out.csv"
    assert main(["simulate", "--system", str(loop_ssp), "--input", str(csv), "--drive", "Controller.r=qg",
                 "--out", str(out)]) == 0
    simulated = pd.read_csv(out)
    np.testing.assert_allclose(simulated["x"], x, rtol=0, atol=TOLERANCE)


def test_both_engines_agree_and_interpolating_the_held_output_would_not(loop_ssp, reference):
    """The master's native and Python engines give the same numbers; a Python master whose
    held-signal set is emptied (the coupling before discrete outputs were held) is off by
    far more than the tolerance, so the comparison above can tell the two apart."""
    from pendfmu.ssp import read_ssp

    t, r, x, _ = reference
    runs = {}
    for engine in ("native", "python", "interpolated"):
        master = Master.from_system(read_ssp(loop_ssp))
        assert master.held == {("Controller", "u")}
        if engine == "interpolated":
            master.held = set()
        result = master.run(t, ["Cart.x"], {"Controller.r": ExternalInput(t, r)},
                            engine="python" if engine != "native" else "native")
        runs[engine] = result["Cart.x"].to_numpy()
        master.close()
    np.testing.assert_array_equal(runs["native"], runs["python"])
    np.testing.assert_allclose(runs["native"], x, rtol=0, atol=TOLERANCE)
    assert np.max(np.abs(runs["interpolated"] - x)) > 1e4 * TOLERANCE


def test_jittered_communication_points_are_the_samples(loop_ssp, reference):
    """Logged time stamps jitter (EMPS's by up to 3e-8 s around whole milliseconds). A
    communication point within a hundredth of T_s of a sample is that sample: the loop on
    stamps jittered by up to 3e-8 s gives the loop on the nominal grid to within what the
    jitter itself moves: the cart travels at most 0.3 m/s x 3e-8 s = 9e-9 m between a stamp
    and its sample, and each held current acts that much longer or shorter (measured 1.4e-8 m,
    6e-9 m once x is corrected by v times the jitter; the current 3.2e-5 A, the D gain's
    K_d/(2 T_s) times that). Without the window (SAMPLE_JITTER 0): 2.0e-4 m and 0.020 A, each
    late point pushing its sample into the step before."""
    from pendfmu.ssp import read_ssp

    t, r, x, u = reference
    jitter = np.random.default_rng(4).uniform(-3e-8, 3e-8, len(t))
    jitter[0] = 0.0
    master = Master.from_system(read_ssp(loop_ssp))
    result = master.run(t + jitter, ["Cart.x", "Controller.u"], {"Controller.r": ExternalInput(t + jitter, r)})
    master.close()
    np.testing.assert_allclose(result["Cart.x"].to_numpy(), x, rtol=0, atol=3e-8)
    np.testing.assert_allclose(result["Controller.u"].to_numpy(), u, rtol=0, atol=1e-4)


def test_cli_simulate_leaves_measured_columns_alone(loop_ssp, reference, tmp_path):
    """A recording that holds the measured outputs beside the drive (what a user compares the
    simulation with, here the reference's own x as "qm"): `pendfmu simulate` drives the model
    from the columns it needs and leaves the rest, with the same result as without them."""
    import pandas as pd

    from pendfmu.cli import main

    t, r, x, _ = reference
    csv = tmp_path / "measured.csv"
    pd.DataFrame({"time": t, "qg": r, "qm": x}).to_csv(csv, index=False, float_format="%.17g")
    out = tmp_path / "out.csv"
    assert main(["simulate", "--system", str(loop_ssp), "--input", str(csv), "--drive", "Controller.r=qg",
                 "--out", str(out)]) == 0
    np.testing.assert_allclose(pd.read_csv(out)["x"], x, rtol=0, atol=TOLERANCE)
