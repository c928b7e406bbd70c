"""EMPS: a positioning stage under its own position loop, converted to a cart-stage
recording replayed open loop from the recorded controller output (``--drive I``).

The benchmark's model (Simulation_EMPS.m) is ``M ddq = gtau vir - Fv dq - Fc sign(dq) - OF``;
pendfmu's cart stage with no pendulum is ``m_c a = eta k_M k_D I - k_fwc v - F_Kc sign(v)``
(the paper's model, docs/user-guide/model.md; stiction F_Sc aside). :func:`benchmark` converts
one into the other.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pendfmu.recording import Recording, RecordingError, SignalInfo

from _common import REALDATA

EMPS_MAT = REALDATA / "EMPS" / "DATA_EMPS.mat"
EMPS_TRAVEL_PER_REV = 2.5e-3  # m per motor revolution on the load side (SOURCE.txt: 0.05 um per count, 50000 counts)
EMPS_K_D = 2 * math.pi / EMPS_TRAVEL_PER_REV
EMPS_RESOLUTION = 5e-8  # m, one encoder count on the load side
# Published IDIM-LS model (Simulation_EMPS.m): M ddq = gtau vir - Fv dq - Fc sign(dq) - OF
EMPS_PUBLISHED = {"M1": 95.1089, "Fv1": 203.5034, "Fc1": 20.3935, "OF1": -3.1648}
EMPS_START_SAMPLES = 20  # the benchmark's state initialization window (samples)


@dataclass(frozen=True)
class EmpsRecord:
    time: np.ndarray  # s
    qm: np.ndarray  # m, motor encoder on the load side
    vir: np.ndarray  # V, controller output
    gtau: float  # N/V


def read_emps(path: Path = EMPS_MAT) -> EmpsRecord:
    from scipy.io import loadmat

    data = loadmat(path)
    for name in ("t", "qm", "vir", "gtau"):
        if name not in data:
            raise RecordingError(f"{path}: no variable {name!r}")
    return EmpsRecord(np.ravel(data["t"]), np.ravel(data["qm"]), np.ravel(data["vir"]),
                      float(np.ravel(data["gtau"])[0]))


def emps_parameters(record: EmpsRecord | None = None) -> dict[str, float]:
    """The published gains and mass: m_c = M1, k_M k_D = gtau (35.15 N/V) with k_D from
    2.5 mm per revolution, no pendulum; the published friction as the start of the fit.
    eta is free: the published model has no efficiency (gtau already is the force per
    volt), so it should come out near 1, its physical limit."""
    record = record or read_emps()
    return {"m_c": EMPS_PUBLISHED["M1"], "m_p": 0.0, "k_D": EMPS_K_D, "k_M": record.gtau / EMPS_K_D,
            "k_fwc": EMPS_PUBLISHED["Fv1"], "F_Kc": EMPS_PUBLISHED["Fc1"]}


def emps_recording(record: EmpsRecord | None = None) -> Recording:
    """The identification record replayed open loop, as the benchmark does (u = vir,
    y = qm): a cart-stage recording driven by ``I`` = vir in volts, minus the published
    offset force OF1 expressed in volts (the stage has no constant force, and the
    published model subtracts it from the drive), fitted to ``x`` = qm, whose step is
    one encoder count (5e-8 m; every qm value is a multiple of it).

    The record starts in motion, and the cart stage takes its initial state from the
    sidecar: x0 and v0 from a quadratic fit of the first 20 samples (the benchmark's
    initialization window), evaluated at the first sample."""
    record = record or read_emps()
    n = EMPS_START_SAMPLES
    c = np.polyfit(record.time[:n] - record.time[0], record.qm[:n], 2)
    drive = record.vir - EMPS_PUBLISHED["OF1"] / record.gtau
    return Recording(EMPS_MAT.with_name("emps"), record.time, {"I": drive, "x": record.qm},
                     experiment="EMPS identification record, open loop from the controller output",
                     signal_info={"x": SignalInfo(EMPS_RESOLUTION)}, parameters={"m_p": 0.0},
                     initial={"x": float(c[2]), "v": float(c[1])})



STAGE = "cart"
SOURCES = (EMPS_MAT,)
OPTIONS = ("--drive", "I")  # the controller output drives the force directly
RUN_OPTIONS = ("--uncertainty", "jacobian")


def build() -> tuple[list[Recording], dict[str, float]]:
    record = read_emps()
    return [emps_recording(record)], emps_parameters(record)


def benchmark(parameters: dict[str, float]) -> dict[str, float]:
    """The fitted cart-stage parameters in the benchmark's terms and units.

    With I = vir - OF1/gtau (:func:`emps_recording`) and k_M k_D = gtau
    (:func:`emps_parameters`), the stage's equation divided by eta is

        (m_c/eta) a = gtau vir - OF1 - (k_fwc/eta) v - (F_Kc/eta) sign(v)

    which is the benchmark's model with

    * M = m_c / eta [kg] (m_c is fixed at the published M1, so eta carries the mass),
    * Fv = k_fwc / eta [N s/m],
    * Fc = F_Kc / eta [N],
    * offset = OF1 [N]: fixed at the published value, *not* fitted (the stage has no
      constant force; the conversion puts it into the drive).

    Stiction (F_Sc above F_Kc) has no counterpart in the benchmark and is left out.
    """
    eta = parameters["eta"]
    return {"M": parameters["m_c"] / eta, "Fv": parameters["k_fwc"] / eta, "Fc": parameters["F_Kc"] / eta,
            "offset": EMPS_PUBLISHED["OF1"]}
