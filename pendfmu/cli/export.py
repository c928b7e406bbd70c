"""Export parameters for other tools: parameterized FMUs, an SSP parameter values file and
Modelica modifiers for the PendulumID library.

Writes DIR/<Name>.fmu for each component one of the given parameters belongs to (or the
components named by --component; all three when the file gives no parameters), with the
new start values, a fresh GUID and the original binaries; DIR/parameters.ssv (SSP 1.0,
names like "Cart.k_fwc"); DIR/modifiers.mo (package PendfmuExport: component declarations
and a complete rig model). m_p = 0 (pendulum removed) exports no Pendulum.
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


def run(args: argparse.Namespace) -> int:
    from pendfmu.export import plan_export, write_export
    from pendfmu.parameters import read_parameters

    parameters = read_parameters(args.params)
    plan = plan_export(parameters, args.component, source=args.params)
    for name, why in plan.skipped.items():
        print(f"note: {name} not exported: {why}", file=sys.stderr)
    for note in plan.notes:
        print(f"note: {note}", file=sys.stderr)
    for path in write_export(plan, args.out):
        print(f"wrote {path}")
    return 0
