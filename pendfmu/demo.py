"""``make demo``: the paper's friction test (Fig. 3), a pendulum free decay, and the whole
identification on the virtual rig (record, fit all stages, report, export, predict).

Writes CSV files, PNG plots, an HTML report and exported FMUs into an output folder.
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


# The demo's rig: worn, with more friction than the reference rig (docs/user-guide/model.md),
# which the fit starts from.
DEMO_TRUTH = {"T_i": 0.4e-3, "dIdt_max": 2300.0, "eta": 0.37, "k_fwc": 36.0, "F_Kc": 9.5, "F_Sc": 14.0,
              "k_fwp": 1.4e-3, "T_Kp": 2.6e-3, "T_Sp": 5.0e-3, "a_h": 0.02, "f_h": 1900.0, "phase_h": 0.3}


def identify(out: Path) -> Path:
    """The paper's method end to end: record the experiments on the virtual rig, fit the
    stages in order from the reference values, write the result, its report and the
    exported FMUs, and plot the unfitted coupled recordings against their prediction."""
    from pendfmu.export import export_result
    from pendfmu.fitting.identification import fit
    from pendfmu.recording import read_recording
    from pendfmu.report import write_report
    from pendfmu.simulator.rig import simulate_recording
    from pendfmu.virtual_rig import write_experiments

    rig_dir = out / "virtual-rig"
    print(f"demo: recording the paper's experiments on a virtual rig with a worn truth ({rig_dir})", flush=True)
    write_experiments(rig_dir, DEMO_TRUTH, seed=1)
    print("demo: fitting current, cart and pendulum in turn from the reference rig's values, with bootstrap "
          "intervals (about a minute)", flush=True)
    result = fit("all", rig_dir, seed=1)
    result.write_json(out / "identified.json")
    print("demo: writing the report and the exported FMUs", flush=True)
    write_report(result, out / "report")
    export_result(result, out / "exported")
    for warning in result.warnings:
        print(f"warning: {warning}")
    held = write_truth_table(result, out / "identified-vs-truth.csv")
    print(f"demo: {sum(held.values())} of {len(held)} intervals hold the demo's truth"
          + ("" if all(held.values()) else f"; missed: {', '.join(n for n, ok in held.items() if not ok)}"))
    for name in ("coupled-step", "bangbang-2"):
        recording = read_recording(rig_dir / f"{name}.csv")
        predicted = simulate_recording(result.parameters, recording)
        fig, axes = plt.subplots(2, 1, sharex=True, figsize=(8, 5.5))
        for axis, signal, unit in zip(axes, ("x", "phi"), ("m", "rad")):
            axis.step(recording.time, recording.signal(signal), where="post", lw=1.6, color="0.7",
                      label="recorded (virtual rig)")
            axis.plot(predicted["time"], predicted[signal], lw=0.9, label="predicted by the identified model")
            axis.set_ylabel(f"{signal} [{unit}]")
        errors = result.validation.get(name, {})
        axes[0].set_title(f"{name} (not fitted): phi RMS error {errors.get('phi_rms_steps', float('nan')):.2f} "
                          f"encoder steps")
        axes[0].legend(loc="lower right")
        axes[-1].set_xlabel("time [s]")
        fig.tight_layout()
        fig.savefig(out / f"{name}-predicted.png", dpi=120)
        plt.close(fig)
    return out / "report" / "index.html"


def write_truth_table(result, path: Path) -> dict[str, bool]:
    """The identified values against the demo's truth, with each 95 % interval (or the
    set a parameter is only bounded to) and whether it holds the truth."""
    from pendfmu.virtual_rig import against_truth, reference_truth

    rows = against_truth(result.estimates, {**reference_truth(), **DEMO_TRUTH})
    with open(path, "w") as table:
        table.write("parameter,truth,identified,relative_error,low,high,method,holds_truth\n")
        for r in rows:
            table.write(f"{r.name},{r.truth!r},{r.value!r},{r.value / r.truth - 1:.3e},{r.low!r},{r.high!r},"
                        f"{r.method},{r.holds}\n")
    return {r.name: r.holds for r in rows}


def run_demo(out: str | Path = "out/demo") -> Path:
    out = Path(out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    print("demo: the paper's friction test (Fig. 3) and a 30 s pendulum decay through fmpy", flush=True)
    friction = friction_test()
    friction.to_csv(out / "friction_test.csv", index=False)
    _plot_friction(friction, out / "friction_test.png")
    decay = pendulum_decay()
    decay.to_csv(out / "pendulum_decay.csv", index=False)
    _plot_decay(decay, out / "pendulum_decay.png")
    identify(out)
    return out
