"""Reference results inside the FMU, in the layout of FMI-LS-REF (the FMI layered standard
"References": related files of an FMU, each with a role), as the FMI standard's Reference
FMUs ship them:

    extra/org.fmi-standard.fmi-ls-ref/fmi-ls-manifest.xml   root <fmiReferences> with the
        fmi-ls:fmi-ls-name / -version / -description attributes (namespace
        http://fmi-standard.org/fmi-ls-manifest) and one <Related source="..." role="..."
        type="..." description="..."/> per file, the source a URI relative to the manifest
    extra/org.fmi-standard.fmi-ls-ref/<Model>_out.csv        role "result": the reference
                                                             results (time first, a column
                                                             per variable)
    extra/org.fmi-standard.fmi-ls-ref/<Model>_in.csv         role "other": the inputs they
                                                             were made with (pendfmu's export;
                                                             the Reference FMUs' name for an
                                                             input file; FMI-LS-REF's role list
                                                             has no "stimulus")

The text of FMI-LS-REF (modelica/fmi-ls-ref, docs/index.adoc, version 1.0.0-alpha.1) and its
schema fmi3LayeredStandardReferenceManifest.xsd define the manifest, the roles and that
"an importer should be prepared to handle related files that are described in the layered
standard manifest file, but are not present in the FMU archive": such a file is a note, not
an error, and so is a manifest without the schema's fixed fmi-ls-description (the Reference
FMUs v0.0.41 ship it so). A result `X_out.csv` goes with the stimulus `X_in.csv` beside it.
pendfmu 0.x wrote reference.csv, stimulus.csv and an experiments.xml pairing them (the
<Experiments> format of an earlier draft); that is still read.

`add_references(fmu, reference_csv, stimulus_csv)` writes them into an FMU (replacing an
earlier set); `carried(path)` reads them back for `pendfmu check`.
"""

from __future__ import annotations

import re
import zipfile
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath

from lxml import etree

from pendfmu.atomic import write_atomically
from pendfmu.errors import BadInput
from pendfmu.escaping import xml_text

FOLDER = "extra/org.fmi-standard.fmi-ls-ref"
MANIFEST = f"{FOLDER}/fmi-ls-manifest.xml"
RESULT, STIMULUS = "_out.csv", "_in.csv"
LS_NAMESPACE = "http://fmi-standard.org/fmi-ls-manifest"
LS_NAME = "org.fmi-standard.fmi-ls-ref"
LS_VERSION = "1.0.0-alpha.1"
LS_DESCRIPTION = "Layered Standard providing information on related files included in an FMU."
ROLE = re.compile(r"(document|requirement|specification|model|parameter|system|testcase|"
                  r"experiment(/(smoke-test|validation|uncertainty-analysis))?|result|method|rationale|report|"
                  r"request|delivery|configuration|signature|serialized-state(/.*)?|meta-data|other)")


def _ls(attribute: str) -> str:
    return f"{{{LS_NAMESPACE}}}{attribute}"


def manifest_xml(related: list[tuple[str, str, str, str]]) -> bytes:
    """The manifest for (source, role, type, description) entries."""
    root = etree.Element("fmiReferences", nsmap={"fmi-ls": LS_NAMESPACE})
    root.set(_ls("fmi-ls-name"), LS_NAME)
    root.set(_ls("fmi-ls-version"), LS_VERSION)
    root.set(_ls("fmi-ls-description"), LS_DESCRIPTION)
    for source, role, kind, description in related:
        entry = etree.SubElement(root, "Related")
        entry.set("source", source)
        entry.set("role", role)
        entry.set("type", kind)
        entry.set("description", xml_text(description))
    return etree.tostring(root, xml_declaration=True, encoding="UTF-8", pretty_print=True)


