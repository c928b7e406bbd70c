"""The ``pendfmu`` command line: ``main(argv)`` so tests call it in-process.

One module per subcommand, each with ``add_arguments(parser)`` and ``run(args)``.
Exit codes (a contract other tools script against): 0 success, 2 bad input (a one-line
message naming the file, column or value; no traceback), 1 internal failure, 3 warnings
under ``--strict`` (suspicious data: nothing fitted; a suspicious result: written), 4 the
model failed (an FMU refused a value or a step), 5 the FMUs cannot be built here, 6 the
worker processes or the Dask cluster failed the work (killed, every worker lost).
"""

from __future__ import annotations

import argparse
import os
import sys
import textwrap
import traceback
from collections.abc import Sequence

from pendfmu import __version__
from pendfmu.cli import build, check, control, demo, export, fit, laws, recording_format, report, rig, simulate, system
from pendfmu.cli.argv import command_options, untangle
from pendfmu.errors import (EXIT_BAD_INPUT, EXIT_BUILD_FAILED, EXIT_MODEL_FAILED, EXIT_SUSPICIOUS, EXIT_WORKERS_FAILED,
                            BadInput, BuildError, FMUError, OptionError, Suspicious, WorkersFailed)
from pendfmu.suggest import did_you_mean

SUBCOMMANDS = {"build": build, "demo": demo, "rig": rig, "simulate": simulate, "fit": fit, "laws": laws,
               "export": export, "system": system, "check": check, "report": report, "format": recording_format,
               "control": control}


# Words a subcommand takes as positionals, so that a list option before them stops there
# (cli/argv.py): `fit cart --fix eta rec.csv` keeps rec.csv a recording.
POSITIONAL_WORDS = {"fit": fit.STAGE_NAMES, "laws": laws.STAGE_NAMES}


class HelpFormatter(argparse.HelpFormatter):
    """A command's description as its docstring has it, for a terminal: prose paragraphs
    wrapped to the width, example lines (indented by four spaces) kept whole on their own
    lines, and the docstring's markup (``name``, `name`) shown as plain words."""

    def _fill_text(self, text: str, width: int, indent: str) -> str:
        paragraphs = []
        for paragraph in text.strip().split("\n\n"):
            lines = paragraph.split("\n")
            if all(line.startswith("    ") for line in lines):  # examples: one per line, as written
                paragraphs.append("\n".join(indent + line.rstrip() for line in lines))
            else:
                plain = " ".join(line.strip() for line in lines).replace("``", "").replace("`", "")
                paragraphs.append(textwrap.fill(plain, width, initial_indent=indent, subsequent_indent=indent))
        return "\n\n".join(paragraphs)


