"""`pendfmu control`'s work: options checked, the design made from a fit result, and written.

design.json holds every number of the design (the FMU's parameters) and what it rests on;
report.md says in words what was designed: the model (self-locking axis or coupled), the
values assumed, the LQR's and the estimator's closed-loop poles (discrete, and as continuous
time constants), the limits.
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np

from pendfmu.atomic import write_atomically
from pendfmu.control.design import Design, Options, Weights, design
from pendfmu.control.export import fmu_parameters, write_fmus
from pendfmu.control.fromfit import rig_values, sidecar_resolutions
from pendfmu.control.plant import discretize
from pendfmu.errors import OptionError


def _positive(option: str, value: float | None) -> None:
    if value is not None and not (math.isfinite(value) and value > 0):
        raise OptionError(option, f"{value} must be a positive number")


def named_values(option: str, items: list[str], names, word: str) -> dict[str, float]:
    """Positive numbers from NAME=VALUE words, each name one of `names` (one line per fault)."""
    values = {}
    for item in items:
        name, _, text = item.partition("=")
        if name not in names:
            raise OptionError(option, f"{item!r}: the name must be one of {', '.join(names)} (NAME={word.upper()})")
        try:
            value = float(text)
        except ValueError:
            raise OptionError(option, f"{item!r}: the {word} {text!r} is not a number") from None
        if not (0.0 < value < math.inf):
            raise OptionError(option, f"{item!r}: must be a positive number")
        values[name] = value
    return values


def weights_from(items: list[str]) -> Weights:
    """Weights from NAME=SCALE words (--weights x=0.05 phi=0.01)."""
    return Weights(**named_values("weights", items, Weights.__dataclass_fields__, "scale"))


# --require's names -> verify.Requirements' fields
REQUIREMENT_NAMES = {"capture": "capture", "phi": "phi_steps", "x": "x_rms", "I": "I_rms", "track": "x_peak"}


def requirements_from(items: list[str]):
    """Requirements from NAME=VALUE words (--require x=0.005 I=0.5)."""
    from pendfmu.control.verify import Requirements

    given = named_values("require", items, REQUIREMENT_NAMES, "value")
    return Requirements(**{REQUIREMENT_NAMES[name]: value for name, value in given.items()})


def options_from(args, resolutions: dict[str, float]) -> Options:
    """The design's Options from the command line (checked, one line per fault)."""
    for option, value in (("sample_time", args.sample_time), ("current_limit", args.current_limit),
                          ("track", args.track), ("dx", args.dx), ("dphi", args.dphi)):
        _positive(option, value)
    return Options(task=args.task, T_s=args.sample_time, I_max=args.current_limit, x_max=args.track,
                   weights=weights_from(args.weights), compensation=not args.no_compensation,
                   dx=args.dx or resolutions.get("x"), dphi=args.dphi or resolutions.get("phi"))


def design_from_result(path: str, args) -> tuple[Design, dict[str, float], list[str]]:
    """The design for the fit result at `path`, the rig values it rests on and notes on what it assumed."""
    from pendfmu.fitting.result import read_result

    return design_from(read_result(path), args)


def design_from(result, args) -> tuple[Design, dict[str, float], list[str]]:
    """The design for a read fit result (design_from_result)."""
    values, assumed = rig_values(result)
    resolutions = sidecar_resolutions(result)
    options = options_from(args, resolutions)
    notes = [f"{name} = {values[name]:g}: not in the result, the reference rig's value" for name in assumed]
    notes += [f"encoder resolution of {name}: " + ("the sidecars" if name in resolutions else "the reference rig's encoders")
              for name in ("x", "phi") if getattr(args, "d" + name) is None]
    return design(values, options), values, notes


def closed_loop_poles(the_design: Design) -> dict[str, list[float]]:
    """The magnitudes of the balance loop's and the estimator's discrete poles, slowest first."""
    rig = the_design.rig
    A, B = rig.axis_linear() if the_design.axis else rig.linear()
    Phi, Gamma = discretize(A, B, the_design.T_s)
    loop = np.linalg.eigvals(Phi - Gamma @ np.array([the_design.K]))
    A_e, B_e = rig.linear()
    Phi_e, _ = discretize(A_e, B_e, the_design.T_s)
    C = np.zeros((2, 5))
    C[0, 0] = C[1, 2] = 1.0
    estimator = np.linalg.eigvals(Phi_e - Phi_e @ np.array(the_design.L) @ C)
    return {name: sorted((float(abs(p)) for p in poles), reverse=True)
            for name, poles in (("balance", loop), ("estimator", estimator))}


