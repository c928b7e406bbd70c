"""Recordings of the foreign cart (ForeignCart.fmu) for the issue-13 fit and benchmark.

A known truth of ForeignCart (`TRUTH`: a 2 kg cart, 4 N/V, Stribeck stiction) is simulated
with fmpy's FMU2Slave in a plain Python loop, the voltage held over each 1 ms sample and a
fine internal step (`TRUTH_H_MAX` = 10 µs, ten times finer than the FMU's default, so the
truth is not the fit's own discretization). The position is quantized like an encoder of
`RESOLUTION` = 10 µm (rounding). Three voltage profiles are for fitting -- steps, a slow
ramp through breakaway in both directions, reversals -- and a fourth, different one (a
seeded random staircase) is for prediction.

Files: `<name>.csv` with the columns ``time, u, x`` (u[k] is the voltage held over
[time[k], time[k+1])) and the sidecar `<name>.json` in pendfmu's recording format (the
encoder resolution and quantizer, the known mass, the initial state).

pendfmu reads them with the model's names (``pendfmu fit --fmu ForeignCart.fmu ...``);
`read_recording` without the model refuses the column ``u`` and the parameter ``m``, which
are not the rig's (docs/user-guide/model.md). `read` reads them without pendfmu (pandas, json).

    python tests/foreign/recordings.py FMU OUT_DIR      (writes the four recordings)
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave

TRUTH = {"m": 2.0, "k_u": 4.0, "c_v": 8.0, "F_c": 3.0, "F_s": 5.0, "v_s": 0.02, "F_0": 0.5}
"""The cart the recordings come from; m is known (weighed), the other six are fitted."""

FITTED = ("k_u", "c_v", "F_c", "F_s", "v_s", "F_0")
"""The parameters a fit estimates, in this order."""

INITIAL = {"x0": 0.0, "v0": 0.0}
"""Every recording starts at rest at x = 0."""

SAMPLE_PERIOD = 1e-3
RESOLUTION = 1e-5
TRUTH_H_MAX = 1e-5
PREDICTION_SEED = 13

FIT_NAMES = ("fit_steps", "fit_ramp", "fit_reversals")
PREDICTION_NAME = "predict_staircase"


def _grid(duration: float) -> np.ndarray:
    return np.arange(round(duration / SAMPLE_PERIOD) + 1) * SAMPLE_PERIOD


def _held(time: np.ndarray, changes: list[tuple[float, float]]) -> np.ndarray:
    """Piecewise-constant voltage: (start time, level) pairs, the first at t = 0."""
    u = np.zeros_like(time)
    for start, level in changes:
        u[time >= start - 1e-12] = level
    return u


def voltage_profiles() -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """{name: (time, u)} of the four recordings. Breakaway needs u > 1.125 V forward and
    u < -1.375 V backward (|k_u u + F_0| > F_s); the speeds stay below 0.8 m/s and the
    travel within about +-0.5 m, like a lab track."""
    profiles = {}
    t = _grid(2.0)
    profiles["fit_steps"] = (t, _held(t, [(0.0, 0.0), (0.1, 2.0), (0.5, 0.0), (0.8, -2.2), (1.2, 1.0),
                                          (1.4, 2.6), (1.6, 0.6), (1.75, -1.6)]))
    t = _grid(4.0)  # 0 -> 1.6 V in 1.5 s, down to -1.8 V at 3.2 s, back to 0 at 4 s
    profiles["fit_ramp"] = (t, np.interp(t, [0.0, 1.5, 3.2, 4.0], [0.0, 1.6, -1.8, 0.0]))
    t = _grid(2.0)  # a 1.5 Hz sine, then a 2.5 Hz square wave
    sine = 2.2 * np.sin(2 * np.pi * 1.5 * t)
    square = np.where(np.floor((t - 1.2) / 0.2) % 2 == 0, 2.0, -2.0)
    profiles["fit_reversals"] = (t, np.where(t < 1.2, sine, square))
    t = _grid(2.5)
    rng = np.random.default_rng(PREDICTION_SEED)
    starts = np.cumsum(rng.uniform(0.08, 0.3, size=40))
    changes = [(0.0, 0.0)] + [(float(s), float(rng.uniform(-2.5, 2.5))) for s in starts if s < 2.5]
    profiles[PREDICTION_NAME] = (t, _held(t, changes))
    return profiles


def simulate(fmu: str | Path, parameters: dict[str, float], time: np.ndarray, u: np.ndarray,
             h_max: float = TRUTH_H_MAX) -> np.ndarray:
    """Position x at every time stamp, from one FMU2Slave instance; u[k] held over
    [time[k], time[k+1]). Parameters are set by the value references the model
    description gives for their names."""
    description = read_model_description(str(fmu))
    vr = {v.name: v.valueReference for v in description.modelVariables}
    unzipped = extract(str(fmu))
    slave = FMU2Slave(guid=description.guid, unzipDirectory=unzipped,
                      modelIdentifier=description.coSimulation.modelIdentifier, instanceName="truth")
    try:
        slave.instantiate()
        values = {**INITIAL, **parameters, "h_max": h_max}
        slave.setReal([vr[name] for name in values], list(values.values()))
        slave.setupExperiment(startTime=float(time[0]))
        slave.enterInitializationMode()
        slave.exitInitializationMode()
        x = np.empty(len(time))
        x[0] = slave.getReal([vr["x"]])[0]
        for k in range(len(time) - 1):
            slave.setReal([vr["u"]], [float(u[k])])
            slave.doStep(float(time[k]), float(time[k + 1] - time[k]))
            x[k + 1] = slave.getReal([vr["x"]])[0]
        slave.terminate()
    finally:
        slave.freeInstance()
        shutil.rmtree(unzipped, ignore_errors=True)
    return x


def quantize(x: np.ndarray) -> np.ndarray:
    """What the encoder reads: RESOLUTION * round(x / RESOLUTION)."""
    return RESOLUTION * np.rint(x / RESOLUTION)


def write_recordings(fmu: str | Path, out_dir: str | Path) -> dict[str, Path]:
    """Simulate the truth for every profile and write `<name>.csv` and `<name>.json` into
    `out_dir`; returns {name: csv path} (the three fit recordings first)."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = {}
    for name, (time, u) in voltage_profiles().items():
        x = quantize(simulate(fmu, TRUTH, time, u))
        path = out_dir / f"{name}.csv"
        lines = ["time,u,x"] + [f"{t!r},{uk!r},{xk!r}" for t, uk, xk in zip(time.tolist(), u.tolist(), x.tolist())]
        path.write_text("\n".join(lines) + "\n")
        sidecar = {"experiment": f"ForeignCart {name}",
                   "comment": "u[k] is held over [time[k], time[k+1]); written by tests/foreign/recordings.py",
                   "signals": {"x": {"resolution": RESOLUTION, "quantizer": "round"}},
                   "parameters": {"m": TRUTH["m"]},
                   "initial": {"x": INITIAL["x0"], "v": INITIAL["v0"]}}
        path.with_suffix(".json").write_text(json.dumps(sidecar, indent=2) + "\n")
        paths[name] = path
    return paths


def read(path: str | Path) -> tuple[pd.DataFrame, dict]:
    """A recording written by `write_recordings`: (the CSV as a DataFrame, the sidecar)."""
    path = Path(path)
    return pd.read_csv(path), json.loads(path.with_suffix(".json").read_text())


if __name__ == "__main__":
    import sys

    for written in write_recordings(sys.argv[1], sys.argv[2]).values():
        print(written)
