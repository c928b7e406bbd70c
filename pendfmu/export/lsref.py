"""Reference results inside the FMU, in the layout of FMI-LS-REF (the FMI layered standard
for references, "related files" of an FMU).

The standard's text was not found; the layout follows what its published pieces show (the
XSD of the manifest, fmi3LayeredStandardReferenceManifest.xsd, and implementations of
version 1.0.0-alpha.1):

    extra/org.fmi-standard.fmi-ls-ref/fmi-ls-manifest.xml   root <fmiReferences> with the
        fmi-ls:fmi-ls-name / -version / -description attributes of every layered standard
        manifest (namespace http://fmi-standard.org/fmi-ls-manifest) and one
        <Related source="..." role="..." type="..." description="..."/> per file; sources
        are URIs relative to the manifest; roles from the standard's list (result,
        experiment[/validation|/smoke-test|...], testcase, parameter, other, ...)
    extra/org.fmi-standard.fmi-ls-ref/experiments.xml        <Experiments name=...>
        <Experiment name=... startTime stopTime> <Stimuli source type/> <References source
        type/> </Experiment>: which stimulus goes with which reference result
    extra/org.fmi-standard.fmi-ls-ref/reference.csv          role "result"
    extra/org.fmi-standard.fmi-ls-ref/stimulus.csv           role "other" (the experiment's
                                                             stimulus; the role list has none
                                                             closer)

`add_references(fmu, reference_csv, stimulus_csv)` writes them into an FMU (replacing an
earlier set); `carried(path)` reads them back for `pendfmu check`.
"""

from __future__ import annotations

import os
import re
import zipfile
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

from lxml import etree

from pendfmu.errors import BadInput

FOLDER = "extra/org.fmi-standard.fmi-ls-ref"
MANIFEST = f"{FOLDER}/fmi-ls-manifest.xml"
EXPERIMENTS = "experiments.xml"
REFERENCE = "reference.csv"
STIMULUS = "stimulus.csv"
LS_NAMESPACE = "http://fmi-standard.org/fmi-ls-manifest"
LS_NAME = "org.fmi-standard.fmi-ls-ref"
LS_VERSION = "1.0.0-alpha.1"
LS_DESCRIPTION = "Layered Standard providing information on related files included in an FMU."
ROLE = re.compile(r"(document|requirement|specification|model|parameter|system|testcase|"
                  r"experiment(/(smoke-test|validation|uncertainty-analysis))?|result|method|rationale|report|"
                  r"request|delivery|configuration|signature|serialized-state(/.*)?|other)")


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
        entry.set("description", description)
    return etree.tostring(root, xml_declaration=True, encoding="UTF-8", pretty_print=True)


def experiments_xml(stop: float, stimulus: str | None) -> bytes:
    root = etree.Element("Experiments", name="pendfmu export")
    experiment = etree.SubElement(root, "Experiment", name="reference", startTime="0", stopTime=repr(float(stop)),
                                  description="the FMU driven by the stimulus reproduces the reference results")
    if stimulus:
        etree.SubElement(experiment, "Stimuli", source=stimulus, type="text/csv")
    etree.SubElement(experiment, "References", source=REFERENCE, type="text/csv")
    return etree.tostring(root, xml_declaration=True, encoding="UTF-8", pretty_print=True)


def check_manifest(data: bytes) -> list[str]:
    """What is wrong with an FMI-LS-REF manifest (empty: nothing): the root, its three
    fmi-ls attributes (name and description fixed by the standard), each Related entry's
    required source and role (role from the standard's list)."""
    try:
        root = etree.fromstring(data)
    except etree.XMLSyntaxError as error:
        return [f"not XML: {error}"]
    problems = []
    if root.tag != "fmiReferences":
        problems.append(f"root element {root.tag!r}, not 'fmiReferences'")
    for attribute, fixed in (("fmi-ls-name", LS_NAME), ("fmi-ls-version", None), ("fmi-ls-description", LS_DESCRIPTION)):
        value = root.get(_ls(attribute))
        if value is None:
            problems.append(f"no fmi-ls:{attribute} attribute")
        elif fixed is not None and value != fixed:
            problems.append(f"fmi-ls:{attribute} is {value!r}, must be {fixed!r}")
    for child in root:
        if not isinstance(child.tag, str):
            continue  # comments
        if child.tag != "Related":
            problems.append(f"unexpected element {child.tag!r}")
            continue
        if not child.get("source"):
            problems.append("a Related element without source")
        if child.get("role") is None or not ROLE.fullmatch(child.get("role")):
            problems.append(f"Related {child.get('source')!r}: role {child.get('role')!r} is not one of the standard's")
    return problems


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


