"""The ``pendfmu`` command line: ``main(argv)`` so tests call it in-process.

One module per subcommand, each with ``add_arguments(parser)`` and ``run(args)``.
Exit codes (a contract other tools script against): 0 success, 2 bad input (a one-line
message naming the file, column or value; no traceback), 1 internal failure, 3 warnings
under ``--strict`` (suspicious data: nothing fitted; a suspicious result: written).
"""

from __future__ import annotations

import argparse
import os
import sys
import traceback
from collections.abc import Sequence

from pendfmu.cli import build, check, demo, export, fit, report, rig, simulate, system
from pendfmu.errors import EXIT_BAD_INPUT, EXIT_MODEL_FAILED, EXIT_SUSPICIOUS, BadInput, FMUError, Suspicious

SUBCOMMANDS = {"build": build, "demo": demo, "rig": rig, "simulate": simulate, "fit": fit, "export": export,
               "system": system, "check": check, "report": report}


class _Parser(argparse.ArgumentParser):
    """argparse exits with 2 on bad usage already; keep its message to one line."""

    def error(self, message: str):  # noqa: D102
        self.exit(2, f"{self.prog}: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="pendfmu", description="Identify an inverted-pendulum rig with FMI component FMUs.")
    parser.add_argument("--debug", action="store_true", help="show tracebacks of internal failures")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    for name, module in SUBCOMMANDS.items():
        command = sub.add_parser(name, help=module.HELP, description=module.__doc__)
        module.add_arguments(command)
        command.set_defaults(run=module.run)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    args.command_line = ["pendfmu", *(sys.argv[1:] if argv is None else argv)]  # a result's provenance
    try:
        return args.run(args) or 0
    except BadInput as error:
        print(f"pendfmu {args.command}: error: {error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except Suspicious as error:
        print(f"pendfmu {args.command}: {error}", file=sys.stderr)
        return EXIT_SUSPICIOUS
    except FMUError as error:
        print(f"pendfmu {args.command}: the model failed: {error}", file=sys.stderr)
        return EXIT_MODEL_FAILED
    except KeyboardInterrupt:
        print(f"pendfmu {args.command}: interrupted", file=sys.stderr)
        return 130
    except Exception as error:  # an internal failure: say so, keep the details on demand
        print(f"pendfmu {args.command}: internal failure: {type(error).__name__}: {error}", file=sys.stderr)
        if args.debug or os.environ.get("PENDFMU_DEBUG"):
            traceback.print_exc()
        return 1
