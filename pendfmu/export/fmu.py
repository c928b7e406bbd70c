"""Parameterized copies of the component FMUs, without recompiling.

An exported FMU is the built FMU with three changes (``pendfmu/csrc/framework/start.c`` is the
binary's side of this contract):

- ``modelDescription.xml`` gets a fresh GUID, the new start values of the given
  parameters and a description that says where they came from; everything else,
  formatting included, is kept, so a diff against the original shows only those;
- ``resources/pendfmu-start.txt`` repeats the GUID and every parameter's start value by
  value reference. The binary accepts a GUID other than its own only when this file
  names it, and then computes with these values, after fmi2Instantiate and fmi2Reset;
- binaries and sources are copied byte for byte: the FMU's behaviour is the tested one.

The start file lists *every* parameter, read back from the edited XML, so what the XML
declares and what the binary computes with cannot differ, whatever the defaults are.

FMI 3.0 FMUs (``fmi_version=3``) are exported the same way: the fresh GUID is the
``instantiationToken``, a Real parameter is a ``Float64`` element carrying its own start,
and the binary finds the start file through FMI 3.0's resourcePath.
"""

from __future__ import annotations

import datetime
import uuid
import zipfile
from collections.abc import Mapping
from pathlib import Path

from lxml import etree

from pendfmu import __version__
from pendfmu.atomic import write_atomically
from pendfmu.errors import UsageError
from pendfmu.escaping import one_line, xml_text
from pendfmu.fmubuild import ensure_fmu

MODEL_DESCRIPTION = "modelDescription.xml"
#: The file in an exported FMU that holds its GUID and every parameter's start value by
#: value reference: the binary computes with these values, and accepts the exported FMU's
#: fresh GUID only when this file names it (the path inside the FMU's zip archive).
START_FILE = "resources/pendfmu-start.txt"
# The longest comment line of the start file: start.c reads lines of at most 255 characters,
# and the rest of a longer one would be read as a line of its own (a value line, refused).
START_COMMENT_LENGTH = 200


def new_guid() -> str:
    """A random GUID in braces, like the built FMUs' (theirs is a hash of the sources)."""
    return "{" + str(uuid.uuid4()) + "}"


def _parse(data: bytes) -> etree._Element:
    """Parse a model description, keeping its whitespace so it is written back as it was."""
    return etree.fromstring(data, etree.XMLParser(remove_blank_text=False, resolve_entities=False, no_network=True))


def _token_attribute(root: etree._Element) -> str:
    """Where a model description keeps its GUID: guid (FMI 2.0), instantiationToken (3.0)."""
    return "instantiationToken" if root.get("fmiVersion", "").startswith("3") else "guid"


def _variables(root: etree._Element):
    """(name, causality, the element with the Real start and unit or None, value reference)
    of every variable, FMI 2.0's ScalarVariable or FMI 3.0's typed element."""
    if _token_attribute(root) == "guid":
        for variable in root.iterfind("ModelVariables/ScalarVariable"):
            yield variable.get("name"), variable.get("causality"), variable.find("Real"), variable.get("valueReference")
    else:
        for variable in root.iterfind("ModelVariables/*"):
            real = variable if variable.tag == "Float64" else None
            yield variable.get("name"), variable.get("causality"), real, variable.get("valueReference")


def _now() -> str:
    """xs:dateTime of now in UTC, for generationDateAndTime."""
    return datetime.datetime.now(datetime.timezone.utc).replace(microsecond=0).isoformat().replace("+00:00", "Z")


def parameterized_description(original: bytes, values: Mapping[str, float], guid: str, source: str) -> bytes:
    """`original` modelDescription.xml with `guid`, the start values `values` and provenance.

    Only attributes change: guid, description, generationTool, generationDateAndTime and
    the start attribute of each given parameter (written with repr, which reads back to
    the same double). A name that is not a parameter of the FMU is an internal error:
    the plan has already checked the names against the component table.
    """
    root = _parse(original)
    root.set(_token_attribute(root), guid)
    changed = ", ".join(values) if values else "no values changed"
    root.set("description", f"{root.get('description', '')} [parameterized by pendfmu export from "
                            f"{xml_text(source)}: {changed}]")
    root.set("generationTool", f"pendfmu {__version__} export (parameterized copy of {root.get('generationTool')})")
    root.set("generationDateAndTime", _now())
    found = set()
    for name, causality, real, _ in _variables(root):
        if name in values:
            if causality != "parameter" or real is None:
                raise UsageError(f"{root.get('modelName')}: {name} is not a Real parameter")
            real.set("start", repr(float(values[name])))
            found.add(name)
    missing = set(values) - found
    if missing:
        raise UsageError(f"{root.get('modelName')} has no parameter {', '.join(sorted(missing))}")
    data = etree.tostring(root.getroottree(), xml_declaration=True, encoding="UTF-8")
    return data if data.endswith(b"\n") else data + b"\n"


def start_file_text(description: bytes) -> str:
    """The resources/pendfmu-start.txt that goes with a model description.

    First line ``guid {GUID}``, then for every Real parameter a comment line with its name
    and unit and a line ``<value reference> <start value>``, the start text taken from the
    XML as is. Lines stay short: the binary reads lines of at most 255 characters.
    """
    root = _parse(description)
    lines = [f"guid {root.get(_token_attribute(root))}",
             _start_comment(f"start values of {root.get('modelName')} parameters: <value reference> <value>")]
    for name, causality, real, value_reference in _variables(root):
        if causality == "parameter" and real is not None:
            lines.append(_start_comment(f"{name} [{real.get('unit', '')}]"))
            lines.append(f"{value_reference} {real.get('start')}")
    return "\n".join(lines) + "\n"


def _start_comment(text: str) -> str:
    """A comment line of the start file: one line (a name may hold line breaks), short
    enough for start.c's reader (START_COMMENT_LENGTH)."""
    return f"# {one_line(text)}"[:START_COMMENT_LENGTH]


def _copy_info(info: zipfile.ZipInfo) -> zipfile.ZipInfo:
    """A fresh ZipInfo with the member's name, time, compression and permissions."""
    copy = zipfile.ZipInfo(info.filename, info.date_time)
    copy.compress_type = info.compress_type
    copy.external_attr = info.external_attr
    return copy


def write_parameterized_fmu(name: str, values: Mapping[str, float], target: str | Path,
                            source: str = "parameters given in Python", fmi_version: int = 2) -> Path:
    """Write component `name`'s FMU (FMI 2.0, or 3.0) with start values `values` to `target`;
    return the path.

    Every member but modelDescription.xml is copied byte for byte; a start file left by an
    earlier export (there is none in a built FMU) would be replaced. The file appears
    atomically: a reader never sees half an FMU.
    """
    original, target = ensure_fmu(name, fmi_version), Path(target)
    target.parent.mkdir(parents=True, exist_ok=True)

    def write(out) -> None:
        with zipfile.ZipFile(original) as src, zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as dst:
            description = parameterized_description(src.read(MODEL_DESCRIPTION), values, new_guid(), source)
            for info in src.infolist():
                if info.filename == MODEL_DESCRIPTION:
                    dst.writestr(_copy_info(info), description)
                elif info.filename != START_FILE:
                    dst.writestr(_copy_info(info), src.read(info))
            start = zipfile.ZipInfo(START_FILE, datetime.datetime.now().timetuple()[:6])
            start.compress_type = zipfile.ZIP_DEFLATED
            start.external_attr = 0o644 << 16
            dst.writestr(start, start_file_text(description))

    return write_atomically(target, writer=write)
