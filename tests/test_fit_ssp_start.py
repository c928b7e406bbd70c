"""`pendfmu fit --system S.ssp` starts from the values the SSP binds: they are the model's known
values and the start of the fitted ones (docs/user-guide/own-fmu.md: "Known values", "Search box").

The cart alone, commanded through its drive input u (force k_u*u before the screw), with
k_u 0 in its FMU: without the SSP's value there is no start and no box (a decade either
side of 0 is none). The SSP's value keys under the name the user frees, Cart.k_u, although
the model's own name for it is the bare k_u (fitting/models.py, without_aliases).
"""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from pendfmu.cli import main

TRUE_K_U, START_K_U = 60.0, 40.0
M_C = 2.0  # bound in both SSPs: a known value the fit must take from the SSP (the FMU says 3)
TIME = np.arange(501) * 1e-3
COMMAND = np.where(TIME >= 0.05, 1.0, 0.0)


def cart_ssp(path, k_u: float):
    assert main(["system", "--out", str(path), "--component", "Cart", "--set", f"Cart.k_u={k_u}",
                 f"Cart.m_c={M_C}"]) == 0
    return path


@pytest.fixture(scope="module")
def fitted(tmp_path_factory):
    """`pendfmu fit --system start.ssp run.csv --free Cart.k_u` on a recording of the truth."""
    folder = tmp_path_factory.mktemp("fit-ssp")
    truth, start = cart_ssp(folder / "truth.ssp", TRUE_K_U), cart_ssp(folder / "start.ssp", START_K_U)
    drive = pd.DataFrame({"time": TIME, "u": COMMAND})
    drive.to_csv(folder / "u.csv", index=False)
    assert main(["simulate", "--system", str(truth), "--input", str(folder / "u.csv"),
                 "--out", str(folder / "sim.csv")]) == 0
    x = pd.read_csv(folder / "sim.csv")["x"]
    assert x.iloc[-1] > 0.05  # k_u 60 breaks the cart loose: x depends on k_u
    drive.assign(x=x).to_csv(folder / "run.csv", index=False)
    out = folder / "fitted.json"
    assert main(["fit", "--system", str(start), str(folder / "run.csv"), "--free", "Cart.k_u", "--out", str(out),
                 "--uncertainty", "jacobian"]) == 0
    return out


def test_the_fit_starts_from_the_ssps_value_searches_a_decade_around_it_and_finds_the_truth(fitted):
    result = json.loads(fitted.read_text())
    (stage,) = result["provenance"]["stages"].values()
    assert stage["start"] == {"Cart.k_u": START_K_U}
    assert stage["bounds"] == {"Cart.k_u": [START_K_U / 10, START_K_U * 10]}
    assert stage["fixed"]["m_c"] == M_C
    assert result["parameters"]["Cart.k_u"] == pytest.approx(TRUE_K_U, rel=1e-6)
    assert "k_u" not in result["parameters"]  # one port, one key


def test_the_result_exports_for_its_system_and_the_copys_binary_computes_with_the_fit(fitted, tmp_path):
    """`pendfmu export --params RESULT` without --system exports for the SSP the result names;
    the Cart in it is pendfmu's, so its copy carries a start file: run by fmpy without start
    values, it moves exactly as the built Cart told the fitted values."""
    from fmpy import simulate_fmu

    from pendfmu.fmubuild import ensure_fmu

    assert main(["export", "--params", str(fitted), "--out", str(tmp_path)]) == 0
    k_u = json.loads(fitted.read_text())["parameters"]["Cart.k_u"]
    drive = np.array(list(zip(TIME, COMMAND)), dtype=[("time", float), ("u", float)])
    run = dict(stop_time=TIME[-1], output_interval=TIME[1], input=drive, output=["x"])
    exported = simulate_fmu(str(tmp_path / "Cart.fmu"), **run)
    told = simulate_fmu(str(ensure_fmu("Cart")), start_values={"k_u": k_u, "m_c": M_C}, **run)
    assert exported["x"][-1] > 0.05
    np.testing.assert_array_equal(exported["x"], told["x"])