def add_references(fmu: str | Path, reference_csv: str | Path, stimulus_csv: str | Path | None = None) -> Path:
    """Store the reference results (and the stimulus) in the FMU at `fmu`, in place, under
    extra/org.fmi-standard.fmi-ls-ref/ with its manifest; an earlier set is replaced."""
    fmu = Path(fmu)
    reference = _read_text(reference_csv, "reference")
    stimulus = _read_text(stimulus_csv, "stimulus") if stimulus_csv else None
    rows = [line.split(",")[0] for line in reference.splitlines()[1:] if line.strip()]
    try:
        stop = float(rows[-1])
    except (IndexError, ValueError):
        raise BadInput(f"{reference_csv}: needs a header and rows with time first") from None
    related = [(EXPERIMENTS, "experiment/validation", "application/xml",
                "the experiment: stimulus and reference results"),
               (REFERENCE, "result", "text/csv", f"reference results (from {Path(reference_csv).name})")]
    if stimulus is not None:
        related.append((STIMULUS, "other", "text/csv", f"stimulus of the experiment: the inputs over time "
                                                       f"(from {Path(stimulus_csv).name})"))
    members = {MANIFEST: manifest_xml(related), f"{FOLDER}/{EXPERIMENTS}": experiments_xml(stop, STIMULUS if stimulus
                                                                                          else None),
               f"{FOLDER}/{REFERENCE}": reference.encode()}
    if stimulus is not None:
        members[f"{FOLDER}/{STIMULUS}"] = stimulus.encode()
    from pendfmu.export.fmu import _copy_info

    partial = fmu.with_name(f".{fmu.name}.{os.getpid()}.ref.part")
    try:
        with zipfile.ZipFile(fmu) as src, zipfile.ZipFile(partial, "w", zipfile.ZIP_DEFLATED) as dst:
            for info in src.infolist():
                if not info.filename.startswith(FOLDER + "/"):
                    dst.writestr(_copy_info(info), src.read(info))
            for name, data in members.items():
                info = zipfile.ZipInfo(name, _now_tuple())
                info.compress_type = zipfile.ZIP_DEFLATED
                info.external_attr = 0o644 << 16
                dst.writestr(info, data)
        os.replace(partial, fmu)
    finally:
        partial.unlink(missing_ok=True)
    return fmu


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


def carried(path: str | Path) -> list[Carried]:
    """The reference results an FMU carries under extra/org.fmi-standard.fmi-ls-ref/:
    each Experiment's References (with its Stimuli) from an experiment file, else each
    Related file of role "result". Raises BadInput for a manifest the standard does not
    allow or a file it names that is missing."""
    with zipfile.ZipFile(path) as archive:
        if MANIFEST not in archive.namelist():
            return []
        data = archive.read(MANIFEST)
        problems = check_manifest(data)
        if problems:
            raise BadInput(f"{path}: {MANIFEST}: {'; '.join(problems)}")
        found: list[Carried] = []
        results = []
        for entry in etree.fromstring(data).iterfind("Related"):
            source, role = entry.get("source"), entry.get("role")
            member = _resolve(archive, source)
            if member is None:
                raise BadInput(f"{path}: {MANIFEST} names {source!r}, which the FMU does not contain")
            if role.startswith("experiment") and member.endswith(".xml"):
                for experiment in etree.fromstring(archive.read(member)).iterfind("Experiment"):
                    references = experiment.find("References")
                    if references is None:
                        continue
                    ref_member = _resolve(archive, references.get("source", ""))
                    stimuli = experiment.find("Stimuli")
                    stim_member = _resolve(archive, stimuli.get("source", "")) if stimuli is not None else None
                    if ref_member is None or (stimuli is not None and stim_member is None):
                        raise BadInput(f"{path}: {member} names a file the FMU does not contain")
                    found.append(Carried(ref_member, archive.read(ref_member).decode(), stim_member,
                                         archive.read(stim_member).decode() if stim_member else None))
            elif role == "result" and member.lower().endswith(".csv"):
                results.append(member)
        listed = {c.member for c in found}
        for member in results:
            if member not in listed:
                found.append(Carried(member, archive.read(member).decode(), None, None))
        return found
