"""Export parameters for other tools: parameterized FMUs, the rig as SSP files, an SSP
parameter values file, Modelica modifiers for the PendulumID library and Simulink parameters.

--params is a parameters file {"parameters": {...}} or the result file of a fit (`pendfmu fit
... --out R.json`): its "parameters" are the values the fit ran with, fitted and known; the
initial states it estimated per recording ("initial", phi0[run1]) are the recordings', not
the rig's, and are not exported. A shared name (m_p, l) goes to every component that has it.

Writes DIR/<Name>.fmu (and DIR/fmi3/<Name>.fmu, its FMI 3.0 twin) for each component one of
the given parameters belongs to (or the components named by --component; all three when the
file gives no parameters), with the new start values, a fresh GUID and the original
binaries; DIR/parameters.ssv (SSP 1.0, names like "Cart.k_fwc"); DIR/modifiers.mo (package
PendfmuExport: component declarations and a complete rig model); DIR/set_parameters.m and
DIR/parameters.mat (the values for Simulink's FMU Import blocks: a MATLAB function that sets
them on the blocks of these FMUs, and the same values as MATLAB structs); and, when all
three rig components are exported, DIR/rig.ssp and DIR/rig-flat.ssp: the rig as SSP 1.0
archives with the system's own connectors (fmpy's simulate_ssp, `pendfmu simulate --system`)
and without (ecos, libcosim), as `pendfmu system [--no-system-connectors]` writes them
(pendfmu/export/rig.py). m_p = 0 (pendulum removed) exports no Pendulum.

With --fmu X.fmu (or --system S.ssp), or a result file of a fit of such a model (it names
the model): DIR/<Name>.fmu, a copy of the user's FMU whose model description carries the
values as start values (binaries untouched, GUID kept), DIR/parameters.ssv,
DIR/set_parameters.m and DIR/parameters.mat (pendfmu/export/model.py says what the copy can
and cannot do).

With --reference REF.csv [--input STIM.csv]: each written FMU whose variables name every
column of REF.csv also carries the reference results and the stimulus, in the layout of
FMI-LS-REF as the FMI standard's Reference FMUs ship it (extra/org.fmi-standard.fmi-ls-ref/:
fmi-ls-manifest.xml, <Model>_out.csv, <Model>_in.csv); `pendfmu check FMU` compares with them.
"""

from __future__ import annotations

import argparse
import sys

HELP = "write parameterized FMUs, the rig as SSP files, an SSV file, Modelica modifiers and Simulink parameters"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from pendfmu.components import COMPONENTS

    parser.add_argument("--params", required=True, help='parameters file {"parameters": {...}}, or the result file '
                                                        'of a fit (pendfmu fit ... --out R.json)')
    parser.add_argument("--out", required=True, help="output directory (created if missing)")
    parser.add_argument("--component", action="append", choices=list(COMPONENTS), metavar="NAME",
                        help=f"export this component (repeatable; one of {', '.join(COMPONENTS)}); "
                             "default: every component a given parameter belongs to")
    model = parser.add_mutually_exclusive_group()
    model.add_argument("--fmu", metavar="X.fmu", help="export for this FMU (a copy with the values as start "
                                                      "values, and an SSV file) instead of pendfmu's components")
    model.add_argument("--system", metavar="S.ssp", help="export for the FMUs of this SSP system")
    parser.add_argument("--reference", metavar="REF.csv", help="store these reference results (time first, columns "
                        "named like the FMU's variables) in each exported FMU they fit (FMI-LS-REF, extra/)")
    parser.add_argument("--input", metavar="STIM.csv", help="with --reference: the stimulus (time first, columns "
                        "named like the inputs) stored beside it")


def run(args: argparse.Namespace) -> int:
    from pendfmu.cli.outputs import check_output_folder
    from pendfmu.export import plan_export, write_export
    from pendfmu.parameters import read_parameters

    check_output_folder(args.out, "--out")
    if args.input and not args.reference:
        from pendfmu.errors import UsageError

        raise UsageError("--input needs --reference (the stimulus goes with reference results)")
    fitted_to = args.fmu or args.system or _fitted_model(args.params)
    if fitted_to:
        from pendfmu.export.model import export_model
        from pendfmu.fitting.models import checked_values
        from pendfmu.simulator.model import Model

        model = Model.load(fitted_to)
        values = read_parameters(args.params, lambda given, where: checked_values(model, given, where))
        for path in _with_references(export_model(model, values, args.out, source=args.params), args):
            print(f"wrote {path}")
        return 0
    parameters = read_parameters(args.params)
    plan = plan_export(parameters, args.component, source=args.params)
    for name, why in plan.skipped.items():
        print(f"note: {name} not exported: {why}", file=sys.stderr)
    for note in plan.notes:
        print(f"note: {note}", file=sys.stderr)
    for path in _with_references(write_export(plan, args.out), args):
        print(f"wrote {path}")
    return 0


def _fitted_model(params: str) -> str | None:
    """The user's FMU or SSP file a result file of `pendfmu fit --fmu/--system` was fitted to
    (its fit.model; None for a parameters file or a fit of pendfmu's rig): what to export for
    when neither --fmu nor --system names it."""
    from pathlib import Path

    from pendfmu.errors import UsageError
    from pendfmu.jsontext import parse_json

    try:
        fit = parse_json(Path(params).read_text()).get("fit")
    except (OSError, ValueError, AttributeError):
        return None  # read_parameters says what is wrong with the file
    model = fit.get("model") if isinstance(fit, dict) else None
    if model is None:
        return None
    if not Path(model).is_file():
        raise UsageError(f"--params {params}: fitted to {model}, which is not there; name the model with --fmu or "
                         f"--system")
    option = "--system" if model.lower().endswith(".ssp") else "--fmu"
    print(f"note: {params} was fitted to {model}: exporting for it (as {option} {model})", file=sys.stderr)
    return model


def _with_references(paths, args: argparse.Namespace) -> list[str]:
    """The written paths; with --reference the FMUs it fits carry it (said after their name)."""
    if not args.reference:
        return [str(p) for p in paths]
    from pendfmu.errors import UsageError
    from pendfmu.export.lsref import FOLDER, add_references, fits

    fmus = [p for p in paths if str(p).endswith(".fmu") and fits(p, args.reference)]
    if not fmus:
        raise UsageError(f"{args.reference}: its columns are not all variables of any exported FMU")
    for fmu in fmus:
        add_references(fmu, args.reference, args.input)
    return [f"{p} (with the reference results in {FOLDER}/)" if p in fmus else str(p) for p in paths]
