"""Print pendfmu's recording format: the columns and their units, the sidecar's keys, the
angle and inertia conventions (the document shipped with the package, FORMAT.md).

    pendfmu format            # the document, as markdown
    pendfmu format --path     # where the installed document is
"""

from __future__ import annotations

import argparse

HELP = "print the recording format: columns, units, sidecar keys, angle and inertia conventions"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--path", action="store_true", help="print where the document is instead of the document")


def run(args: argparse.Namespace) -> int:
    from pendfmu.recording import format_document

    document = format_document()
    print(document if args.path else document.read_text(encoding="utf-8"), end="" if not args.path else "\n")
    return 0
