"""Plain least squares against the quantization-aware cost on 10-bit pendulum data.

For several seeds: a free decay (30 s, 10-bit encoder) is recorded on the virtual rig,
and the pendulum stage is fitted with each cost; the relative errors of k_fwp and T_Kp
are printed, with their mean absolute value per cost. This measurement chose the default
cost (docs/user-guide/identification.md).

    python scripts/quantization_benchmark.py [--seeds 1 2 3]
"""

from __future__ import annotations

import argparse
import math
import tempfile
from pathlib import Path

import numpy as np

from pendfmu.fitting.identification import fit
from pendfmu.virtual_rig import reference_truth, standard_experiments, write_experiments

TRUTH = {"k_fwp": 0.9e-3, "T_Kp": 1.8e-3, "T_Sp": 3.5e-3}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    args = parser.parse_args()
    decay = [e for e in standard_experiments() if e.name == "pendulum-decay"]
    errors: dict[str, list[tuple[float, float]]] = {"plain": [], "quantized": []}
    for seed in args.seeds:
        with tempfile.TemporaryDirectory() as tmp:
            # the release angle varies with the seed, so the seeds differ in more than noise
            angle = math.pi + 0.4 + 0.1 * seed
            experiments = [type(decay[0])(**{**decay[0].__dict__, "truth_overrides": {"phi0": angle, "w0": 0.0}})]
            write_experiments(tmp, {**reference_truth(), **TRUTH}, seed=seed, experiments=experiments)
            known = {k: v for k, v in reference_truth().items() if k not in TRUTH}
            for cost in errors:
                result = fit("pendulum", [Path(tmp) / "pendulum-decay.csv"], known, seed=seed, cost=cost,
                             progress=False)
                k = result.parameters["k_fwp"] / TRUTH["k_fwp"] - 1
                t = result.parameters["T_Kp"] / TRUTH["T_Kp"] - 1
                errors[cost].append((k, t))
                print(f"seed {seed} {cost:9s}: k_fwp {k:+.4%}  T_Kp {t:+.4%}  ({result.seconds:.1f} s)")
    for cost, pairs in errors.items():
        mean = np.mean(np.abs(pairs), axis=0)
        print(f"{cost:9s} mean |error|: k_fwp {mean[0]:.4%}  T_Kp {mean[1]:.4%}")


if __name__ == "__main__":
    main()
