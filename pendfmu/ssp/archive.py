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
import zlib
from pathlib import Path, PurePosixPath

from pendfmu.atomic import write_atomically
from pendfmu.ssp._xml import Locator, SspError, safe_parser
from pendfmu.ssp.check import check_system
from pendfmu.ssp.fmu import check_against_fmu
from pendfmu.ssp.model import FmuComponent, System
from pendfmu.ssp.ssd import read_ssd, resolve_source, write_ssd
from pendfmu.tempfolders import temporary_folder

SSD_NAME = "SystemStructure.ssd"  # the default SSD every SSP must have, at the archive root
# What an SSP may make pendfmu unpack: a zip of 1.8 MB can hold 1 GiB of zeros. Only the SSD
# and the files it names are unpacked, and within these limits.
MAX_MEMBERS = 10_000            # an SSP holds an SSD, SSV files and FMUs: tens of members, not thousands
MAX_MEMBER_BYTES = 1 << 30      # one member: an FMU with binaries for several platforms runs to hundreds of MB
MAX_TOTAL_BYTES = 4 << 30       # all members unpacked for one system


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

    Parameters
    ----------
    system : System
        The system; every component's `fmu` must be a file.
    path : str or Path
        The archive (``.ssp``), replaced whole if it exists: never half-written.
    system_connectors : bool, optional
        Whether the SSD holds the system's own connectors.

    Returns
    -------
    Path
        The archive written (`path`).

    Raises
    ------
    SspError
        The system is inconsistent, a component has no FMU file, a connector contradicts
        its FMU, or two components name one source with different files.
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

        def pack(out) -> None:
            with zipfile.ZipFile(out, "w", compression=zipfile.ZIP_DEFLATED) as archive:
                for file in files:
                    archive.write(file, file.relative_to(root).as_posix())

        return write_atomically(path, writer=pack)  # never a half-written archive


def _open_archive(path: Path) -> zipfile.ZipFile:
    try:
        return zipfile.ZipFile(path)
    except (OSError, zipfile.BadZipFile) as exc:
        raise SspError(path, f"is not a readable SSP (zip) archive: {exc}") from exc


def _members(path: Path, archive: zipfile.ZipFile) -> dict[str, zipfile.ZipInfo]:
    """The archive's files by their normalized names, refusing before anything is unpacked:
    too many members, a member that points outside the archive (zip slip), two members of
    one name (also where only the case differs: one file on Windows and macOS), and a name
    that is a file and a folder at once (resources, resources/Cart.fmu)."""
    infos = archive.infolist()
    if len(infos) > MAX_MEMBERS:
        raise SspError(path, f"holds {len(infos)} members, more than an SSP may ({MAX_MEMBERS})")
    files: dict[str, zipfile.ZipInfo] = {}
    seen: dict[str, str] = {}
    folders: dict[str, str] = {}
    for info in infos:
        member = PurePosixPath(info.filename.replace("\\", "/"))
        if member.is_absolute() or ".." in member.parts or not member.parts:
            raise SspError(path, f"archive member {info.filename!r} points outside the archive")
        name = member.as_posix()
        if name.casefold() in seen:
            raise SspError(path, f"archive members {seen[name.casefold()]!r} and {info.filename!r} name one file")
        seen[name.casefold()] = info.filename
        for parent in list(member.parents)[:-1]:
            folders.setdefault(parent.as_posix().casefold(), info.filename)
        if not info.is_dir():
            files[name] = info
    for name, info in files.items():
        if name.casefold() in folders:
            raise SspError(path, f"archive member {info.filename!r} is a file, but {folders[name.casefold()]!r} "
                                 f"makes it a folder")
    return files


def _referenced(ssd_file: Path, root: Path) -> list[str]:
    """The archive paths the SSD names (every ``source``: components' FMUs, parameter value
    and mapping files) that lie inside the archive, as ssd.py resolves them; an SSD that does
    not parse names none (reading it then says why)."""
    from lxml import etree

    try:
        document = etree.parse(str(ssd_file), safe_parser())
    except etree.XMLSyntaxError:
        return []
    names = []
    for element in document.iter():
        source = element.get("source") if isinstance(element.tag, str) else None
        local = resolve_source(root, source) if source else None
        if local is not None:
            names.append(local.relative_to(root).as_posix())
    return names


def _unpack(path: Path, archive: zipfile.ZipFile, info: zipfile.ZipInfo, target: Path, unpacked: int) -> int:
    """Unpack one member below `target` (its size checked against the limits first, its
    CRC checked as it is read); returns the bytes unpacked so far, this member included."""
    if info.file_size > MAX_MEMBER_BYTES:
        raise SspError(f"{path}!{info.filename}", f"unpacks to {info.file_size} bytes, more than a member of an SSP "
                                                  f"may ({MAX_MEMBER_BYTES})")
    if unpacked + info.file_size > MAX_TOTAL_BYTES:
        raise SspError(path, f"the members the system names unpack to more than {MAX_TOTAL_BYTES} bytes")
    destination = target.joinpath(*PurePosixPath(info.filename.replace("\\", "/")).parts)
    destination.parent.mkdir(parents=True, exist_ok=True)
    try:
        with archive.open(info) as member:
            write_atomically(destination, iter(lambda: member.read(1 << 20), b""))
    except (zipfile.BadZipFile, zlib.error, EOFError, RuntimeError, NotImplementedError) as exc:
        raise SspError(f"{path}!{info.filename}", f"cannot be unpacked: {exc}") from None
    return unpacked + info.file_size


def _extract(path: Path, target: Path) -> None:
    """Unpack into `target` the SSD of `path` and the members it names, nothing else."""
    with _open_archive(path) as archive:
        files = _members(path, archive)
        if SSD_NAME not in files:
            raise SspError(path, f"has no {SSD_NAME} at its root, which every SSP must have")
        unpacked = _unpack(path, archive, files[SSD_NAME], target, 0)
        for name in dict.fromkeys(_referenced(target / SSD_NAME, target)):
            if name in files:
                unpacked = _unpack(path, archive, files[name], target, unpacked)


def read_ssp(path: str | Path, extract_dir: str | Path | None = None) -> System:
    """Read an SSP archive: unpack its SSD and the files the SSD names (its FMUs and SSVs),
    within MAX_MEMBERS, MAX_MEMBER_BYTES and MAX_TOTAL_BYTES, and read them.

    The archive is unpacked into `extract_dir` (which the caller owns), else into a new
    temporary folder removed when the process ends (tempfolders.py), or at once when the
    archive is refused; the components' ``fmu`` paths point into it, so the returned system
    can be simulated directly. Errors name the archive and the member, e.g.
    ``rig.ssp!SystemStructure.ssd:12: <ssd:Connection ...>: ...``.

    Parameters
    ----------
    path : str or Path
        The archive.
    extract_dir : str or Path, optional
        Where to unpack it (created if needed; the caller removes it).

    Returns
    -------
    System
        The system, its components' `fmu` paths in the unpacked folder.

    Raises
    ------
    SspError
        The archive, its SSD or an SSV is not acceptable, an FMU it names is missing, or
        it is past the size limits.
    """
    path = Path(path)
    if extract_dir is not None:
        Path(extract_dir).mkdir(parents=True, exist_ok=True)
        return _read_into(path, Path(extract_dir))
    target = temporary_folder("pendfmu-ssp-")
    try:
        return _read_into(path, target)
    except BaseException:
        shutil.rmtree(target, ignore_errors=True)
        raise


def _read_into(path: Path, target: Path) -> System:
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
