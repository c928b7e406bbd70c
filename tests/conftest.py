"""Shared fixtures: the FMUs are built (or found up to date) once per test session."""

from __future__ import annotations

import pytest

from pendfmu.fmubuild import build_all


@pytest.fixture(scope="session", autouse=True)
def built_fmus():
    return build_all()


@pytest.fixture(scope="session")
def cart_recording(tmp_path_factory):
    """A short cart start-up (pendulum removed) on the virtual rig, with a truth away from
    the defaults: the small fit that the determinism, failure, interrupt and Dask tests share."""
    from pendfmu.virtual_rig import Experiment, steps, write_experiments

    out = tmp_path_factory.mktemp("cart-recording")
    experiment = Experiment("cart", "cart", 0.4, 2e-4, ("I_c", "I", "x"), steps((0, 0.0), (0.02, 2.0), (0.25, 0.0)),
                            sidecar_parameters={"m_p": 0.0}, known_initial=("x", "v"))
    write_experiments(out, CART_TRUTH, seed=9, experiments=[experiment])
    return out / "cart.csv"


CART_TRUTH = {"k_fwc": 26.0, "F_Kc": 7.0, "F_Sc": 10.5, "eta": 0.42}


def result_without_time(path):
    """A result file's content without its timings (fit.seconds and fit.uncertainty.seconds)
    and the date and command line of its provenance, the only fields that differ between
    runs (the command line names the run's own output file and worker count)."""
    import json

    document = json.loads(path.read_text())
    document["fit"].pop("seconds")
    if isinstance(document["fit"].get("uncertainty"), dict):
        document["fit"]["uncertainty"].pop("seconds", None)
    for key in ("date", "command"):
        document.get("provenance", {}).pop(key, None)
    return document


@pytest.fixture
def interrupt_costs(monkeypatch):
    """Counts the fit's cost evaluations (Residuals.sum_of_squares, in this process) in
    ``calls["n"]`` and raises KeyboardInterrupt, as Ctrl-C would, at ``calls["stop_at"]``."""
    from pendfmu.fitting.residuals import Residuals

    calls = {"n": 0, "stop_at": None}
    original = Residuals.sum_of_squares

    def counted(self, u):
        calls["n"] += 1
        if calls["n"] == calls["stop_at"]:
            raise KeyboardInterrupt
        return original(self, u)

    monkeypatch.setattr(Residuals, "sum_of_squares", counted)
    return calls
