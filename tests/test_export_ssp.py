"""From a fit to other tools' engines in one step: `pendfmu export --params RESULT.json` writes
the fitted rig as rig.ssp (system connectors: fmpy) and rig-flat.ssp (none: ecos,
libcosim), and each engine runs it as `pendfmu simulate --params RESULT.json` runs the rig.

The result file is a real one: `pendfmu fit current` on a short recording, told the cart of
tests/test_ssp_tools.py (m_c 1.5 kg, eta 0.45: self-locking, no algebraic loop), so its
"parameters" hold the fitted current loop and that cart. The case and the expected
agreement are test_ssp_tools' (its module docstring): a Jacobi master lags the cart's
force by FORCE_LAG steps against pendfmu's coupling, so |dx| is the cart's largest speed
times that lag, and halving the step halves the difference.
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from pendfmu.cli import main
from pendfmu.ssp import read_ssp
from pendfmu.virtual_rig import Trial, steps, write_experiments
from ssp_engines import OUTPUTS, available
from test_ssp_tools import ENGINES, ETA, FORCE_LAG, GIVEN, H, STOP, drive, largest_difference, needs

KNOWN = {**GIVEN, "eta": ETA}
TRUE_CURRENT_LOOP = {"T_i": 0.5e-3, "dIdt_max": 2000.0, "a_h": 0.0}


@pytest.fixture(scope="module")
def result(tmp_path_factory):
    """A result file as `pendfmu fit` writes it: the current loop fitted, the cart known."""
    folder = tmp_path_factory.mktemp("fit")
    experiment = Trial("steps", "current", 0.012, 20e-6, ("I_c", "I"), steps((0, 0.0), (1e-3, 2.0), (6e-3, -1.0)))
    write_experiments(folder, TRUE_CURRENT_LOOP, seed=4, experiments=[experiment])
    known = folder / "known.json"
    known.write_text(json.dumps({"parameters": KNOWN}))
    out = folder / "fitted.json"
    assert main(["fit", "current", str(folder / "steps.csv"), "--params", str(known), "--out", str(out),
                 "--seed", "1", "--uncertainty", "jacobian"]) == 0
    return out


@pytest.fixture(scope="module")
def exported(result, tmp_path_factory):
    out = tmp_path_factory.mktemp("exported")
    assert main(["export", "--params", str(result), "--out", str(out)]) == 0
    return out


def simulate(folder, h, params=None) -> dict[str, np.ndarray]:
    """`pendfmu simulate [--params RESULT]` of the rig on the drive sampled every h, at k*h, k >= 1."""
    times = np.arange(round(STOP / h) + 1) * h
    recording, out = folder / f"drive-{h}.csv", folder / f"out-{h}-{params is not None}.csv"
    pd.DataFrame({"time": times, "I_c": [drive(t) for t in times]}).to_csv(recording, index=False)
    arguments = ["--params", str(params)] if params else []
    assert main(["simulate", *arguments, "--input", str(recording), "--out", str(out)]) == 0
    frame = pd.read_csv(out)
    return {name: frame[name].to_numpy()[1:] for name in ("time", *OUTPUTS)}


@pytest.fixture(scope="module")
def runs(result, exported, tmp_path_factory):
    """(who, values, h) -> time and outputs, keyed as test_ssp_tools' runs: "given" is the
    result's rig, "default" pendfmu's rig without it."""
    folder = tmp_path_factory.mktemp("runs")
    found = {}
    for h in (H, H / 2):
        found["pendfmu", "given", h] = simulate(folder, h, result)
        found["pendfmu", "default", h] = simulate(folder, h)
        for engine, (run, module) in ENGINES.items():
            if not available(module):
                ssp = exported / ("rig.ssp" if engine == "fmpy" else "rig-flat.ssp")
                found[engine, "given", h] = found[engine, "default", h] = run(ssp, drive, STOP, h)
    return found


def test_the_export_writes_both_ssps_with_the_results_values_and_says_so(result, tmp_path, capsys):
    assert main(["export", "--params", str(result), "--out", str(tmp_path)]) == 0
    written = capsys.readouterr().out.splitlines()
    assert written[-2:] == [f"wrote {tmp_path / 'rig.ssp'}", f"wrote {tmp_path / 'rig-flat.ssp'}"]
    fitted = json.loads(result.read_text())["parameters"]
    assert fitted["T_i"] == pytest.approx(TRUE_CURRENT_LOOP["T_i"], rel=0.03)  # a fitted value, not the default
    for name in ("rig.ssp", "rig-flat.ssp"):
        values = read_ssp(tmp_path / name).parameters
        assert values["CurrentLoop"]["T_i"].value == fitted["T_i"]
        assert (values["Cart"]["m_c"].value, values["Cart"]["eta"].value) == (KNOWN["m_c"], KNOWN["eta"])
        assert values["Cart"]["m_p"].value == values["Pendulum"]["m_p"].value == fitted["m_p"]


@pytest.mark.parametrize("engine", list(ENGINES))
def test_the_engine_runs_the_fitted_rig_as_pendfmu_simulate_does(runs, engine):
    """|dx| is the cart's largest speed times the engine's coupling lag (within 25 %, as in
    test_ssp_tools), at both steps; halving the step halves the difference in x and phi;
    and the run is the result's rig, not the default one (which differs far more)."""
    needs(engine)
    for h in (H, H / 2):
        expected = np.max(np.abs(runs["pendfmu", "given", h]["v"])) * FORCE_LAG[engine] * h
        assert 0.75 * expected < largest_difference(runs, engine, h, "x") < 1.25 * expected, (h, expected)
    for signal in ("x", "phi"):
        ratio = largest_difference(runs, engine, H, signal) / largest_difference(runs, engine, H / 2, signal)
        assert 1.7 < ratio < 2.3, (signal, ratio)
    to_default = largest_difference(runs, engine, H, "x", label="default")  # the engine's run against the default rig
    assert largest_difference(runs, engine, H, "x") < 0.01 * to_default


def test_pendfmu_system_takes_the_result_file_as_it_is(result, exported, tmp_path, capsys):
    """`pendfmu system --params RESULT`: the shared m_p and l go to Cart and Pendulum, so the
    rig composed by hand states the exported rig's values; a loop without the current loop
    and the pendulum leaves their values out and says so; a name nothing has stays an error."""
    rig = tmp_path / "rig.ssp"
    assert main(["system", "--out", str(rig), "--component", "CurrentLoop", "Cart", "Pendulum", "--connect",
                 "CurrentLoop.I_mean=Cart.I", "Cart.a=Pendulum.a", "--params", str(result)]) == 0
    assert read_ssp(rig).parameters == read_ssp(exported / "rig.ssp").parameters
    capsys.readouterr()
    loop = tmp_path / "loop.ssp"
    assert main(["system", "--out", str(loop), "--component", "Controller", "Cart", "--connect", "Controller.u=Cart.I",
                 "Cart.x=Controller.y", "--params", str(result)]) == 0
    note = capsys.readouterr().err
    assert "left out, as no component of this system has them: CurrentLoop: T_i, dIdt_max" in note
    assert "Pendulum: J_p" in note and "m_p" not in note
    assert read_ssp(loop).parameters["Cart"]["m_c"].value == KNOWN["m_c"]
    document = json.loads(result.read_text())
    document["parameters"]["k_fwcc"] = 30.0
    typo = tmp_path / "typo.json"
    typo.write_text(json.dumps(document))
    assert main(["system", "--out", str(loop), "--component", "Cart", "--params", str(typo)]) == 2
    assert "parameter k_fwcc: no component has it (did you mean 'k_fwc'?)" in capsys.readouterr().err
