#!/usr/bin/env python3
"""Convert a published pendulum data set's own convention to pendfmu's recording format.

    python examples/convert_convention.py OUTDIR [PUBLISHED.csv PUBLISHED.json]

Published pendulum data rarely come in pendfmu's convention (its FORMAT.md: `pendfmu
format`). A typical set, and the one this script reads:

- PUBLISHED.csv: `t_ms` (milliseconds) and `theta_deg`, the angle from the *hanging*
  position in *degrees*, positive in the sense in which a cart pushed towards +x turns
  the pendulum (pendfmu's +phi);
- PUBLISHED.json: `{"m": kg, "a": pivot to centre of mass [m], "I_cm": inertia about the
  *centre of mass* [kg m^2], "b": viscous damping [N m s], "g": m/s^2, "counts": encoder
  counts per turn}`.

pendfmu's convention: time in seconds, `phi` from the *upward* vertical in radians
(hanging: pi), the inertia about the *pivot* (`J_p`) or, as published, about the centre of
mass under its own name `J_cm` (pendfmu adds m_p l^2). So the conversion is

    time = t_ms / 1000
    phi  = pi + radians(theta_deg)          (a sense opposite to +phi: pi - radians(...))
    sidecar: "parameters": {"m_p": m, "l": a, "J_cm": I_cm, "g": g}
             "signals": {"phi": {"resolution": 2 pi / counts}}

and OUTDIR/decay.csv + decay.json is a recording `pendfmu fit pendulum` reads as it is.
The published model's damping is viscous only: OUTDIR/params.json states no Coulomb
friction or stiction (T_Kp = T_Sp = 0), the start of a fit of the damping k_fwp (the
command is printed).

Without PUBLISHED files the script first makes its own (OUTDIR/published.csv, .json): a
free decay of such a pendulum integrated by scipy in the published convention (its own
equation, (I_cm + m a^2) theta'' = -m g a sin(theta) - b theta', not pendfmu's model),
printed as a 4000-count encoder's degrees to two decimals. tests/test_convert_convention.py
runs this and checks the converted recording against pendfmu's own Pendulum FMU.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np

PUBLISHED = {"m": 0.15, "a": 0.12, "I_cm": 2.0e-4, "b": 3.0e-4, "g": 9.81, "counts": 4000}
RELEASE_DEG = 40.0  # the made-up decay's release, degrees from hanging
DURATION_MS, SAMPLE_MS = 4000, 1


def make_published(folder: Path) -> tuple[Path, Path]:
    """A published-convention data set of a free decay (module docstring)."""
    from scipy.integrate import solve_ivp

    p = PUBLISHED
    pivot = p["I_cm"] + p["m"] * p["a"] ** 2

    def swing(_t, y):
        theta, rate = y
        return [rate, (-p["m"] * p["g"] * p["a"] * math.sin(theta) - p["b"] * rate) / pivot]

    t_ms = np.arange(0, DURATION_MS + SAMPLE_MS, SAMPLE_MS, dtype=float)
    solution = solve_ivp(swing, (0.0, t_ms[-1] / 1000), [math.radians(RELEASE_DEG), 0.0], t_eval=t_ms / 1000,
                         method="DOP853", rtol=1e-11, atol=1e-12)
    step_deg = 360.0 / p["counts"]
    degrees = np.round(np.degrees(solution.y[0]) / step_deg) * step_deg
    folder.mkdir(parents=True, exist_ok=True)
    csv, sidecar = folder / "published.csv", folder / "published.json"
    lines = ["t_ms,theta_deg", *(f"{t:.0f},{d:.2f}" for t, d in zip(t_ms, degrees))]
    csv.write_text("\n".join(lines) + "\n")
    sidecar.write_text(json.dumps(p, indent=1) + "\n")
    return csv, sidecar


def convert(csv: Path, sidecar: Path, folder: Path) -> Path:
    """The published files as a pendfmu recording (CSV + sidecar) in `folder`."""
    from pendfmu.recording import Recording, SignalInfo, write_recording

    published = json.loads(sidecar.read_text())
    table = np.loadtxt(csv, delimiter=",", skiprows=1, ndmin=2)
    time = table[:, 0] / 1000.0  # ms -> s
    phi = math.pi + np.radians(table[:, 1])  # from hanging, degrees -> from upright, rad
    parameters = {"m_p": published["m"], "l": published["a"], "J_cm": published["I_cm"], "g": published["g"]}
    recording = Recording(folder / "decay.csv", time, {"phi": phi},
                          experiment=f"free decay converted from {csv.name} (published convention)",
                          signal_info={"phi": SignalInfo(2 * math.pi / published["counts"])},
                          parameters=parameters)
    return write_recording(recording, folder / "decay.csv")


def fit_command(folder: Path) -> list[str]:
    """The fit of the converted decay's damping: viscous only, as the published model."""
    from pendfmu.parameters import write_parameters

    write_parameters({"T_Kp": 0.0, "T_Sp": 0.0}, folder / "params.json")
    return ["fit", "pendulum", str(folder / "decay.csv"), "--params", str(folder / "params.json"), "--fix", "T_Kp",
            "T_Sp", "--out", str(folder / "result.json")]


def main(argv: list[str]) -> int:
    if len(argv) not in (1, 3):
        print(__doc__.splitlines()[2].strip(), file=sys.stderr)
        return 2
    folder = Path(argv[0])
    csv, sidecar = (Path(argv[1]), Path(argv[2])) if len(argv) == 3 else make_published(folder)
    written = convert(csv, sidecar, folder)
    print(f"{written}: pendfmu's convention (phi from upright in rad, time in s, J_cm in the sidecar)")
    print("fit its damping: pendfmu " + " ".join(fit_command(folder)))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
