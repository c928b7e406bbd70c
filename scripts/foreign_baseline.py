"""The baseline of issue 13's benchmark: a hand-written scipy fit over fmpy's FMU2Slave.

Issue 13 opens pendfmu's fitting engine to any FMU and measures it against what a
competent user writes without pendfmu. This is that code, written plainly and not slowed
down on purpose: one FMU2Slave instance of ForeignCart.fmu, reset for every evaluation,
the six parameters (k_u, c_v, F_c, F_s, v_s, F_0) set by value reference, the voltage
held per sample with FMU2Slave's high-level setReal/doStep/getReal, residuals = simulated
x - recorded x at the samples of the three fit recordings, scipy's `least_squares` (trf,
finite differences, bounds that keep the FMU's parameters physical). The FMU runs with its
default internal step, one RK4 step per 1 ms sample (h_max 1 ms, as a fixed-step export at
its sample time); the recordings were made with 10 µs.

It prints the wall time, the number of simulations, each parameter's relative error
against the truth, and the prediction error on the fourth recording in encoder steps.

    python scripts/foreign_baseline.py [FOLDER]     (FMU and recordings go there; default a temporary folder)

`run_baseline(folder)` does the same and returns the figures (tests/test_foreign_fmus.py).
"""

from __future__ import annotations

import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
from scipy.optimize import least_squares

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from foreign.build import build  # noqa: E402
from foreign.recordings import FIT_NAMES, FITTED, PREDICTION_NAME, RESOLUTION, TRUTH, write_recordings  # noqa: E402

START_FACTORS = {"k_u": 1.3, "c_v": 0.7, "F_c": 1.3, "F_s": 0.7, "v_s": 1.3, "F_0": 0.7}
"""The fit starts at the truth times these factors (30 % off, both ways)."""

LOWER = {"k_u": 0.0, "c_v": 0.0, "F_c": 0.0, "F_s": 0.0, "v_s": 1e-4, "F_0": -np.inf}


class Cart:
    """One FMU2Slave instance of ForeignCart; `run` resets it and simulates one recording."""

    def __init__(self, fmu: Path):
        description = read_model_description(str(fmu))
        self.vr = {v.name: v.valueReference for v in description.modelVariables}
        self.unzipped = extract(str(fmu))
        self.slave = FMU2Slave(guid=description.guid, unzipDirectory=self.unzipped,
                               modelIdentifier=description.coSimulation.modelIdentifier, instanceName="baseline")
        self.slave.instantiate()
        self.runs = 0

    def run(self, parameters: dict[str, float], t: np.ndarray, u: np.ndarray) -> np.ndarray:
        slave, vr_u, vr_x = self.slave, [self.vr["u"]], [self.vr["x"]]
        slave.reset()
        slave.setReal([self.vr[name] for name in parameters], list(parameters.values()))
        slave.setupExperiment(startTime=t[0])
        slave.enterInitializationMode()
        slave.exitInitializationMode()
        x = np.empty(len(t))
        x[0] = slave.getReal(vr_x)[0]
        for k in range(len(t) - 1):
            slave.setReal(vr_u, [u[k]])
            slave.doStep(t[k], t[k + 1] - t[k])
            x[k + 1] = slave.getReal(vr_x)[0]
        self.runs += 1
        return x

    def close(self):
        self.slave.terminate()
        self.slave.freeInstance()
        shutil.rmtree(self.unzipped, ignore_errors=True)


def load(csv: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(time, u, x) of a recording; plain lists of floats are what FMU2Slave takes fastest."""
    data = pd.read_csv(csv)
    return data["time"].to_numpy(), data["u"].to_numpy(), data["x"].to_numpy()


def fit(fmu: Path, fit_csvs: list[Path], start: dict[str, float], known: dict[str, float]) -> dict:
    """least_squares over the fit recordings; returns the estimates and the counts."""
    cart = Cart(fmu)
    recordings = [tuple(a.tolist() for a in load(csv)) for csv in fit_csvs]
    recorded = np.concatenate([np.asarray(x[1:]) for _, _, x in recordings])
    evaluations = 0

    def residuals(theta: np.ndarray) -> np.ndarray:
        nonlocal evaluations
        evaluations += 1
        parameters = {**known, **dict(zip(FITTED, theta.tolist()))}
        simulated = [cart.run(parameters, t, u)[1:] for t, u, _ in recordings]
        return np.concatenate(simulated) - recorded

    began = time.perf_counter()
    try:
        solution = least_squares(residuals, [start[p] for p in FITTED], method="trf",
                                 bounds=([LOWER[p] for p in FITTED], np.inf))
    finally:
        seconds = time.perf_counter() - began
        runs = cart.runs
        cart.close()
    return {"estimate": dict(zip(FITTED, solution.x.tolist())), "seconds": seconds, "evaluations": evaluations,
            "simulations": runs, "nfev": solution.nfev, "status": solution.status, "message": solution.message,
            "cost": float(solution.cost)}


def prediction_rms_steps(fmu: Path, csv: Path, parameters: dict[str, float]) -> float:
    """RMS of simulated - recorded x on a recording, in encoder steps."""
    cart = Cart(fmu)
    try:
        t, u, x = (a.tolist() for a in load(csv))
        return float(np.sqrt(np.mean((cart.run(parameters, t, u) - np.asarray(x)) ** 2)) / RESOLUTION)
    finally:
        cart.close()


def run_baseline(folder: str | Path) -> dict:
    """Build ForeignCart and the recordings in `folder`, fit from the start, and return the
    figures: wall time, simulations, relative errors, prediction RMS in encoder steps."""
    folder = Path(folder)
    fmu = build("ForeignCart", folder)
    csvs = write_recordings(fmu, folder / "recordings")
    known = {"m": TRUTH["m"]}
    start = {p: TRUTH[p] * START_FACTORS[p] for p in FITTED}
    result = fit(fmu, [csvs[name] for name in FIT_NAMES], start, known)
    estimate = {**known, **result["estimate"]}
    result["start"] = start
    result["relative_error"] = {p: result["estimate"][p] / TRUTH[p] - 1.0 for p in FITTED}
    result["prediction_rms_steps"] = prediction_rms_steps(fmu, csvs[PREDICTION_NAME], estimate)
    result["truth_prediction_rms_steps"] = prediction_rms_steps(fmu, csvs[PREDICTION_NAME], TRUTH)
    return result


def main(folder: Path | None = None) -> dict:
    with tempfile.TemporaryDirectory(prefix="foreign-baseline-") as temporary:
        result = run_baseline(folder or temporary)
    print(f"wall time {result['seconds']:.1f} s, {result['simulations']} simulations "
          f"({result['evaluations']} residual evaluations of {len(FIT_NAMES)} recordings), "
          f"least_squares status {result['status']}: {result['message']}")
    for p in FITTED:
        print(f"  {p:4s} start {result['start'][p]:<8.4g} estimate {result['estimate'][p]:<12.6g} "
              f"truth {TRUTH[p]:<6g} relative error {100 * result['relative_error'][p]:+.3f} %")
    print(f"prediction RMS on {PREDICTION_NAME}: {result['prediction_rms_steps']:.3f} encoder steps "
          f"(the truth itself: {result['truth_prediction_rms_steps']:.3f}, quantization alone ~0.29)")
    return result


if __name__ == "__main__":
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else None)
