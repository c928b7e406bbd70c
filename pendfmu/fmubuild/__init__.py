"""Build the component FMUs from their C sources (``pendfmu build``): FMI 2.0 into fmus/,
FMI 3.0 into fmus/fmi3/."""

from __future__ import annotations

from pathlib import Path

from pendfmu.components import ALL_COMPONENTS
from pendfmu.console import progress
from pendfmu.fmubuild.compiler import FMI_VERSIONS, BuildError, build_fmu, compute_guid, fmu_path

__all__ = ["BuildError", "FMI_VERSIONS", "build_all", "build_fmu", "compute_guid", "fmu_path", "ensure_fmu"]


def build_all(force: bool = False, folder: Path | None = None, fmi_version: int = 2) -> dict[str, Path]:
    """Build every component FMU of one FMI version that is missing or stale in `folder`
    (default: the FMU folder pendfmu loads from, compiler.fmu_folder); return their paths
    by name."""
    return {name: build_fmu(component, force=force, fmi_version=fmi_version, folder=folder)
            for name, component in progress(ALL_COMPONENTS.items(), f"building FMI {fmi_version} FMUs",
                                            label=lambda item: item[0])}


def ensure_fmu(name: str, fmi_version: int = 2) -> Path:
    """The path of component `name`'s FMU (FMI 2.0 or 3.0), built first if missing or stale."""
    if name not in ALL_COMPONENTS:
        raise KeyError(f"no component {name!r}; known: {', '.join(ALL_COMPONENTS)}")
    return build_fmu(ALL_COMPONENTS[name], fmi_version=fmi_version)
