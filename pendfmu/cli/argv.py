"""The command line as users type it, put in the order argparse can read.

argparse has two habits mature tools do not: an option taking a list (``--fix eta k_fwc``)
swallows the positionals after it (``fit cart --fix eta rec.csv`` lost the recording),
and positionals split by options (``fit cart --fix eta rec.csv --out r.json``) confuse a
`nargs="+"` positional. And options of the program itself (``--debug``) are only accepted
before the subcommand. :func:`untangle` rewrites the arguments before argparse sees them:

- global flags (GLOBAL_FLAGS) are taken from anywhere before a ``--``;
- a list option's values end at the next option or at the first word that is clearly a
  positional: an existing file or folder, a name with a recording's or model's suffix,
  or one of the subcommand's positional words (the stages for ``fit``);
- all positionals then come first, right after the subcommand, the options after them;
  after a ``--``, the options come first and every positional after the ``--`` (argparse
  fills a list positional only from one run of words).

Nothing is dropped or invented: the same words reach argparse, only reordered, so its own
error messages stay right.
"""

from __future__ import annotations

import argparse
from collections.abc import Collection, Sequence
from pathlib import Path

GLOBAL_FLAGS = ("--debug",)
FILE_SUFFIXES = (".csv", ".mat", ".json", ".fmu", ".ssp", ".ssd")


def _looks_positional(word: str, words: Collection[str]) -> bool:
    """A word no list option takes: a path that exists, a file name of the kinds pendfmu
    reads, or one of the subcommand's own positional words. A word with `=` is an option's
    NAME=VALUE (`--component Cart=cart.fmu`): no pendfmu positional has one."""
    if "=" in word:
        return False
    if word in words or Path(word).suffix.lower() in FILE_SUFFIXES:
        return True
    try:
        return Path(word).exists()
    except OSError:  # a name too long for the file system is no path
        return False


def _options(parser: argparse.ArgumentParser) -> dict[str, argparse.Action]:
    return {flag: action for action in parser._actions for flag in action.option_strings}


def _subcommands(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    found = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    return dict(found[0].choices) if found else {}


def command_options(parser: argparse.ArgumentParser, command: str) -> set[str]:
    """Every option string `command` accepts, the program's own (--version, --debug) included."""
    return {*_options(_subcommands(parser)[command]), *_options(parser)}


def untangle(argv: Sequence[str], parser: argparse.ArgumentParser,
             positional_words: dict[str, Collection[str]]) -> tuple[list[str], list[str]]:
    """(global flags found, the arguments reordered) for `parser` (the main parser, with
    its subcommands). Arguments argparse will refuse anyway are passed through as they are."""
    argv = list(argv)
    found = [a for a in argv[: argv.index("--") if "--" in argv else len(argv)] if a in GLOBAL_FLAGS]
    rest = [a for i, a in enumerate(argv) if not (a in GLOBAL_FLAGS and ("--" not in argv or i < argv.index("--")))]
    commands = _subcommands(parser)
    command_index = next((i for i, a in enumerate(rest) if not a.startswith("-")), None)
    if command_index is None or rest[command_index] not in commands:
        return found, rest
    command = rest[command_index]
    options = _options(commands[command])
    words = positional_words.get(command, ())
    positionals: list[str] = []
    tail: list[str] = []
    i = command_index + 1
    while i < len(rest):
        word = rest[i]
        if word == "--":  # what follows is positional, whatever it looks like: every positional goes there
            return found, rest[:command_index + 1] + tail + ["--"] + positionals + rest[i + 1:]
        action = options.get(word.split("=", 1)[0]) if word.startswith("-") else None
        if action is None:
            (tail if word.startswith("-") else positionals).append(word)  # argparse words unknown options
            i += 1
            continue
        tail.append(word)
        i += 1
        if "=" in word or action.nargs == 0:
            continue
        if action.nargs in (None, 1, "?"):
            if i < len(rest) and (action.nargs != "?" or not rest[i].startswith("-")):
                tail.append(rest[i])
                i += 1
            continue
        while i < len(rest) and not rest[i].startswith("-") and not _looks_positional(rest[i], words):
            tail.append(rest[i])
            i += 1
    return found, rest[:command_index + 1] + positionals + tail
