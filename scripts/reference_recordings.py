"""The identification recordings of the virtual rig, simulated by the independent
reference simulator (tests/reference_rig.py) instead of pendfmu's FMUs.

Why: a fit judged on recordings made by the very FMUs it fits shares every numerical
choice of theirs (internal step, event location, input interpolation), so it cannot see
the bias those choices cause. Here the truth is simulated by a different code, written
apart from the FMUs (event-driven DOP853 at rtol 1e-10), and everything else is the
virtual rig's own: the same experiments (drive, duration, sample time, known initial
states, sidecar parameters), the same sensors (``virtual_rig.Sensors``), the same files
(``Recording`` + ``write_recording``, ``truth.json`` beside). With the same truth and
seed, the sensor noise is the same draw as ``virtual_rig.write_experiments`` makes, so
the two folders differ only by the simulator.

Drives: the FMUs see a command as its value at each sample held to the next sample
(``ComponentFMU.run`` and the master's ``ExternalInput(..., "hold")``); the reference
simulator gets exactly that staircase, with every change as a breakpoint where the
integration restarts (for the steps a handful, for the slow current ramp one per
sample). The rocking acceleration of ``pendulum-stiction`` is smooth: the FMU
interpolates it linearly with its slope per step, the reference evaluates the sine.
The measured current carries the PWM ripple; the cart is driven by the ripple-free
current (docs/user-guide/model.md), which the reference simulator does the same way.

    python scripts/reference_recordings.py --out DIR [--seed N]   # the six stage recordings
    python scripts/reference_recordings.py --compare              # FMU vs reference at the truth
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from pendfmu.parameters import write_parameters
from pendfmu.recording import Recording, write_recording
from pendfmu.virtual_rig import Trial, Sensors, reference_truth, simulate_truth, standard_experiments

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import reference_rig  # noqa: E402  (tests/ holds the independent simulator)

STAGE_EXPERIMENTS = ("current-steps", "cart-startup-2A", "cart-startup-3A", "cart-ramp",
                     "pendulum-decay", "pendulum-stiction")


def stage_experiments(release_angle: float | None = None) -> list[Trial]:
    """The virtual rig's experiments of the three fitted stages, in its order (so the
    sensor noise is drawn as write_experiments draws it); `release_angle` (rad from
    hanging) replaces the free decay's 0.6 rad."""
    experiments = [e for e in standard_experiments() if e.name in STAGE_EXPERIMENTS]
    if release_angle is not None:
        experiments = [dataclasses.replace(e, truth_overrides={"phi0": math.pi + release_angle, "w0": 0.0})
                       if e.name == "pendulum-decay" else e for e in experiments]
    return experiments


def sample_times(experiment: Trial) -> np.ndarray:
    """The sample times exactly as virtual_rig computes them."""
    return np.arange(int(round(experiment.duration / experiment.sample)) + 1) * experiment.sample


def held(times: np.ndarray, values: np.ndarray) -> reference_rig.Steps:
    """A sampled drive as the FMUs receive it: each sample held to the next. Only the
    samples where the value changes become steps (each is a restart of the reference
    integration)."""
    changes = np.concatenate([[0], np.flatnonzero(np.diff(values) != 0) + 1])
    return reference_rig.Steps(times[changes], values[changes], before=float(values[0]))


def reference_parameters(values: Mapping[str, float]) -> dict[str, float]:
    """The truth in the reference simulator's names (it knows every rig parameter; the
    FMU-only solver_step is dropped)."""
    known = set(reference_rig.DEFAULTS) | set(reference_rig.INITIAL_DEFAULTS)
    return {k: float(v) for k, v in values.items() if k in known}


def reference_signals(experiment: Trial, truth: Mapping[str, float]) -> dict[str, np.ndarray]:
    """The true signals of an experiment at its sample times, like
    ``virtual_rig.simulate_truth`` but by the reference simulator (stage experiments only).

    scipy's DOP853 error estimate divides 0 by 0 when its 5th-order error is exactly zero
    and the 3rd-order one a subnormal number (a stuck cart: only the current moves); the
    NaN rejects the step and a smaller one is taken, so only the warning is silenced."""
    with np.errstate(invalid="ignore"):
        return _reference_signals(experiment, truth)