def report_text(the_design: Design, notes: list[str]) -> str:
    rig, poles = the_design.rig, closed_loop_poles(the_design)
    model = ("self-locking screw (eta = {:.3f} <= 0.5): the cart as an acceleration-commanded axis, its current "
             "from the identified cart model inverted".format(rig.eta) if the_design.axis else
             "back-drivable screw (eta = {:.3f}): the coupled cart and pendulum, the current as input".format(rig.eta))
    slowest = {name: -the_design.T_s / math.log(values[0]) for name, values in poles.items()}
    lines = ["# RigController design", "",
             f"- task: {'swing-up and balance' if the_design.swing_up else 'balance'}; T_s = {the_design.T_s:g} s; "
             f"current limit {the_design.I_max:g} A; track +-{the_design.x_max:g} m",
             f"- model: {model}",
             f"- friction compensation: {'on' if the_design.compensation else 'off'} (F_Kc = {rig.F_Kc:.3g} N, "
             f"breakaway {rig.F_Sc:.3g} N)",
             f"- LQR gains K (x, v, phi, w, drive): {', '.join(f'{k:.4g}' for k in the_design.K)}",
             f"- slowest balance pole |z| = {poles['balance'][0]:.5f} (time constant {slowest['balance']:.3g} s); "
             f"slowest estimator pole |z| = {poles['estimator'][0]:.5f} ({slowest['estimator']:.3g} s)",
             *(f"- {note}" for note in notes), ""]
    return "\n".join(lines)


def loop_connections(the_design: Design) -> list[str]:
    """The rig's wiring (pendfmu.ssp.rig: the pendulum fed back for a back-drivable screw) and
    the controller's: the encoders' x and phi in, its current command to the current loop."""
    from pendfmu.ssp.rig import BACK_DRIVE, DRIVE

    pairs = DRIVE + (BACK_DRIVE if the_design.rig.A > 0 else ())
    pairs += (("Cart.x", "RigController.x"), ("Pendulum.phi", "RigController.phi"),
              ("RigController.I_c", "CurrentLoop.I_c"))
    return [f"{start}={end}" for start, end in pairs]


def write_loop_ssp(the_design: Design, values: dict[str, float], out: Path, built: bool = True) -> Path:
    """out/ClosedLoop.ssp: the identified rig's FMUs (pendfmu's components with the fit's
    values) and out/RigController.fmu (`built`: written by write_fmus; else pendfmu's own,
    the reference rig's design), sampled at T_s; its free input is x_ref. The pendulum starts
    hanging for swing-up, 0.1 rad from upright for balance (Pendulum.phi0)."""
    from pendfmu.components import COMPONENTS
    from pendfmu.ssp.archive import write_ssp
    from pendfmu.ssp.compose import compose

    given = {f"{component}.{name}": values[name] for component, table in COMPONENTS.items()
             for name in table.parameters if name in values}
    given["Pendulum.phi0"] = math.pi if the_design.swing_up else 0.1
    parts = {name: name for name in COMPONENTS} | {"RigController": out / "RigController.fmu" if built
                                                   else "RigController"}
    system = compose(parts, loop_connections(the_design), given, name="ClosedLoop", step_size=the_design.T_s,
                     description="The identified rig in closed loop with the RigController designed from its fit")
    return write_ssp(system, out / "ClosedLoop.ssp")


def write_outputs(the_design: Design, values: dict[str, float], notes: list[str], out: Path,
                  weights: Weights | None = None) -> list[Path]:
    """The two FMUs, the closed loop's SSP, design.json and report.md in `out`; design.json
    names the LQR `weights` the design was made with (a tuning's, to design with again)."""
    out.mkdir(parents=True, exist_ok=True)
    paths = write_fmus(the_design, out)
    paths.append(write_loop_ssp(the_design, values, out))
    document = {"parameters": fmu_parameters(the_design), "notes": notes, "poles": closed_loop_poles(the_design)}
    if weights is not None:
        document["weights"] = dataclasses.asdict(weights)
    paths.append(write_atomically(out / "design.json", json.dumps(document, indent=2) + "\n"))
    paths.append(write_atomically(out / "report.md", report_text(the_design, notes)))
    return paths