def manifest_problems(data: bytes) -> tuple[list[str], list[str]]:
    """(errors, notes) of an FMI-LS-REF manifest. Errors keep its files from being used: not
    XML, another root or layered standard's name, a Related entry without source or with a
    role outside the standard's list. Notes do not: the schema's version and fixed
    description attributes missing or different."""
    try:
        root = etree.fromstring(data)
    except etree.XMLSyntaxError as error:
        return [f"not XML: {error}"], []
    errors, notes = [], []
    if root.tag != "fmiReferences":
        errors.append(f"root element {root.tag!r}, not 'fmiReferences'")
    name = root.get(_ls("fmi-ls-name"))
    if name is None:
        errors.append("no fmi-ls:fmi-ls-name attribute")
    elif name != LS_NAME:
        errors.append(f"fmi-ls:fmi-ls-name is {name!r}, must be {LS_NAME!r}")
    for attribute, fixed in (("fmi-ls-version", None), ("fmi-ls-description", LS_DESCRIPTION)):
        value = root.get(_ls(attribute))
        if value is None:
            notes.append(f"no fmi-ls:{attribute} attribute (the FMI-LS-REF schema requires it)")
        elif fixed is not None and value != fixed:
            notes.append(f"fmi-ls:{attribute} is {value!r}, the schema fixes {fixed!r}")
    for child in root:
        if not isinstance(child.tag, str) or child.tag == "Annotations":
            continue  # comments
        if child.tag != "Related":
            errors.append(f"unexpected element {child.tag!r}")
        elif not child.get("source"):
            errors.append("a Related element without source")
        elif child.get("role") is None or not ROLE.fullmatch(child.get("role")):
            errors.append(f"Related {child.get('source')!r}: role {child.get('role')!r} is not one of the standard's")
    return errors, notes


def check_manifest(data: bytes) -> list[str]:
    """Everything the FMI-LS-REF schema and text find wrong with a manifest (empty: nothing)."""
    errors, notes = manifest_problems(data)
    return errors + notes


def _columns(text: str) -> list[str]:
    first = text.splitlines()[0] if text.strip() else ""
    return [name.strip() for name in first.split(",")]


def _read_text(path: str | Path, what: str) -> str:
    try:
        return Path(path).read_text()
    except OSError as error:
        raise BadInput(f"{path}: cannot read the {what} ({error.strerror})") from None


def fits(fmu: str | Path, reference_csv: str | Path) -> bool:
    """Whether every column of the reference (after time) is a variable of the FMU."""
    from fmpy import read_model_description

    names = {v.name for v in read_model_description(str(fmu)).modelVariables}
    return all(name in names for name in _columns(_read_text(reference_csv, "reference"))[1:])


def _model(fmu: Path) -> str:
    """The FMU's model identifier, the Reference FMUs' name for its files."""
    from fmpy import read_model_description

    md = read_model_description(str(fmu))
    interface = md.coSimulation or md.modelExchange
    return interface.modelIdentifier if interface is not None else fmu.stem


def add_references(fmu: str | Path, reference_csv: str | Path, stimulus_csv: str | Path | None = None) -> Path:
    """Store the reference results (and the stimulus) in the FMU at `fmu`, in place, as
    extra/org.fmi-standard.fmi-ls-ref/<Model>_out.csv (and <Model>_in.csv) with the
    manifest; an earlier set is replaced."""
    fmu = Path(fmu)
    reference = _read_text(reference_csv, "reference")
    stimulus = _read_text(stimulus_csv, "stimulus") if stimulus_csv else None
    if len(reference.strip().splitlines()) < 2:
        raise BadInput(f"{reference_csv}: needs a header and rows with time first")
    model = _model(fmu)
    related = [(model + RESULT, "result", "text/csv", f"reference results (from {Path(reference_csv).name})")]
    members = {f"{FOLDER}/{model}{RESULT}": reference.encode()}
    if stimulus is not None:
        related.append((model + STIMULUS, "other", "text/csv", f"the inputs the reference results were made with "
                                                               f"(from {Path(stimulus_csv).name})"))
        members[f"{FOLDER}/{model}{STIMULUS}"] = stimulus.encode()
    members[MANIFEST] = manifest_xml(related)
    _replace_folder(fmu, members)
    return fmu


def _replace_folder(fmu: Path, members: dict[str, bytes]) -> None:
    """Rewrite the FMU with `members` in place of whatever it had under FOLDER."""
    from pendfmu.export.fmu import _copy_info

    def write(out) -> None:
        with zipfile.ZipFile(fmu) as src, zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as dst:
            for info in src.infolist():
                if not info.filename.startswith(FOLDER + "/"):
                    dst.writestr(_copy_info(info), src.read(info))
            for name, data in members.items():
                info = zipfile.ZipInfo(name, _now_tuple())
                info.compress_type = zipfile.ZIP_DEFLATED
                info.external_attr = 0o644 << 16
                dst.writestr(info, data)

    write_atomically(fmu, writer=write)


def _now_tuple():
    import datetime

    return datetime.datetime.now().timetuple()[:6]


@dataclass
class Carried:
    """A reference result found in an FMU: its member name, text, and the stimulus's (or None)."""
    member: str
    text: str
    stimulus_member: str | None
    stimulus_text: str | None


@dataclass
class Shipped:
    """What an FMU carries under FOLDER: its reference results and the notes on what could
    not be used or deviates from FMI-LS-REF without stopping the rest."""
    results: list[Carried] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)


