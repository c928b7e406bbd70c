"""Build the component FMUs from their C sources (``pendfmu build``)."""

from __future__ import annotations

from pathlib import Path

from pendfmu.components import ALL_COMPONENTS
from pendfmu.console import progress
from pendfmu.fmubuild.compiler import BuildError, build_fmu, compute_guid, fmu_path

__all__ = ["BuildError", "build_all", "build_fmu", "compute_guid", "fmu_path", "ensure_fmu"]


def build_all(force: bool = False, folder: Path | None = None) -> dict[str, Path]:
    """Build every component FMU that is missing or stale in `folder` (default: the FMU
    folder pendfmu loads from, compiler.fmu_folder); return their paths by name."""
    return {name: build_fmu(component, force=force, folder=folder)
            for name, component in progress(ALL_COMPONENTS.items(), "building FMUs", label=lambda item: item[0])}


def ensure_fmu(name: str) -> Path:
    """The path of component `name`'s FMU, built first if missing or stale."""
    if name not in ALL_COMPONENTS:
        raise KeyError(f"no component {name!r}; known: {', '.join(ALL_COMPONENTS)}")
    return build_fmu(ALL_COMPONENTS[name])
