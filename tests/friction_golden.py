"""Runs whose outputs must not change when the friction extras are added (all at 0).

Why: the extras are off by default so that the paper's model and every earlier result stay
bit-identical. `golden_runs()` exercises each path of the friction code (the Cart's exact
step and its RK4 path with stick-slip, the Pendulum's RK4 with reversals); the values it
gave before the extras existed are stored in friction_golden.json (written by running this
file as a script on the commit before them), and tests/test_friction_extras.py compares
today's outputs with them to the bit.
"""

from __future__ import annotations

import hashlib
import json
import math
from pathlib import Path

import numpy as np

from pendfmu.simulator import ComponentFMU

GOLDEN = Path(__file__).resolve().parent / "friction_golden.json"
EVERY = 50  # stored values: every 50th point of each signal (the hash covers them all)

FIG3 = dict(m_c=0.5, m_p=0.0, eta=1.0, k_M=1.0, k_D=1.0, k_fwc=2.0, F_Kc=0.3, F_Sc=0.8)
OMEGA = 2 * math.pi / 0.63


def _sine(t):
    return {"I": math.sin(OMEGA * t)}


def _sine_derivatives(t):
    return {"I": [OMEGA * math.cos(OMEGA * t), -OMEGA**2 * math.sin(OMEGA * t), -OMEGA**3 * math.cos(OMEGA * t)]}


def _pulse(t):
    return {"I": 2.0 if t < 0.25 - 1e-9 else 0.0}


def golden_runs() -> dict[str, dict[str, np.ndarray]]:
    """Each run's outputs by name: the stick-slip sine test (RK4), a start-stop pulse on
    the reference rig (exact steps), a pendulum's free decay (RK4 with reversals)."""
    runs = {}
    times = np.linspace(0.0, 2.0, 2001)
    with ComponentFMU("Cart", FIG3) as cart:
        runs["cart_sine"] = cart.run(times, ["x", "v", "a", "F_F", "mode", "t_mode"], inputs=_sine,
                                     derivatives=_sine_derivatives)
    times = np.linspace(0.0, 0.6, 601)
    with ComponentFMU("Cart", {"m_p": 0.0}) as cart:
        runs["cart_pulse"] = cart.run(times, ["x", "v", "a", "F_F", "mode", "t_mode"], inputs=_pulse)
    times = np.linspace(0.0, 5.0, 5001)
    with ComponentFMU("Pendulum", {"phi0": math.pi + 0.5}) as pendulum:
        runs["pendulum_decay"] = pendulum.run(times, ["phi", "w", "alpha", "T_F", "mode", "t_mode"],
                                              inputs=lambda t: {"a": 0.0})
    return runs


def fingerprint(runs: dict[str, dict[str, np.ndarray]]) -> dict:
    """Per run and signal: the sha256 of all its float64 bytes and every EVERY-th value
    (repr round-trips a double exactly, so a difference shows where and by how much)."""
    out = {}
    for run, signals in runs.items():
        out[run] = {name: {"sha256": hashlib.sha256(np.ascontiguousarray(values, dtype=np.float64).tobytes()).hexdigest(),
                           "samples": [float(v) for v in values[::EVERY]]}
                    for name, values in signals.items()}
    return out


if __name__ == "__main__":
    GOLDEN.write_text(json.dumps(fingerprint(golden_runs()), indent=1) + "\n")
    print(f"wrote {GOLDEN}")
