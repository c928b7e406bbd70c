"""Build the component FMUs from their C sources (``pendfmu build``): FMI 2.0 into fmus/,
FMI 3.0 into fmus/fmi3/."""

from __future__ import annotations

from pathlib import Path

from pendfmu.components import ALL_COMPONENTS
from pendfmu.fmubuild.compiler import FMI_VERSIONS, BuildError, build_fmu, compute_guid, fmu_path

__all__ = ["BuildError", "FMI_VERSIONS", "build_all", "build_fmu", "compute_guid", "fmu_path", "ensure_fmu"]


def build_all(force: bool = False, fmi_version: int = 2) -> dict[str, Path]:
    """Build every component FMU of one FMI version that is missing or stale; return their
    paths by name."""
    return {name: build_fmu(component, force=force, fmi_version=fmi_version)
            for name, component in ALL_COMPONENTS.items()}


def ensure_fmu(name: str, fmi_version: int = 2) -> Path:
    """The path of component `name`'s FMU (FMI 2.0 or 3.0), built first if missing or stale."""
    if name not in ALL_COMPONENTS:
        raise KeyError(f"no component {name!r}; known: {', '.join(ALL_COMPONENTS)}")
    return build_fmu(ALL_COMPONENTS[name], fmi_version=fmi_version)