def verification_text(checked) -> str:
    """report.md's section on the closed-loop verification (verify.py): a row per task and
    compensation, the identified model's figures and the replicates' success rate and worst."""
    from pendfmu.control.verify import WINDOW

    req = checked.requirements
    track = req.x_peak if req.x_peak is not None else checked.track
    rows = checked.summary()
    lines = ["## Verification in closed loop", "",
             f"Requirements: capture within {req.capture:g} s; over the last {WINDOW:g} s (half the run if shorter): RMS phi <= "
             f"{req.phi_steps:g} encoder step(s), RMS x <= {1000 * req.x_rms:g} mm, RMS I_c <= {req.I_rms:g} A; "
             f"|x| <= {1000 * track:g} mm throughout. {len(checked.outcomes)} runs in {checked.seconds:.1f} s.", "",
             "| task | compensation | rig | capture [s] | RMS phi [steps] | RMS x [mm] | RMS I_c [A] | max abs x [mm] "
             "| meets |", "|---|---|---|---|---|---|---|---|---|"]
    for row in rows:
        on = "on" if row["compensation"] else "off"
        lines.append(_figures_row(row["task"], on, "identified", row["identified"],
                                  "yes" if row["identified"]["meets"] else "NO"))
        if row["replicates"]:
            lines.append(_figures_row(row["task"], on, f"worst of {row['replicates']} replicates",
                                      row["worst_replicate"],
                                      f"{row['replicates_meeting']} of {row['replicates']}"))
    if not any(row["replicates"] for row in rows):
        lines += ["", "The result holds no bootstrap replicates (its intervals are Jacobian or sandwich ones, or "
                      "it was written before pendfmu kept them): verified on the identified model only."]
    lines += ["", "![closed loop](verification.png)", ""]
    return "\n".join(lines)


def _figures_row(task: str, compensation: str, rig: str, figures: dict, meets: str) -> str:
    capture = "not caught" if figures["capture"] is None else f"{figures['capture']:.2f}"
    cells = [_cell(figures["phi_steps"]), _cell(figures["x_rms"], 1000), _cell(figures["I_rms"]),
             _cell(figures["x_peak"], 1000)]
    return f"| {task} | {compensation} | {rig} | {capture} | {' | '.join(cells)} | {meets} |"


def _cell(value: float | None, scale: float = 1.0) -> str:
    return "-" if value is None else f"{scale * value:.3g}"


def plot_verification(checked, path: Path) -> Path:
    """phi and x over time for every run with the design's compensation: the identified model
    bold, the replicates thin; a panel per task."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    groups = {task: [o for o in checked.outcomes if o.run.task == task and o.signals
                     and o.run.compensation == checked.outcomes[0].run.compensation]
              for task in dict.fromkeys(o.run.task for o in checked.outcomes)}
    figure, axes = plt.subplots(2, len(groups), figsize=(6 * len(groups), 6), squeeze=False, sharex="col")
    for column, (task, outcomes) in enumerate(groups.items()):
        for outcome in sorted(outcomes, key=lambda o: o.run.rig == "identified"):
            bold = outcome.run.rig == "identified"
            style = dict(color="k" if bold else "tab:blue", lw=1.5 if bold else 0.5, alpha=1.0 if bold else 0.4)
            time = np.asarray(outcome.signals["time"])
            angle = np.mod(np.asarray(outcome.signals["phi"]) + math.pi, 2 * math.pi) - math.pi
            angle[1:][np.abs(np.diff(angle)) > math.pi] = np.nan  # no line across a wrap at +-pi
            axes[0, column].plot(time, angle, **style)
            axes[1, column].plot(time, 1000 * np.asarray(outcome.signals["x"]), **style)
        axes[0, column].set_title(f"{task}: identified model (black), replicates (blue)")
        axes[0, column].set_ylabel("phi from upright [rad]")
        axes[1, column].set_ylabel("x [mm]")
        axes[1, column].set_xlabel("time [s]")
    figure.tight_layout()
    figure.savefig(path, dpi=90)
    plt.close(figure)
    return path


def write_verification(checked, the_design: Design, notes: list[str], out: Path) -> list[Path]:
    """verification.json, verification.png and report.md with the verification's section."""
    document = json.dumps(checked.to_dict(), indent=2, allow_nan=False) + "\n"
    paths = [write_atomically(out / "verification.json", document), plot_verification(checked, out / "verification.png")]
    paths.append(write_atomically(out / "report.md", report_text(the_design, notes) + "\n" + verification_text(checked)))
    return paths
