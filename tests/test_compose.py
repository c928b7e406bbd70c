"""`pendfmu system` (pendfmu/ssp/compose.py): a system of components wired by name.

The loop of test_controller_loop written by the command line instead of by hand must run
to the same numbers as that test's independent plain-Python closed loop (the SSP is all
that differs); and every kind of mistake is an exit 2 naming what is wrong."""

from __future__ import annotations

import json
import zipfile

import numpy as np
import pytest
from fmpy import read_model_description

from pendfmu.cli import main
from pendfmu.ssp import read_ssp

from test_controller_loop import CART_VALUES, CONTROLLER, TOLERANCE, python_closed_loop, reference_signal


def write_loop(tmp_path, extra=()):
    params = tmp_path / "loop.json"
    values = {f"Controller.{k}": (int(v) if isinstance(v, bool) else v) for k, v in CONTROLLER.items()}
    values.update({f"Cart.{k}": v for k, v in CART_VALUES.items()})
    params.write_text(json.dumps({"parameters": values}))
    out = tmp_path / "loop.ssp"
    code = main(["system", "--out", str(out), "--component", "Controller", "Cart", "--connect",
                 "Controller.u=Cart.I", "Cart.x=Controller.y", "--params", str(params), *extra])
    return code, out


def test_the_composed_loop_runs_as_the_independent_one(tmp_path):
    from pendfmu.simulator.model import Model
    from pendfmu.fitting.models import simulate_model
    from pendfmu.recording import Recording

    code, ssp = write_loop(tmp_path)
    assert code == 0
    system = read_ssp(ssp)
    assert sorted(str(c) for c in system.component_connections()) == ["Cart.x -> Controller.y",
                                                                       "Controller.u -> Cart.I"]
    # every input no connection feeds is an input of the system, named like the variable
    assert sorted(str(c) for c in system.connections if c.at_boundary) == [
        "alpha -> Cart.alpha", "phi -> Cart.phi", "r -> Controller.r", "u -> Cart.u", "u_ff -> Controller.u_ff",
        "w -> Cart.w"]
    assert system.parameters["Controller"]["n_d"].value == 2 and system.parameters["Controller"]["n_d"].type == "Integer"
    t, r = reference_signal()
    model = Model.load(ssp)
    recording = Recording(tmp_path / "reference.csv", t, {"qg": r}, vocabulary=model.vocabulary(["qg"]))
    out = simulate_model(model, recording, {}, drive={"Controller.r": "qg"})
    x, u = python_closed_loop(t, r)
    np.testing.assert_allclose(out["x"], x, rtol=0, atol=TOLERANCE)
    np.testing.assert_allclose(out["u"], u, rtol=0, atol=1e-9)
    through_system_input = simulate_model(model, recording, {}, drive={"r": "qg"})
    np.testing.assert_array_equal(through_system_input["x"], out["x"])


def test_without_system_connectors_for_ecos_and_libcosim(tmp_path):
    """The same loop with no system inputs: pendfmu still reads it, its free inputs drivable by name."""
    code, ssp = write_loop(tmp_path, ["--no-system-connectors"])
    assert code == 0
    system = read_ssp(ssp)
    assert system.connectors == () and len(system.connections) == 2
    from pendfmu.simulator.model import Model
    assert "Controller.r" in Model.load(ssp).names("input")


def test_set_comes_after_params(tmp_path):
    code, ssp = write_loop(tmp_path, ["--set", "Cart.eta=0.45", "m_c=2.5"])
    assert code == 0
    cart = read_ssp(ssp).parameters["Cart"]
    assert cart["eta"].value == 0.45 and cart["m_c"].value == 2.5


@pytest.mark.parametrize("arguments, message", [
    (["--component", "Controller", "Nope"], "'Nope' is neither an FMU file"),
    (["--component", "Controller", "Cart", "--connect", "Controller.u-Cart.I"], "write it Start.output=End.input"),
    (["--component", "Controller", "Cart", "--connect", "Controller.q=Cart.I"], "Controller has no output 'q'"),
    (["--component", "Controller", "Cart", "--connect", "Cart.I=Controller.y"], "Cart has no output 'I'"),
    (["--component", "Controller", "Cart", "--set", "l=0.3"], None),
    (["--component", "Controller", "Cart", "--set", "K_q=1"], "K_q: no component has it"),
    (["--component", "Controller", "Cart", "--set", "Cart.n_d=1"], "Cart has no parameter 'n_d'"),
    (["--component", "Controller", "Cart", "--set", "Controller.n_d=1.5"], "an Integer"),
    (["--component", "Controller", "Cart", "--set", "Controller.K_p"], "NAME=NUMBER"),
])
def test_mistakes_are_named(tmp_path, capsys, arguments, message):
    code = main(["system", "--out", str(tmp_path / "s.ssp"), *arguments])
    if message is None:
        assert code == 0
        return
    assert code == 2
    assert message in capsys.readouterr().err


def test_one_system_input_feeds_every_input_it_is_wired_to(tmp_path):
    """Two current loops with different time constants behind one system input: a recording's
    column drives both, each as it does alone (the paper's first-order lag)."""
    from pendfmu.simulator.model import Model
    from pendfmu.fitting.models import simulate_model
    from pendfmu.recording import Recording
    from pendfmu.ssp import Connection, Connector, write_ssp
    from pendfmu.ssp.compose import compose

    system = compose({"A": "CurrentLoop", "B": "CurrentLoop"}, [], {"A.T_i": 1e-3, "B.T_i": 2e-3}, step_size=1e-4)
    assert [c.name for c in system.connectors] == ["A_I_c", "B_I_c"]  # the same name in two components
    system.connectors = (Connector("I_c", "input", "Real", "A"),)
    system.connections = [Connection.between("I_c", "A.I_c"), Connection.between("I_c", "B.I_c")]
    ssp = write_ssp(system, tmp_path / "two.ssp")
    with zipfile.ZipFile(ssp) as archive:  # one packed copy per component, each with its values
        archive.extractall(tmp_path / "two")
    for name, tau in (("A", 1e-3), ("B", 2e-3)):
        description = read_model_description(str(tmp_path / "two" / "resources" / f"{name}.fmu"))
        assert next(float(v.start) for v in description.modelVariables if v.name == "T_i") == tau
    model = Model.load(ssp)
    t = np.arange(101) * 1e-4
    recording = Recording(tmp_path / "step.csv", t, {"I_c": np.where(t > 0, 0.1, 0.0)},
                          vocabulary=model.vocabulary())
    out = simulate_model(model, recording, {})
    for name, tau in (("A.I", 1e-3), ("B.I", 2e-3)):  # slope 0.1/tau < dIdt_max: the plain lag
        np.testing.assert_allclose(out[name], np.where(t > 0, 0.1 * (1 - np.exp(-(t - 1e-4) / tau)), 0.0),
                                   rtol=0, atol=2e-3 * 0.1)
