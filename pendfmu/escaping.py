"""User text in generated files: one function per language and place, used by every generator.

A user's string (a file path, a name from an FMU, a description) reaches code pendfmu
writes: MATLAB (set_parameters.m), Modelica (modifiers.mo), XML (model descriptions, SSD,
SSV), HTML (the report) and the start file the FMUs' C code reads. FMI allows any
character in a variable name, line breaks and quotes included, and a path may hold them
too; such text must never change the structure around it: a line break ends a ``%``,
``//`` or ``#`` comment (what follows would be code), a quote ends a string literal, ``<``
opens a tag. Every generator passes user text through the function for its place here,
and no generator quotes on its own.

Characters a place cannot hold are shown as their Python escape (``\\n``, ``\\x07``,
``\\u2028``): line breaks and separators (any character Python's ``str.splitlines``
splits at, what editors and tools may take as a line end), other control characters, and
lone surrogates (an undecodable byte of a file name, which UTF-8 cannot encode).
"""

from __future__ import annotations

import html
import re
import unicodedata

from pendfmu.errors import UsageError

# Unicode categories no generated text may hold raw: controls, lone surrogates, line and
# paragraph separators (a tab is a control too, but harmless everywhere: kept).
_UNSAFE = {"Cc", "Cs", "Zl", "Zp"}
# XML 1.0 (what lxml writes) cannot hold these at all, not even as character references.
_NOT_XML = re.compile("[\x00-\x08\x0b\x0c\x0e-\x1f\ud800-\udfff\ufffe\uffff]")
_SURROGATE = re.compile("[\ud800-\udfff]")
# Modelica's escapes in a string literal (Modelica Language Specification 3.5, section 2.4.6).
_MODELICA_ESCAPES = {"\\": "\\\\", '"': '\\"', "\n": "\\n", "\r": "\\r", "\t": "\\t", "\v": "\\v", "\f": "\\f",
                     "\a": "\\a", "\b": "\\b"}
_MODELICA_KEYWORDS = frozenset(
    "algorithm and annotation block break class connect connector constant constrainedby der discrete each else "
    "elseif elsewhen encapsulated end enumeration equation expandable extends external false final flow for "
    "function if import impure in initial inner input loop model not operator or outer output package parameter "
    "partial protected public pure record redeclare replaceable return stream then true type when while within"
    .split())
_MODELICA_IDENTIFIER = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


def _unsafe(char: str) -> bool:
    return char != "\t" and unicodedata.category(char) in _UNSAFE


def _shown(char: str) -> str:
    """An unsafe character as its Python escape, the way a person reads it: \\n, \\x07, \\u2028."""
    return repr(char)[1:-1]


def one_line(text: object) -> str:
    """`text` as one line that any line comment holds (MATLAB ``%``, Modelica ``//``, the
    start file's ``#``): every line break, control character and lone surrogate shown as
    its escape. Nothing else changes: a comment ends only at the line's end."""
    return "".join(_shown(c) if _unsafe(c) else c for c in str(text))


def matlab_string(text: object) -> str:
    """A MATLAB expression whose value is the character array `text`: ``'it''s'``, and where
    `text` holds an ASCII control character (a line break), a concatenation such as
    ``['a' char(10) 'b']`` (a quoted MATLAB string cannot span lines). Other characters are
    written as they are (the file is UTF-8; MATLAB ends a line only at LF and CR, and
    Octave's char(N) holds no N above 127); lone surrogates, which UTF-8 cannot encode, are
    shown as escapes."""
    pieces, literal = [], ""
    for char in str(text):
        if _unsafe(char) and char.isascii():
            pieces += [f"'{literal}'"] if literal else []
            pieces.append(f"char({ord(char)})")
            literal = ""
        else:
            literal += _shown(char) if _SURROGATE.match(char) else char.replace("'", "''")
    pieces += [f"'{literal}'"] if literal or not pieces else []
    return pieces[0] if len(pieces) == 1 else "[" + " ".join(pieces) + "]"


def modelica_string(text: object) -> str:
    """A Modelica string literal (quotes included) of `text`: Modelica's own escapes for
    quotes, backslashes and the control characters it names; any other character as it is
    (a Modelica string holds any Unicode character), but for control characters with no
    escape and lone surrogates, shown as their escapes."""
    out = []
    for char in str(text):
        escaped = _MODELICA_ESCAPES.get(char)
        if escaped is None and unicodedata.category(char) in ("Cc", "Cs"):
            escaped = _shown(char).replace("\\", "\\\\")
        out.append(char if escaped is None else escaped)
    return '"' + "".join(out) + '"'


def modelica_identifier(name: str) -> str:
    """`name` if it is a Modelica identifier (not a keyword), which generated code may use as
    it is; anything else is refused (UsageError): quoting it would make another name."""
    if not _MODELICA_IDENTIFIER.fullmatch(name) or name in _MODELICA_KEYWORDS:
        raise UsageError(f"'{one_line(name)}' is not a Modelica identifier")
    return name


def xml_text(text: object) -> str:
    """Free text (a description, a path) for an XML attribute or element: lxml escapes
    markup itself, but XML 1.0 cannot hold most control characters and lone surrogates at
    all; those are shown as their escapes."""
    return _NOT_XML.sub(lambda found: _shown(found.group()), str(text))


def xml_name(name: str, where: str) -> str:
    """A name that identifies something in XML (a component, a connector, a parameter): it
    must reach the file unchanged, so one XML 1.0 cannot hold is refused (UsageError naming
    `where`) rather than altered."""
    if _NOT_XML.search(name):
        raise UsageError(f"{where}: the name '{one_line(name)}' holds a character XML cannot hold")
    return name


def html_text(value: object) -> str:
    """Any value as HTML text: markup characters and quotes escaped (safe in element text and
    in quoted attributes), lone surrogates shown as escapes so that the page encodes as UTF-8."""
    return html.escape(_SURROGATE.sub(lambda found: _shown(found.group()), str(value)), quote=True)
