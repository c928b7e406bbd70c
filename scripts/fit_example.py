"""Scripted fitting with the Python API: the same engine as `pendfmu fit`.

Makes a short current-step recording on the virtual rig, fits the current loop, prints
the estimates with their intervals, and writes the result, a report and exported FMUs.

    python scripts/fit_example.py [OUTPUT_FOLDER]
"""

from __future__ import annotations

import sys
from pathlib import Path

import pendfmu
from pendfmu.virtual_rig import Trial, steps, write_experiments


def main(out: Path) -> pendfmu.FitResult:
    out.mkdir(parents=True, exist_ok=True)
    experiment = Trial("current-step", "current", 0.012, 20e-6, ("I_c", "I"),
                            steps((0, 0.0), (1e-3, 2.5), (6e-3, 0.5)))
    write_experiments(out / "recordings", {"T_i": 0.45e-3, "dIdt_max": 2200.0}, seed=7, experiments=[experiment])

    result = pendfmu.fit("current", [out / "recordings" / "current-step.csv"], params={"T_i": 1e-3}, seed=1)
    for label, estimate in result.estimates.items():
        print(f"{label:10s} {estimate.value:.6g}  95 % interval {estimate.ci95}  {'; '.join(estimate.flags)}")
    result.write_json(out / "current.json")
    pendfmu.write_report(result, out / "report")
    pendfmu.export_result(result, out / "exported")
    return result


if __name__ == "__main__":
    main(Path(sys.argv[1] if len(sys.argv) > 1 else "out/fit-example"))
