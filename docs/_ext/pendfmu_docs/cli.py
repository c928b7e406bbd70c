"""The command-line reference, from the parsers `pendfmu` itself runs (pendfmu.cli.build_parser):
per command its usage, its description (the subcommand module's docstring) and every
argument with its help, grouped as --help groups them. A command with subcommands of its
own gets a section for each, in the same way."""

from __future__ import annotations

import argparse

from sphinx.util import logging

from pendfmu_docs.markdown import docstring, fence, plain, table

logger = logging.getLogger(__name__)

WIDTH = 88  # the usage lines' width: as a wide terminal shows them


def _formatter(parser: argparse.ArgumentParser) -> argparse.HelpFormatter:
    return argparse.HelpFormatter(parser.prog, width=WIDTH)


def usage(parser: argparse.ArgumentParser) -> str:
    formatter = _formatter(parser)
    formatter.add_usage(parser.usage, parser._actions, parser._mutually_exclusive_groups, prefix="")
    return formatter.format_help().strip()


def _subcommands(parser: argparse.ArgumentParser) -> list[tuple[str, str, argparse.ArgumentParser]]:
    """(name, one-line help, parser) of each subcommand, in the order --help lists them."""
    found = []
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            helps = {choice.dest: choice.help or "" for choice in action._choices_actions}
            found += [(name, helps.get(name, ""), sub) for name, sub in action.choices.items()]
    return found


def _arguments(parser: argparse.ArgumentParser) -> str:
    """Every argument of the parser, in its --help groups: the invocation as code, the help."""
    formatter = _formatter(parser)
    out = []
    for group in parser._action_groups:
        actions = [a for a in group._group_actions
                   if a.help != argparse.SUPPRESS and not isinstance(a, argparse._SubParsersAction)]
        if not actions:
            continue
        out.append(f"{plain(group.title.capitalize())}:\n")
        for action in actions:
            invocation = formatter._format_action_invocation(action)
            text = formatter._expand_help(action) if action.help else ""
            out.append(f"- `{invocation}`" + (f": {plain(text)}" if text else ""))
        out.append("")
    return "\n".join(out)


def command(parser: argparse.ArgumentParser, summary: str, level: int) -> str:
    """One command's section: heading, summary, usage, description, arguments, then its subcommands'."""
    parts = [f"{'#' * level} `{parser.prog}`\n"]
    if summary:
        sentence = summary[0].upper() + summary[1:]
        parts.append(plain(sentence if sentence.endswith(".") else sentence + ".") + "\n")
    parts.append(fence(usage(parser)))
    if parser.description:
        parts.append(docstring(parser.description))
    parts.append(_arguments(parser))
    subcommands = _subcommands(parser)
    if subcommands:
        parts.append("Commands: " + ", ".join(f"[`{name}`](#{_anchor(sub.prog)})" for name, _, sub in subcommands)
                     + ".\n")
    for _, help_text, sub in subcommands:
        parts.append(command(sub, help_text, min(level + 1, 3)))
    return "\n".join(parts)


def _anchor(prog: str) -> str:
    """MyST's anchor of a heading `prog` (myst_heading_anchors: lower case, spaces to -)."""
    return prog.lower().replace(" ", "-")


# What each exit code means; the codes are pendfmu.errors' EXIT_ constants (and 0, 1, 130).
EXIT_CODES = {
    "": (0, "success"),
    "EXIT_INTERNAL": (1, "an internal failure: a bug (`--debug` or PENDFMU_DEBUG=1 shows the traceback)"),
    "EXIT_BAD_INPUT": (None, "bad input: a one-line message names the file, column, option or value"),
    "EXIT_SUSPICIOUS": (None, "warnings under `--strict`: suspicious data (nothing fitted) or a suspicious result "
                              "(written)"),
    "EXIT_MODEL_FAILED": (None, "the model failed: an FMU refused a value or a step"),
    "EXIT_BUILD_FAILED": (None, "the FMUs cannot be built here (no C compiler, or it refused the sources)"),
    "EXIT_WORKERS_FAILED": (None, "the worker processes or the Dask cluster failed the work (killed, every worker "
                                  "lost)"),
    "SIGINT": (130, "interrupted (Ctrl-C); a fit keeps its checkpoint for `--resume`"),
}


def exit_codes() -> str:
    """The exit codes' table; a code pendfmu.errors defines that EXIT_CODES does not describe
    is a warning, so an error of the build (the page would be incomplete)."""
    from pendfmu import errors

    defined = {name: getattr(errors, name) for name in dir(errors) if name.startswith("EXIT_")}
    missing = sorted(set(defined) - set(EXIT_CODES))
    if missing:
        logger.warning("pendfmu.errors defines exit codes the CLI reference does not describe: %s", missing)
    rows = [[f"{defined.get(name, code)}", meaning] for name, (code, meaning) in EXIT_CODES.items()
            if name in defined or code is not None]
    return table(["exit code", "meaning"], sorted(rows, key=lambda row: int(row[0])))


def markdown(app=None) -> str:
    from pendfmu.cli import build_parser

    return "## Exit codes\n\n" + exit_codes() + "\n" + command(build_parser(), "", 2)
