"""Export parameters for other tools: parameterized FMUs, an SSP parameter values file and
Modelica modifiers for the PendulumID library.

Writes DIR/<Name>.fmu for each component one of the given parameters belongs to (or the
components named by --component; all three when the file gives no parameters), with the
new start values, a fresh GUID and the original binaries; DIR/parameters.ssv (SSP 1.0,
names like "Cart.k_fwc"); DIR/modifiers.mo (package PendfmuExport: component declarations
and a complete rig model). m_p = 0 (pendulum removed) exports no Pendulum.

With --fmu X.fmu (or --system S.ssp): DIR/<Name>.fmu, a copy of the user's FMU whose
model description carries the values as start values (binaries untouched, GUID kept), and
DIR/parameters.ssv (pendfmu/export/model.py says what the copy can and cannot do).
"""

from __future__ import annotations

import argparse
import sys

HELP = "write parameterized FMUs, an SSV file and Modelica modifiers"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from pendfmu.components import COMPONENTS

    parser.add_argument("--params", required=True, help='parameters file {"parameters": {...}}')
    parser.add_argument("--out", required=True, help="output directory (created if missing)")
    parser.add_argument("--component", action="append", choices=list(COMPONENTS), metavar="NAME",
                        help=f"export this component (repeatable; one of {', '.join(COMPONENTS)}); "
                             "default: every component a given parameter belongs to")
    model = parser.add_mutually_exclusive_group()
    model.add_argument("--fmu", metavar="X.fmu", help="export for this FMU (a copy with the values as start "
                                                      "values, and an SSV file) instead of pendfmu's components")
    model.add_argument("--system", metavar="S.ssp", help="export for the FMUs of this SSP system")


def run(args: argparse.Namespace) -> int:
    from pendfmu.export import plan_export, write_export
    from pendfmu.parameters import read_parameters

    if args.fmu or args.system:
        from pendfmu.export.model import export_model
        from pendfmu.fitting.models import checked_values, load_model

        model = load_model(args.fmu or args.system)
        values = read_parameters(args.params, lambda given, where: checked_values(model, given, where))
        for path in export_model(model, values, args.out, source=args.params):
            print(f"wrote {path}")
        return 0
    parameters = read_parameters(args.params)
    plan = plan_export(parameters, args.component, source=args.params)
    for name, why in plan.skipped.items():
        print(f"note: {name} not exported: {why}", file=sys.stderr)
    for note in plan.notes:
        print(f"note: {note}", file=sys.stderr)
    for path in write_export(plan, args.out):
        print(f"wrote {path}")
    return 0