def _resolve(archive: zipfile.ZipFile, source: str) -> str | None:
    """A manifest source as a member name: relative to the manifest's folder, else to the
    archive's root; None if neither exists."""
    names = set(archive.namelist())
    for base in (FOLDER, ""):
        candidate = str(PurePosixPath(base) / source) if base else source
        parts = []
        for part in candidate.split("/"):
            if part == "..":
                if parts:
                    parts.pop()
            elif part not in ("", "."):
                parts.append(part)
        member = "/".join(parts)
        if member in names:
            return member
    return None


def carried(path: str | Path) -> Shipped:
    """The reference results an FMU carries under extra/org.fmi-standard.fmi-ls-ref/: each
    Related file of role "result" (a CSV) with the stimulus beside it (X_out.csv: X_in.csv),
    and each experiment of a pendfmu 0.x experiments.xml. Raises BadInput for a manifest
    whose files cannot be told apart (manifest_problems' errors); a file it names that the
    FMU lacks is a note. BadInput too for a member that is not UTF-8 text or not XML."""
    with zipfile.ZipFile(path) as archive:
        if MANIFEST not in archive.namelist():
            return Shipped()
        data = archive.read(MANIFEST)
        errors, notes = manifest_problems(data)
        if errors:
            raise BadInput(f"{path}: {MANIFEST}: {'; '.join(errors)}")
        shipped = Shipped(notes=[f"{MANIFEST}: {note}" for note in notes])
        results = []
        for entry in etree.fromstring(data).iterfind("Related"):
            source, role = entry.get("source"), entry.get("role")
            member = _resolve(archive, source)
            if member is None:
                shipped.notes.append(f"{MANIFEST} names {source!r} ({role}), which the FMU does not contain")
            elif role.startswith("experiment") and member.endswith(".xml"):
                shipped.results += _experiments(archive, member, shipped.notes)
            elif role == "result" and member.lower().endswith(".csv"):
                results.append(member)
        described = {_resolve(archive, e.get("source")) for e in etree.fromstring(data).iterfind("Related")}
        described |= {_stimulus(member) for member in results}
        for member in sorted(set(archive.namelist())):
            if member.startswith(FOLDER + "/") and not member.endswith("/") and member not in described | {MANIFEST}:
                shipped.notes.append(f"{member} is not described in the manifest: not read")
        listed = {c.member for c in shipped.results}
        for member in results:
            if member not in listed:
                stimulus = _stimulus(member) if _stimulus(member) in archive.namelist() else None
                shipped.results.append(Carried(member, _text(archive, member), stimulus,
                                               _text(archive, stimulus) if stimulus else None))
        return shipped


def _text(archive: zipfile.ZipFile, member: str) -> str:
    """A member's text; BadInput naming the FMU and the member when it is not UTF-8."""
    try:
        return archive.read(member).decode("utf-8")
    except UnicodeDecodeError as error:
        raise BadInput(f"{archive.filename}: {member}: not UTF-8 text (byte {error.start}: "
                       f"{error.object[error.start:error.start + 1]!r})") from None


def _stimulus(result: str) -> str | None:
    """The stimulus member that goes with a result member: X_out.csv, X_in.csv."""
    return result[:-len(RESULT)] + STIMULUS if result.endswith(RESULT) else None


def _experiments(archive: zipfile.ZipFile, member: str, notes: list[str]) -> list[Carried]:
    """The reference results and stimuli of pendfmu 0.x's experiments.xml (<Experiments>
    <Experiment><Stimuli source/><References source/></Experiment>); a file it names that
    the FMU lacks is a note. An experiment file in another XML format is a note too; one that
    is not XML is BadInput."""
    try:
        root = etree.fromstring(archive.read(member))
    except etree.XMLSyntaxError as error:  # broken (or an entity bomb): the FMU's failure, named
        raise BadInput(f"{archive.filename}: {member}: not XML: {error}") from None
    if root.tag != "Experiments":
        notes.append(f"{member}: an experiment file pendfmu check does not read")
        return []
    found = []
    for experiment in root.iterfind("Experiment"):
        references, stimuli = experiment.find("References"), experiment.find("Stimuli")
        if references is None:
            continue
        ref = _resolve(archive, references.get("source", ""))
        stim = _resolve(archive, stimuli.get("source", "")) if stimuli is not None else None
        if ref is None or (stimuli is not None and stim is None):
            notes.append(f"{member} names a file the FMU does not contain")
            continue
        found.append(Carried(ref, _text(archive, ref), stim, _text(archive, stim) if stim else None))
    return found