def _reference_signals(experiment: Trial, truth: Mapping[str, float]) -> dict[str, np.ndarray]:
    values = reference_parameters({**truth, **experiment.truth_overrides, **experiment.sidecar_parameters})
    times = sample_times(experiment)
    command = np.array([experiment.drive(t) for t in times])
    if experiment.kind == "current":
        frame = reference_rig.simulate_current_loop(values, held(times, command), times, I0=values["I0"])
        return {"time": times, "I_c": command, "I": frame["I"].to_numpy()}
    if experiment.kind == "cart":
        if values["m_p"] != 0.0:
            raise ValueError(f"{experiment.name}: the cart experiments run without the pendulum (m_p = 0)")
        # m_p = J_p = 0: the reference leaves the pendulum out
        frame = reference_rig.simulate_rig({**values, "J_p": 0.0}, held(times, command), times)
        return {"time": times, "I_c": command, **{name: frame[name].to_numpy() for name in ("I", "x", "v")}}
    if experiment.kind == "pendulum":
        frame = reference_rig.simulate_pendulum(values, experiment.drive, times, phi0=values["phi0"],
                                                w0=values["w0"])
        # the commanded acceleration as the virtual rig records it (the reference evaluates
        # the drive just left of the last sample there)
        return {"time": times, "a": command, **{name: frame[name].to_numpy() for name in ("phi", "w")}}
    raise ValueError(f"{experiment.name}: kind {experiment.kind!r} is not a stage experiment")


def record(experiment: Trial, truth: Mapping[str, float], sensors: Sensors) -> Recording:
    """Simulate by the reference and read through the sensors: ``virtual_rig.record``
    with the other simulator (same signal order, so the same noise draws)."""
    true = reference_signals(experiment, truth)
    signals = {name: sensors.read(name, true[name]) for name in experiment.recorded}
    initial = {name: float(sensors.read(name, true[name][:1])[0]) if name in sensors.info() else float(true[name][0])
               for name in experiment.known_initial}
    info = {name: i for name, i in sensors.info().items() if name in signals}
    return Recording(path=Path(f"{experiment.name}.csv"), time=true["time"], signals=signals,
                     experiment=f"{experiment.name}: {experiment.description}", signal_info=info,
                     parameters=dict(experiment.sidecar_parameters), initial=initial)


def write_reference_experiments(out: str | Path, truth: Mapping[str, float] | None = None, seed: int = 0,
                                experiments: list[Trial] | None = None, **extra: object) -> list[Path]:
    """``virtual_rig.write_experiments`` by the reference simulator: the recordings,
    their sidecars and truth.json (with `extra` keys beside the seed)."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    values = {**reference_truth(), **(truth or {})}
    sensors = Sensors(values["k_D"], np.random.default_rng(seed))
    paths = [write_recording(record(e, values, sensors), out / f"{e.name}.csv")
             for e in (experiments or stage_experiments())]
    write_parameters(values, out / "truth.json", seed=seed, simulator="tests/reference_rig.py", **extra)
    return paths + [out / "truth.json"]


def disagreement(experiment: Trial, truth: Mapping[str, float]) -> dict[str, float]:
    """Max |FMU - reference| of each sensed signal at the truth, in sensor steps (the
    current in ADC steps), before noise and quantization."""
    values = {**reference_truth(), **truth}
    fmu, reference = simulate_truth(experiment, values), reference_signals(experiment, values)
    steps = {name: info.resolution for name, info in Sensors(values["k_D"], np.random.default_rng(0)).info().items()}
    return {name: float(np.max(np.abs(fmu[name] - reference[name]))) / steps[name]
            for name in experiment.recorded if name in steps}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, help="write the six stage recordings here")
    parser.add_argument("--seed", type=int, default=0, help="sensor noise seed")
    parser.add_argument("--compare", action="store_true",
                        help="print max |FMU - reference| per experiment at the reference truth, in sensor steps")
    args = parser.parse_args()
    if args.out:
        for path in write_reference_experiments(args.out, seed=args.seed):
            print(path)
    if args.compare:
        for experiment in stage_experiments():
            gaps = disagreement(experiment, reference_truth())
            print(f"{experiment.name:18s} " + "  ".join(f"{k}: {v:.3g} steps" for k, v in gaps.items()))
    if not (args.out or args.compare):
        parser.error("give --out DIR and/or --compare")


if __name__ == "__main__":
    main()
