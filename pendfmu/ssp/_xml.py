"""XML plumbing shared by the SSD and SSV readers and writers.

Namespaces, the SSP 1.0 schemas shipped with fmpy, number formatting that survives a
round trip, unit definitions, and errors that say where a problem is: file, line and
the element as it looks in the file, so that a user can go and fix it.
"""

from __future__ import annotations

import math
from functools import lru_cache
from pathlib import Path

from lxml import etree

from pendfmu.errors import BadInput
from pendfmu.ssp.model import Unit

SSD_NS = "http://ssp-standard.org/SSP1/SystemStructureDescription"
SSC_NS = "http://ssp-standard.org/SSP1/SystemStructureCommon"
SSV_NS = "http://ssp-standard.org/SSP1/SystemStructureParameterValues"

# XML says prefixes do not matter, but ecos reads SSP files with a namespace-unaware
# parser that looks for the literal names "ssd:Component", "ssc:Real", "ssv:Parameter".
# Writing the prefixes the standard's own examples use keeps such importers working.
SSD_NSMAP = {"ssd": SSD_NS, "ssc": SSC_NS}
SSV_NSMAP = {"ssv": SSV_NS, "ssc": SSC_NS}

SSD_SCHEMA = "SystemStructureDescription.xsd"
SSV_SCHEMA = "SystemStructureParameterValues.xsd"


def ssd(tag: str) -> str:
    """Qualified name of an element of the SystemStructureDescription namespace."""
    return f"{{{SSD_NS}}}{tag}"


def ssc(tag: str) -> str:
    """Qualified name of an element of the SystemStructureCommon namespace."""
    return f"{{{SSC_NS}}}{tag}"


def ssv(tag: str) -> str:
    """Qualified name of an element of the SystemStructureParameterValues namespace."""
    return f"{{{SSV_NS}}}{tag}"


class SspError(BadInput):
    """An SSD, SSV or SSP file (or a system about to be written) is not acceptable.

    The message reads ``file:line: <element ...>: problem`` like a compiler's, because the
    person reading it has the file open in an editor.

    Attributes
    ----------
    file : str or None
        The file, e.g. ``rig.ssp!SystemStructure.ssd`` for a member of an archive; None for
        a system built in memory.
    line : int or None
        The line of the element in the file; None when not known.
    element : str or None
        The element's start tag as it reads in the file; None when not known.
    problem : str
        What is wrong.
    """

    def __init__(self, file: str | Path | None, problem: str, *, line: int | None = None,
                 element: str | None = None) -> None:
        self.file = None if file is None else str(file)
        self.line = line
        self.element = element
        self.problem = problem
        super().__init__(self._message())

    def _message(self) -> str:
        where = self.file or "<system>"
        if self.line:
            where += f":{self.line}"
        if self.element:
            where += f": {self.element}"
        return f"{where}: {self.problem}"

    def in_file(self, file: str | Path) -> SspError:
        """The same error reported against another file name (e.g. the archive member).

        Parameters
        ----------
        file : str or Path
            The name to report.

        Returns
        -------
        SspError
            A new error; this one is unchanged.
        """
        return SspError(file, self.problem, line=self.line, element=self.element)


def describe(element: etree._Element) -> str:
    """The element's start tag as it reads in the file, e.g. ``<ssd:Connection startElement="Cart" ...>``."""
    qname = etree.QName(element)
    name = f"{element.prefix}:{qname.localname}" if element.prefix else qname.localname
    attributes = "".join(f' {etree.QName(k).localname}="{v}"' for k, v in element.attrib.items())
    return f"<{name}{attributes}>"


class Locator:
    """Remembers which XML element (in which file) each part of a system came from.

    Semantic checks run on the dataclasses, after parsing; this turns "connection 3 names
    an unknown connector" back into a file, a line and an element. For a system built in
    memory nothing is remembered and errors name the part instead.
    """

    def __init__(self, file: str | Path | None = None) -> None:
        self.file = file
        self._places: dict[tuple, tuple[Path | str | None, etree._Element]] = {}

    def note(self, key: tuple, element: etree._Element, file: str | Path | None = None) -> None:
        """Record that the part named `key` was read from `element` (in `file`, default ours)."""
        self._places[key] = (file if file is not None else self.file, element)

    def at(self, element: etree._Element, problem: str, file: str | Path | None = None) -> SspError:
        """An error located at `element`."""
        return SspError(file if file is not None else self.file, problem,
                        line=element.sourceline, element=describe(element))

    def error(self, key: tuple, what: str, problem: str) -> SspError:
        """An error about the part `key` (described as `what` when its element is unknown)."""
        if key in self._places:
            file, element = self._places[key]
            return self.at(element, problem, file)
        return SspError(self.file, problem, element=what)


