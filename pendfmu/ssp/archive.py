"""SSP archives (``.ssp``): a zip with ``SystemStructure.ssd`` at its root and the files
it references (FMUs and SSV parameter files) under ``resources/``.

The parameter values are in the archive twice, so that every importer uses them without
being told to: in the SSV files the components' ParameterBindings name (the standard's
place; pendfmu and libcosim apply them by default), and, for pendfmu's own components, as
the start values of the packed FMUs themselves (a parameterized copy as `pendfmu export`
writes it, whose binary computes with them: pendfmu/export/fmu.py). ecos 0.7.2 applies a
parameter set only when it is named on its command line and fmpy's simulate_ssp ignores
ParameterBindings (TOOL-NOTES.md); both run the packed FMUs with the system's values.
A user's FMU is packed as it is: its values reach other tools through the SSV files only.
"""

from __future__ import annotations

import shutil
import tempfile
import zipfile
from pathlib import Path, PurePosixPath

from pendfmu.ssp._xml import Locator, SspError
from pendfmu.ssp.check import check_system
from pendfmu.ssp.fmu import check_against_fmu
from pendfmu.ssp.model import FmuComponent, System
from pendfmu.ssp.ssd import read_ssd, write_ssd

SSD_NAME = "SystemStructure.ssd"  # the default SSD every SSP must have, at the archive root


def _member_name(system: System, source: str) -> str:
    """The archive path of a component source: relative, below the root, as the standard asks."""
    path = PurePosixPath(source)
    if path.is_absolute() or ".." in path.parts or ":" in source:
        raise SspError(f"system {system.name!r}", f"component source {source!r} must be a relative path "
                                                  "inside the archive, e.g. resources/Cart.fmu")
    return str(path)


def own_component(fmu: Path) -> str | None:
    """The name of pendfmu's component whose build (or parameterized copy) `fmu` is, else None:
    only those binaries read the start file a parameterized copy carries."""
    from fmpy import read_model_description

    from pendfmu.components import ALL_COMPONENTS
    from pendfmu.export.fmu import START_FILE
    from pendfmu.fmubuild import ensure_fmu
    from pendfmu.fmubuild.compiler import built_guid

    description = read_model_description(str(fmu), validate=False)
    kind = description.coSimulation.modelIdentifier if description.coSimulation is not None else None
    if kind not in ALL_COMPONENTS:
        return None
    with zipfile.ZipFile(fmu) as archive:
        if START_FILE in archive.namelist():
            return kind
    return kind if built_guid(ensure_fmu(kind)) == description.guid else None  # the build's, parsed once


def _start_values(system: System, component: FmuComponent) -> dict[str, float]:
    """The Real parameter values the system gives `component` (what a parameterized copy carries)."""
    values = {}
    for name, given in system.parameters.get(component.name, {}).items():
        connector = component.connector(name)
        if given.type == "Real" and connector is not None and connector.kind == "parameter":
            values[name] = float(given.value)
    return values


def _pack_fmu(system: System, users: list[FmuComponent], target: Path) -> None:
    """Put the FMU the components `users` share at `target`: pendfmu's own as a copy whose
    start values are the system's values (module docstring), any other as it is. One file
    holds one set of start values: components sharing it with different values get the FMU
    as it is, and their values through the SSV files only."""
    from pendfmu.export.fmu import write_parameterized_fmu

    fmu = Path(users[0].fmu)
    kind = own_component(fmu)
    values = [_start_values(system, component) for component in users]
    if kind is None or any(v != values[0] for v in values[1:]):
        shutil.copyfile(fmu, target)
        return
    write_parameterized_fmu(kind, values[0], target, f"SSP system {system.name!r}, parameter set "
                                                     f"{system.parameter_set!r}")


def write_ssp(system: System, path: str | Path, *, system_connectors: bool = True) -> Path:
    """Write `system` as an SSP archive holding the SSD, the components' FMUs and the SSV files.

    Every component needs its FMU on disk (``component.fmu``); connectors are checked against
    it before packing, so an archive never contains an SSD that contradicts its FMUs.
    `system_connectors` False leaves the system's own connectors out of the SSD, for ecos and
    libcosim, which refuse connections to them (ssd.py).
    """
    path = Path(path)
    check_system(system)
    for component in system.components.values():
        if component.fmu is None or not Path(component.fmu).is_file():
            raise SspError(f"system {system.name!r}", f"component {component.name!r} has no FMU file to pack "
                                                      f"(fmu={component.fmu})")
        check_against_fmu(component, Locator(f"system {system.name!r}"))
    with tempfile.TemporaryDirectory(prefix="pendfmu-ssp-") as tmp:
        root = Path(tmp)
        files = write_ssd(system, root / SSD_NAME, system_connectors=system_connectors)
        sources: dict[str, list[FmuComponent]] = {}
        for component in system.components.values():
            sources.setdefault(_member_name(system, component.source), []).append(component)
        for member, users in sources.items():
            if len({Path(u.fmu).resolve() for u in users}) > 1:
                raise SspError(f"system {system.name!r}", f"components {', '.join(u.name for u in users)} name "
                                                          f"the same source {member!r} but different FMU files")
            target = root / member
            target.parent.mkdir(parents=True, exist_ok=True)
            _pack_fmu(system, users, target)
            files.append(target)
        partial = path.with_name(path.name + ".part")  # never leave a half-written archive behind
        with zipfile.ZipFile(partial, "w", compression=zipfile.ZIP_DEFLATED) as archive:
            for file in files:
                archive.write(file, file.relative_to(root).as_posix())
        partial.replace(path)
    return path


def _extract(path: Path, target: Path) -> None:
    """Unzip `path` into `target`, refusing members that would land outside it."""
    try:
        archive = zipfile.ZipFile(path)
    except (OSError, zipfile.BadZipFile) as exc:
        raise SspError(path, f"is not a readable SSP (zip) archive: {exc}") from exc
    with archive:
        for member in archive.namelist():
            parts = PurePosixPath(member).parts
            if PurePosixPath(member).is_absolute() or ".." in parts:
                raise SspError(path, f"archive member {member!r} points outside the archive")
        if SSD_NAME not in archive.namelist():
            raise SspError(path, f"has no {SSD_NAME} at its root, which every SSP must have")
        archive.extractall(target)


def read_ssp(path: str | Path, extract_dir: str | Path | None = None) -> System:
    """Read an SSP archive: unpack it and read its SystemStructure.ssd with its FMUs and SSVs.

    The archive is unpacked into `extract_dir` (a new temporary directory if None, which the
    caller then owns); the components' ``fmu`` paths point into it, so the returned system
    can be simulated directly. Errors name the archive and the member, e.g.
    ``rig.ssp!SystemStructure.ssd:12: <ssd:Connection ...>: ...``.
    """
    path = Path(path)
    target = Path(extract_dir) if extract_dir is not None else Path(tempfile.mkdtemp(prefix="pendfmu-ssp-"))
    target.mkdir(parents=True, exist_ok=True)
    _extract(path, target)
    try:
        return read_ssd(target / SSD_NAME, require_fmus=True)
    except SspError as exc:
        raise exc.in_file(_archive_name(path, target, exc.file)) from exc


def _archive_name(archive: Path, extracted: Path, file: str | None) -> str:
    """Report a file of the unpacked archive as ``archive.ssp!member``."""
    if file is None:
        return str(archive)
    try:
        return f"{archive}!{Path(file).resolve().relative_to(extracted.resolve()).as_posix()}"
    except ValueError:
        return file
