"""The Python API's reference: for each public module, autodoc directives for every name of its
__all__, in the order __all__ lists them (numpydoc renders the docstrings' sections).

The top level's names are pendfmu's lazy API table (pendfmu._API: each imported from its
module on first use); autodoc reaches them through pendfmu.__getattr__ like any user. An
object that more than one module exports (pendfmu.Recording is pendfmu.recording.Recording)
is documented once, in the module nearest to its definition; the others' name for it is a
target of its own that points there.
"""

from __future__ import annotations

import importlib
import inspect
import sys

from sphinx.errors import PycodeError
from sphinx.pycode import ModuleAnalyzer

from pendfmu_docs.markdown import plain

MODULES = ("pendfmu", "pendfmu.recording", "pendfmu.simulator", "pendfmu.report", "pendfmu.export",
           "pendfmu.fmubuild", "pendfmu.ssp", "pendfmu.check", "pendfmu.testing", "pendfmu.control")


def _directive(full_name: str, value) -> str:
    """The autodoc directive (reST, in an eval-rst block) that documents one object."""
    if inspect.isclass(value) and issubclass(value, BaseException):
        lines = [f".. autoexception:: {full_name}"]
    elif inspect.isclass(value):
        lines = [f".. autoclass:: {full_name}", "   :members:"]
    elif inspect.isroutine(value):
        lines = [f".. autofunction:: {full_name}"]
    else:
        module, _, attribute = full_name.rpartition(".")
        lines = [f".. py:data:: {attribute}", f"   :module: {module}"]
        if isinstance(value, (str, int, float)):
            lines.append(f"   :value: {value!r}")
        lines += [""] + ["   " + line if line else "" for line in attribute_doc(full_name)]
    return "```{eval-rst}\n" + "\n".join(lines) + "\n```\n"


def attribute_doc(full_name: str) -> list[str]:
    """The docstring written below a module-level name where it is assigned, in the
    exporting package or one of its modules (autodata would take a value's class docstring
    when the exporting module itself has none: RIG's would be Vocabulary's)."""
    package, _, attribute = full_name.rpartition(".")
    candidates = [package, *sorted(name for name in sys.modules if name.startswith(package + "."))]
    for name in candidates:
        try:
            docs = ModuleAnalyzer.for_module(name).find_attr_docs()
        except PycodeError:
            continue
        if ("", attribute) in docs:
            return list(docs[("", attribute)])
    return []


def _exports() -> list[tuple[str, str, object]]:
    """(module, name, object) of every public name, in MODULES' order and each __all__'s."""
    found = []
    for name in MODULES:
        module = importlib.import_module(name)
        found += [(name, attribute, getattr(module, attribute)) for attribute in module.__all__]
    return found


def homes(exports: list[tuple[str, str, object]]) -> dict[int, str]:
    """Where each object exported more than once is documented: by the exporting module
    nearest to where it is defined (pendfmu.recording for read_recording, whose docstring
    names its module's other objects), else the first that exports it."""
    chosen: dict[int, tuple[int, str]] = {}
    for module, attribute, value in exports:
        if isinstance(value, (str, int, float, bool)):
            continue
        defined = getattr(value, "__module__", "") or ""
        near = len(module) if defined == module or defined.startswith(module + ".") else 0
        if id(value) not in chosen or near > chosen[id(value)][0]:
            chosen[id(value)] = (near, f"{module}.{attribute}")
    return {key: full_name for key, (_, full_name) in chosen.items()}


def module_section(name: str, exports: list[tuple[str, str, object]], home: dict[int, str]) -> str:
    """A module's section: its first docstring paragraph, then each name of its __all__."""
    module = importlib.import_module(name)
    summary = (module.__doc__ or "").strip().split("\n\n")[0]
    parts = [f"## `{name}`\n", "```{eval-rst}\n" + f".. module:: {name}\n" + "```\n"]
    if name != "pendfmu" and summary:
        parts.append(plain(" ".join(line.strip() for line in summary.splitlines())) + "\n")
    for _, attribute, value in (entry for entry in exports if entry[0] == name):
        full_name = f"{name}.{attribute}"
        if home.get(id(value), full_name) != full_name:
            parts.append(_pointer(name, attribute, value, home[id(value)]))
        else:
            parts.append(_directive(full_name, value))
    return "\n".join(parts)


def _pointer(module: str, attribute: str, value, home: str) -> str:
    """A name that another module's documentation describes: a target of its own (so that
    a reference to pendfmu.read_recording resolves), saying where."""
    kind = "exception" if inspect.isclass(value) and issubclass(value, BaseException) else \
        "class" if inspect.isclass(value) else "function" if inspect.isroutine(value) else "data"
    role = {"exception": "exc", "class": "class", "function": "func", "data": "data"}[kind]
    return (f"```{{eval-rst}}\n.. py:{kind}:: {attribute}\n   :module: {module}\n   :no-index-entry:\n\n"
            f"   The same object as :{role}:`{home}`, documented in its own module.\n```\n")


def markdown(app=None) -> str:
    exports = _exports()
    home = homes(exports)
    return "\n".join(module_section(name, exports, home) for name in MODULES)
