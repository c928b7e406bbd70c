"""Simulate the whole rig driven by a recording's command current I_c, or a user's FMU or
SSP system driven by the recording's columns (--fmu, --system).

Writes time and the outputs (the rig: I, x, v, a, phi, w; a model: every output) at the
recording's time stamps, as CSV or as a MATLAB .mat file (Simulink "Structure with time",
variable simout) by the suffix of --out. Initial states come from the parameters file
(x0, v0, phi0, w0), overridden by the recording sidecar's "initial".
"""

from __future__ import annotations

import argparse

HELP = "simulate the rig driven by a recording's I_c (or --fmu / --system driven by its columns)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--params", help='parameters file {"parameters": {...}} (absent names keep defaults)')
    parser.add_argument("--input", required=True, help="recording (CSV + sidecar, or .mat) with a column I_c")
    parser.add_argument("--out", required=True,
                        help="output file: .csv, or .mat (Simulink 'Structure with time' named simout)")
    parser.add_argument("--step", type=float, default=2e-4, help="communication step [s] (default 0.2 ms)")
    parser.add_argument("--interpolation", choices=("hold", "linear"), default="hold",
                        help="drives between samples: held (zero-order hold, default) or linear")
    model = parser.add_mutually_exclusive_group()
    model.add_argument("--fmu", metavar="X.fmu", help="simulate this FMU instead of the rig")
    model.add_argument("--system", metavar="S.ssp", help="simulate this SSP system instead of the rig")
    parser.add_argument("--drive", nargs="+", action="extend", metavar="INPUT[=COLUMN]",
                        help="with --fmu/--system: inputs driven by recorded columns (default: by equal names)")


def run(args: argparse.Namespace) -> int:
    from pendfmu.cli.outputs import check_output_file
    from pendfmu.errors import UsageError
    from pendfmu.parameters import read_parameters
    from pendfmu.recording import read_recording
    from pendfmu.recording.writer import check_output_path, write_signals
    from pendfmu.simulator.rig import simulate_recording

    if not args.step > 0:
        raise UsageError(f"--step {args.step}: the communication step must be positive")
    check_output_path(args.out)
    check_output_file(args.out, "--out")
    if args.fmu or args.system:
        result, used, columns = _simulate_model(args)
    else:
        if args.drive:
            raise UsageError("--drive is for --fmu/--system; the rig is driven by the recording's I_c")
        parameters = read_parameters(args.params) if args.params else {}
        recording = read_recording(args.input)
        result = simulate_recording(parameters, recording, step=args.step, interpolation=args.interpolation)
        used, columns = ["I_c"], list(recording.signals)
    write_signals(args.out, result["time"], {name: result[name] for name in result.columns[1:]})
    print(f"wrote {len(result)} samples of {', '.join(result.columns[1:])} to {args.out}")
    unused = [c for c in columns if c not in used]
    if unused:  # said, so that a column meant as a drive but misnamed does not pass unnoticed
        print(f"note: driven by {', '.join(used) or 'nothing'}; not used: {', '.join(unused)}")
    return 0


def _simulate_model(args: argparse.Namespace):
    """A user's FMU or SSP system driven by the recording, at the recording's time stamps
    (the model's own communication points: --step is the rig's); with the columns that
    drove it and all the recording's columns."""
    from pendfmu.fitting.models import checked_values, initial_map, mapping, read_for, simulate_model
    from pendfmu.simulator.model import Model
    from pendfmu.parameters import read_parameters

    model = Model.load(args.fmu or args.system)
    parameters = read_parameters(args.params, lambda values, where: checked_values(model, values, where)) \
        if args.params else {}
    drive = mapping(args.drive)
    columns = _csv_columns(args.input)
    (recording,) = read_for(model, [args.input], drive, None, initial_map(model, None), columns)
    used = sorted(set(drive.values())) if drive else [c for c in recording.signals if c in model.drive_names()]
    return simulate_model(model, recording, parameters, drive, args.interpolation), used, \
        columns or list(recording.signals)


def _csv_columns(path: str) -> list[str]:
    """The columns of a CSV recording's header besides time: a simulation drives the model's
    inputs from the columns named after them (or mapped by --drive) and leaves the others
    (the measured outputs a user compares the simulation with) alone, where a fit would
    refuse a name it does not know. Nothing for a .mat file."""
    from pathlib import Path

    from pendfmu.recording.csv_reader import signal_columns

    return signal_columns(Path(path)) if Path(path).suffix.lower() == ".csv" else []
