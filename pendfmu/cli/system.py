"""Write an SSP system of pendfmu's components and/or FMU files, wired by name.

    pendfmu system --out loop.ssp --component Controller Cart \\
        --connect Controller.u=Cart.I Cart.x=Controller.y --params loop.json

A component is NAME (one of pendfmu's components: CurrentLoop, Cart, Pendulum,
Controller) or NAME=FILE.fmu (any FMI 2.0 FMU). Parameters come from --params
({"parameters": {"Controller.K_p": ..., "m_c": ...}}, or the result file of a fit, whose
"parameters" are the values it ran with) and --set NAME=VALUE; a bare name sets the one
component that has it, or every one of pendfmu's components that has it (m_p and l of Cart
and Pendulum). A value of a pendfmu component the system does not hold, or of the
recordings (x_offset), is left out with a note (pendfmu/ssp/compose.py). The system then
runs with `pendfmu simulate --system` and fits with `pendfmu fit --system` (e.g. a
closed-loop recording through its controller).

Every component input no connection feeds becomes an input of the system (fmpy's
simulate_ssp needs that); --no-system-connectors leaves them out for ecos and libcosim."""

from __future__ import annotations

import argparse

HELP = "write an SSP system of components (pendfmu's or FMU files) wired by name"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--out", required=True, help="the SSP file to write (.ssp)")
    parser.add_argument("--component", nargs="+", action="extend", required=True, metavar="NAME[=FILE.fmu]",
                        help="a pendfmu component by name, or NAME=FILE.fmu")
    parser.add_argument("--connect", nargs="+", action="extend", default=[], metavar="A.output=B.input",
                        help="connections, output to input")
    parser.add_argument("--params", help='parameter values {"parameters": {"Component.name": value, ...}}, or the '
                                         'result file of a fit (pendfmu fit ... --out R.json)')
    parser.add_argument("--set", nargs="+", action="extend", default=[], metavar="NAME=VALUE",
                        help="parameter values (after --params)")
    parser.add_argument("--step", type=float, help="the system's communication step [s] (an annotation)")
    parser.add_argument("--name", default="System", help="the system's name")
    parser.add_argument("--no-system-connectors", action="store_true",
                        help="leave out the system's own inputs (every input no connection feeds) for ecos and "
                             "libcosim, which refuse connections to them")


def run(args: argparse.Namespace) -> int:
    import sys

    from pendfmu.cli.outputs import check_output_file
    from pendfmu.errors import UsageError
    from pendfmu.parameters import read_parameters
    from pendfmu.ssp import write_ssp
    from pendfmu.ssp.compose import compose

    out = check_output_file(args.out, "--out")
    if out.suffix.lower() != ".ssp":
        raise UsageError(f"--out {args.out}: an SSP file ends in .ssp")
    components = {}
    for item in args.component:
        name, _, source = item.partition("=")
        if name in components:
            raise UsageError(f"--component {name} appears twice")
        components[name] = source or name
    values: dict[str, object] = {}
    if args.params:  # a parameters file, or a result file of `pendfmu fit` (its "parameters")
        values.update(read_parameters(args.params, lambda given, where: dict(given)))
    for item in args.set:
        key, equals, text = item.partition("=")
        try:
            values[key] = float(text) if equals else None
        except ValueError:
            values[key] = None
        if values[key] is None:
            raise UsageError(f"--set {item!r}: expected NAME=NUMBER")
    system = compose(components, args.connect, values, name=args.name, step_size=args.step,
                     warn=lambda message: print(f"note: {message}", file=sys.stderr))
    print(write_ssp(system, out, system_connectors=not args.no_system_connectors))
    return 0