class _Parser(argparse.ArgumentParser):
    """argparse exits with 2 on bad usage already; keep its message to one line, and
    answer a mistyped subcommand with the nearest one."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("allow_abbrev", False)  # `--fre` is a typo to answer, not `--free`: abbreviations break
        super().__init__(*args, **kwargs)         # scripts whenever an option with the same prefix is added

    def error(self, message: str):  # noqa: D102
        if "invalid choice: " in message:
            head, _, rest = message.partition("invalid choice: ")
            word, _, choices = rest.partition(" (choose from ")
            word = word.strip("'")
            valid = [c.strip(" '") for c in choices.rstrip(")").split(",")]
            if self._subparsers is not None and head.startswith("argument COMMAND"):
                message = f"{word!r} is not a command{did_you_mean(word, SUBCOMMANDS)}; commands: {', '.join(SUBCOMMANDS)}"
            else:
                message = f"{head}{word!r} is not one of {', '.join(valid)}{did_you_mean(word, valid)}"
        self.exit(2, f"{self.prog}: error: {message}\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="pendfmu", description="Identify an inverted-pendulum rig with FMI component FMUs.")
    parser.add_argument("--version", action="version", version=f"pendfmu {__version__}")
    parser.add_argument("--debug", action="store_true", help="show tracebacks of internal failures (anywhere on the "
                                                              "command line)")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=_Parser)
    for name, module in SUBCOMMANDS.items():
        command = sub.add_parser(name, help=module.HELP, description=module.__doc__, formatter_class=HelpFormatter)
        module.add_arguments(command)
        command.set_defaults(run=module.run)
    return parser


FLAGS = {"windows": "--window", "global_search": "--no-global", "global_search.popsize": "--population",
         "global_search.maxiter": "--generations", "global_search.workers": "--workers",
         "recordings": "recordings", "target": "the stage or model"}


def flag_of(option: str) -> str:
    """The command line's name of a fit specification's field (fitting.spec)."""
    return FLAGS.get(option, f"--{option.replace('_', '-')}")


def _unknown_options(extras: list[str], parser: argparse.ArgumentParser, command: str) -> str:
    """argparse's "unrecognized arguments", with the nearest option of the command."""
    first = extras[0].split("=", 1)[0]
    hint = did_you_mean(first, sorted(command_options(parser, command))) if first.startswith("-") else ""
    return f"pendfmu {command}: error: unrecognized arguments: {' '.join(extras)}{hint}\n"


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    typed = list(sys.argv[1:] if argv is None else argv)
    flags, words = untangle(typed, parser, POSITIONAL_WORDS)
    if not words:
        parser.print_help()  # bare `pendfmu`: what it can do, not an error
        return 0
    command = next((w for w in words if not w.startswith("-")), None)
    if command in SUBCOMMANDS:  # an unknown option first: a typo explains a "required" error that follows it
        known = command_options(parser, command)
        cut = words.index("--") if "--" in words else len(words)
        unknown = [w for w in words[:cut] if w.startswith("--") and w.split("=", 1)[0] not in known]
        if unknown:
            parser.exit(2, _unknown_options(unknown, parser, command))
    args, extras = parser.parse_known_args(words)
    if extras:
        parser.exit(2, _unknown_options(extras, parser, args.command) if args.command else
                    f"pendfmu: error: unrecognized arguments: {' '.join(extras)}\n")
    if args.command is None:
        parser.error(f"give a command: {', '.join(SUBCOMMANDS)}")
    args.debug = args.debug or "--debug" in flags
    args.command_line = ["pendfmu", *typed]  # a result's provenance: as the user typed it
    try:
        return args.run(args) or 0
    except OptionError as error:  # the API's field name, said as the flag the user typed
        print(f"pendfmu {args.command}: error: {flag_of(error.option)}: {error.detail}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except BadInput as error:
        print(f"pendfmu {args.command}: error: {error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except Suspicious as error:
        print(f"pendfmu {args.command}: {error}", file=sys.stderr)
        return EXIT_SUSPICIOUS
    except FMUError as error:
        print(f"pendfmu {args.command}: the model failed: {error}", file=sys.stderr)
        return EXIT_MODEL_FAILED
    except BuildError as error:
        print(f"pendfmu {args.command}: cannot build the FMUs: {error}", file=sys.stderr)
        return EXIT_BUILD_FAILED
    except WorkersFailed as error:
        print(f"pendfmu {args.command}: the workers failed: {error}", file=sys.stderr)
        return EXIT_WORKERS_FAILED
    except KeyboardInterrupt:
        print(f"pendfmu {args.command}: interrupted", file=sys.stderr)
        return 130
    except OSError as error:  # the system refused a file (a full disk, a folder made read-only): not pendfmu's bug
        if error.filename is None:
            return _internal_failure(args, error)
        print(f"pendfmu {args.command}: error: {error.filename}: {error.strerror or error}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except Exception as error:
        return _internal_failure(args, error)


def _internal_failure(args: argparse.Namespace, error: Exception) -> int:
    """An internal failure: said in one line, the details on demand (--debug, PENDFMU_DEBUG)."""
    print(f"pendfmu {args.command}: internal failure: {type(error).__name__}: {error}", file=sys.stderr)
    if args.debug or os.environ.get("PENDFMU_DEBUG"):
        traceback.print_exc()
    return 1
