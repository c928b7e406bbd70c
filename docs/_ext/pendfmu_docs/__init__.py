"""The site's generated parts: a Sphinx extension that writes Markdown from pendfmu itself
into a page while Sphinx reads it, so nothing generated is committed and nothing can fall
behind the code.

A page asks for a part with a line of its own (a MyST comment, so the page reads as
Markdown without the extension too):

    % generated: cli

and the extension puts the part's Markdown in its place: `cli` (every command's usage,
description and options, from pendfmu.cli's argparse parsers), `api` (autodoc directives
for each public module's __all__), `variables` (the component FMUs' variables, from
pendfmu.components), `result-file` (the fields of a result file, from FitResult.to_dict
and the provenance record) and `performance` (the tables of docs/performance.json, which
scripts/bench.py writes). A page with a generated part is read anew on every build: the
code it comes from may have changed while the page did not.
"""

from __future__ import annotations

import re

from sphinx.application import Sphinx
from sphinx.util import logging

from pendfmu_docs import api, cli, performance, result_file, variables

MARKER = re.compile(r"^% generated: ([\w-]+)[ \t]*$", re.M)
PARTS = {"cli": cli.markdown, "api": api.markdown, "variables": variables.markdown,
         "result-file": result_file.markdown, "performance": performance.markdown}

logger = logging.getLogger(__name__)


def _fill(app: Sphinx, docname: str, source: list[str]) -> None:
    """Replace each marker of the page with its part (Sphinx's source-read event)."""

    def part(match: re.Match) -> str:
        name = match.group(1)
        if name not in PARTS:
            logger.warning("unknown generated part %r (known: %s)", name, ", ".join(PARTS), location=docname)
            return ""
        app.env.metadata[docname]["generated"] = name  # read anew on every build (_outdated)
        return PARTS[name](app)

    source[0] = MARKER.sub(part, source[0])


def _outdated(app: Sphinx, env, added, changed, removed) -> list[str]:
    """Pages with a generated part: always read again (env-get-outdated)."""
    return [name for name, meta in env.metadata.items() if "generated" in meta and name not in removed]


REPR = re.compile(r"<[^<>]*>")  # a default's repr Python cannot read back: <factory>, <function f>


def _readable_defaults(app, what, name, obj, options, signature, return_annotation):
    """A signature whose default is a repr like <factory> (a dataclass field's default_factory)
    shows ... there instead: Sphinx parses signatures as Python, and falls back to splitting
    them at every comma, type hints included, when it cannot (autodoc-process-signature)."""
    if signature and REPR.search(signature):
        return REPR.sub("...", signature), return_annotation
    return None


SUBSTITUTION = re.compile(r"(``.*?``|`[^`]*`)|\|(?=[^|\s`][^|`\n]*\|)")


def _plain_pipes(app, what, name, obj, options, lines: list[str]) -> None:
    """pendfmu's docstrings write |y| for an absolute value, which reST reads as a
    substitution it does not know: such a pipe is escaped (outside code) before numpydoc
    reads the docstring (autodoc-process-docstring)."""
    lines[:] = [SUBSTITUTION.sub(lambda m: m.group(1) or "\\|", line) for line in lines]


def setup(app: Sphinx) -> dict:
    app.connect("autodoc-process-docstring", _plain_pipes, priority=100)
    app.connect("autodoc-process-signature", _readable_defaults, priority=100)  # before numpydoc's own
    app.connect("source-read", _fill)
    app.connect("env-get-outdated", _outdated)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
