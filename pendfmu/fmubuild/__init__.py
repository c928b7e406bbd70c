"""Build the component FMUs from their C sources (``pendfmu build``): FMI 2.0 into fmus/,
FMI 3.0 into fmus/fmi3/."""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from pendfmu.components import ALL_COMPONENTS
from pendfmu.console import progress
from pendfmu.fmubuild.compiler import FMI_VERSIONS, BuildError, build_fmu, compute_guid, fmu_path

__all__ = ["BuildError", "FMI_VERSIONS", "build_all", "build_fmu", "compute_guid", "fmu_path", "ensure_fmu"]


def build_all(force: bool = False, folder: Path | None = None, fmi_version: int = 2) -> dict[str, Path]:
    """Build every component FMU of one FMI version that is missing or stale.

    Parameters
    ----------
    force : bool, optional
        Build even FMUs whose sources have not changed.
    folder : Path, optional
        Where the FMUs go; by default the FMU folder pendfmu loads from
        (compiler.fmu_folder: ``$PENDFMU_FMU_DIR``, a checkout's ``fmus/``, or the user
        cache).
    fmi_version : int, optional
        2 or 3 (:data:`FMI_VERSIONS`); FMI 3.0 FMUs go into ``fmi3/`` of the folder.

    Returns
    -------
    dict of str to Path
        Each component's FMU file, by component name.

    Raises
    ------
    BuildError
        No C compiler, or the compiler refused the sources.
    """
    # The components side by side, one per core (each already compiles its platforms side by
    # side): a build from scratch took 61 s on two cores one component at a time, the win64
    # cross-compiler's link-time optimization most of it, with a core idle.
    with ThreadPoolExecutor(os.cpu_count() or 1) as pool:
        built = {name: pool.submit(build_fmu, component, force=force, fmi_version=fmi_version, folder=folder)
                 for name, component in ALL_COMPONENTS.items()}
        return {name: built[name].result()  # a BuildError is raised here, the others finished
                for name in progress(built, f"building FMI {fmi_version} FMUs")}


def ensure_fmu(name: str, fmi_version: int = 2) -> Path:
    """The FMU of a component, built first if missing or stale: what every simulation
    loads, so a fresh install or a changed source needs no separate build step.

    Parameters
    ----------
    name : str
        The component: "CurrentLoop", "Cart", "Pendulum", ... (components.ALL_COMPONENTS).
    fmi_version : int, optional
        2 or 3.

    Returns
    -------
    Path
        The FMU file, in the FMU folder pendfmu loads from.

    Raises
    ------
    KeyError
        `name` is not a component.
    BuildError
        The FMU had to be built and could not be.
    """
    if name not in ALL_COMPONENTS:
        raise KeyError(f"no component {name!r}; known: {', '.join(ALL_COMPONENTS)}")
    return build_fmu(ALL_COMPONENTS[name], fmi_version=fmi_version)