def schema_dir() -> Path:
    """Where fmpy keeps the normative SSP 1.0 XML schemas, which every file pendfmu reads
    or writes is validated against.

    Returns
    -------
    Path
        The folder of the schemas.

    Raises
    ------
    FileNotFoundError
        fmpy is installed without them.
    """
    import fmpy

    path = Path(fmpy.__file__).parent / "ssp" / "schema"
    if not (path / SSD_SCHEMA).is_file():
        raise FileNotFoundError(f"the SSP schemas are not in {path}; is fmpy installed completely?")
    return path


@lru_cache(maxsize=None)
def schema(name: str) -> etree.XMLSchema:
    """The compiled schema `name` (parsed once: compiling the SSD schema takes a while)."""
    return etree.XMLSchema(etree.parse(str(schema_dir() / name)))


def safe_parser() -> etree.XMLParser:
    """A parser that never fetches anything or expands entities: SSP files come from others."""
    return etree.XMLParser(resolve_entities=False, no_network=True)


def _validate(tree: etree._ElementTree, schema_name: str, file: str | Path, note: str = "") -> None:
    """Raise SspError at the first schema violation of `tree`."""
    checker = schema(schema_name)
    if checker.validate(tree):
        return
    error = checker.error_log[0]
    element = next((e for e in tree.iter() if isinstance(e.tag, str) and e.sourceline == error.line), None)
    raise SspError(file, f"not valid against the SSP 1.0 schema {schema_name}: {error.message}{note}",
                   line=error.line, element=None if element is None else describe(element))


def read_validated(path: Path, schema_name: str) -> etree._ElementTree:
    """Parse `path` and check it against the schema, or raise SspError saying where it fails."""
    try:
        tree = etree.parse(str(path), safe_parser())
    except OSError as exc:
        raise SspError(path, f"cannot be read: {exc}") from exc
    except etree.XMLSyntaxError as exc:
        raise SspError(path, f"is not well-formed XML: {exc.msg}", line=exc.lineno) from exc
    _validate(tree, schema_name, path)
    return tree


def serialize_validated(root: etree._Element, path: Path, schema_name: str) -> bytes:
    """The document as bytes, after checking them against the schema.

    The bytes are parsed back before validating so that an error can give the line it
    would have in the file; nothing is written when the document is invalid.
    """
    data = etree.tostring(root, xml_declaration=True, encoding="UTF-8", pretty_print=True)
    tree = etree.ElementTree(etree.fromstring(data, safe_parser()))
    _validate(tree, schema_name, path, note=" (file not written)")
    return data


def format_double(value: float) -> str:
    """xs:double text that reads back to the same float (repr is shortest-exact; INF is XML's inf)."""
    value = float(value)
    if math.isnan(value):
        return "NaN"
    if math.isinf(value):
        return "INF" if value > 0 else "-INF"
    return repr(value)


def parse_bool(text: str) -> bool:
    """xs:boolean: true, false, 1 or 0."""
    return text.strip() in ("true", "1")


def units_element(tag: str, units: dict[str, Unit]) -> etree._Element:
    """A Units element (ssd:Units or ssv:Units) defining `units`, sorted by name for stable files."""
    parent = etree.Element(tag)
    for name in sorted(units):
        unit = units[name]
        unit_el = etree.SubElement(parent, ssc("Unit"), name=name)
        base = etree.SubElement(unit_el, ssc("BaseUnit"))
        for exponent in Unit.EXPONENTS:
            if getattr(unit, exponent):
                base.set(exponent, str(getattr(unit, exponent)))
        if unit.factor != 1.0:
            base.set("factor", format_double(unit.factor))
        if unit.offset != 0.0:
            base.set("offset", format_double(unit.offset))
    return parent


def read_units(units_el: etree._Element | None, locator: Locator) -> dict[str, Unit]:
    """The unit definitions of a Units element (none when it is absent); duplicates are errors."""
    units: dict[str, Unit] = {}
    if units_el is None:
        return units
    for unit_el in units_el.iterfind(ssc("Unit")):
        name = unit_el.get("name")
        if name in units:
            raise locator.at(unit_el, f"unit {name!r} is defined twice")
        base = unit_el.find(ssc("BaseUnit"))
        exponents = {e: int(base.get(e, "0")) for e in Unit.EXPONENTS}
        units[name] = Unit(name, **exponents, factor=float(base.get("factor", "1")),
                           offset=float(base.get("offset", "0")))
    return units
