"""``make demo``: the paper's friction test (Fig. 3) and a pendulum free decay through fmpy.

Writes CSV files and PNG plots into an output folder and returns its path.
"""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")  # files only, no screen needed
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from pendfmu.simulator import ComponentFMU  # noqa: E402

FIG3_PERIOD = 0.63
FIG3_PARAMETERS = dict(m_c=0.5, m_p=0.0, eta=1.0, k_M=1.0, k_D=1.0, k_fwc=2.0, F_Kc=0.3, F_Sc=0.8)


def friction_test(step: float = 1e-3, stop: float = 2.0) -> pd.DataFrame:
    """Paper Fig. 3 through the Cart FMU: with eta = k_M = k_D = 1 the current is the force."""
    omega = 2 * math.pi / FIG3_PERIOD
    times = np.linspace(0.0, stop, int(round(stop / step)) + 1)
    with ComponentFMU("Cart", FIG3_PARAMETERS) as cart:
        result = cart.run(
            times, ["x", "v", "F_A", "F_F", "mode"],
            inputs=lambda t: {"I": math.sin(omega * t)},
            derivatives=lambda t: {"I": [omega * math.cos(omega * t), -omega**2 * math.sin(omega * t),
                                         -omega**3 * math.cos(omega * t)]},
        )
    return pd.DataFrame(result)


def pendulum_decay(phi0: float = math.pi + 0.5, stop: float = 30.0, step: float = 2e-4) -> pd.DataFrame:
    """Free damped swing of the reference pendulum, cart still, with the 10-bit reading."""
    times = np.linspace(0.0, stop, int(round(stop / step)) + 1)
    with ComponentFMU("Pendulum", {"phi0": phi0}) as pendulum:
        frame = pd.DataFrame(pendulum.run(times, ["phi", "w", "T_A", "mode"]))
    resolution = 2 * math.pi / 1024
    frame["phi_10bit"] = resolution * np.round(frame["phi"] / resolution)
    return frame


def _plot_friction(frame: pd.DataFrame, path: Path) -> None:
    fig, (top, bottom) = plt.subplots(2, 1, sharex=True, figsize=(8, 6))
    top.plot(frame["time"], frame["F_A"], label="active force F_A [N]")
    top.plot(frame["time"], frame["F_F"], label="friction F_F [N]")
    top.axhline(0.8, color="grey", lw=0.5, ls="--")
    top.axhline(-0.8, color="grey", lw=0.5, ls="--")
    top.legend(loc="upper right")
    top.set_title("Friction test (paper Fig. 3): 0.5 kg, F_S 0.8 N, F_K 0.3 N, k_fw 2 N.s/m")
    bottom.plot(frame["time"], frame["v"], label="speed v [m/s]")
    bottom.plot(frame["time"], frame["x"], label="position x [m]")
    stuck = frame["mode"] == 0
    bottom.fill_between(frame["time"], -0.3, 0.3, where=stuck, color="orange", alpha=0.2, label="stuck")
    bottom.set_xlabel("time [s]")
    bottom.legend(loc="upper right")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _plot_decay(frame: pd.DataFrame, path: Path) -> None:
    fig, (whole, zoom) = plt.subplots(2, 1, figsize=(8, 6))
    whole.plot(frame["time"], frame["phi"] - math.pi, lw=0.8, label="phi - pi [rad]")
    whole.set_title("Pendulum free decay: viscous + Coulomb + stiction (reference rig)")
    whole.legend(loc="upper right")
    late = frame["time"] > frame["time"].iloc[-1] * 0.6
    zoom.plot(frame["time"][late], frame["phi"][late] - math.pi, label="model")
    zoom.step(frame["time"][late], frame["phi_10bit"][late] - math.pi, where="post", label="10-bit encoder")
    zoom.set_xlabel("time [s]")
    zoom.legend(loc="upper right")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def rig_against_simulation(out: Path) -> list[Path]:
    """Record the coupled experiments on the virtual rig, simulate them from their
    recorded command current with the truth parameters, and plot one against the other."""
    from pendfmu.parameters import read_parameters
    from pendfmu.recording import read_recording
    from pendfmu.simulator.rig import simulate_recording
    from pendfmu.virtual_rig import standard_experiments, write_experiments

    rig_dir = out / "virtual-rig"
    chosen = [e for e in standard_experiments() if e.name in ("coupled-step", "bangbang-2")]
    write_experiments(rig_dir, seed=1, experiments=chosen)
    truth = read_parameters(rig_dir / "truth.json")
    plots = []
    for experiment in chosen:
        recording = read_recording(rig_dir / f"{experiment.name}.csv")
        simulated = simulate_recording(truth, recording)
        simulated.to_csv(out / f"{experiment.name}-simulated.csv", index=False, float_format="%.17g")
        fig, axes = plt.subplots(3, 1, sharex=True, figsize=(8, 7))
        for axis, name, unit in zip(axes, ("I", "x", "phi"), ("A", "m", "rad")):
            axis.step(recording.time, recording.signal(name), where="post", lw=0.8, label="recorded (virtual rig)")
            axis.plot(simulated["time"], simulated[name], lw=0.8, label="simulated (SSP rig, fmpy master)")
            axis.set_ylabel(f"{name} [{unit}]")
        axes[0].set_title(f"{experiment.name}: recorded vs simulated with the truth parameters")
        axes[0].legend(loc="lower right")
        axes[-1].set_xlabel("time [s]")
        fig.tight_layout()
        path = out / f"{experiment.name}.png"
        fig.savefig(path, dpi=120)
        plt.close(fig)
        plots.append(path)
    return plots


def run_demo(out: str | Path = "out/demo") -> Path:
    out = Path(out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    rig_against_simulation(out)
    friction = friction_test()
    friction.to_csv(out / "friction_test.csv", index=False)
    _plot_friction(friction, out / "friction_test.png")
    decay = pendulum_decay()
    decay.to_csv(out / "pendulum_decay.csv", index=False)
    _plot_decay(decay, out / "pendulum_decay.png")
    return out
