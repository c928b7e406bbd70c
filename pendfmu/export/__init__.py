"""Export identified parameters for other tools (``pendfmu export``).

:func:`export_all` writes, into one directory:

- ``<Name>.fmu`` for each exported component: the built FMU with the new parameter start
  values, a fresh GUID and ``resources/pendfmu-start.txt``; binaries and sources are the
  original bytes (:mod:`pendfmu.export.fmu`); ``fmi3/<Name>.fmu`` the same for the
  component's FMI 3.0 FMU;
- ``parameters.ssv``: SSP 1.0 parameter values, named ``Component.parameter``
  (:mod:`pendfmu.export.ssv`);
- ``modifiers.mo``: Modelica declarations and a complete rig model for the PendulumID
  library (:mod:`pendfmu.export.modelica`);
- ``set_parameters.m`` and ``parameters.mat``: the values for Simulink's FMU Import blocks,
  a MATLAB function that sets them on the blocks (checking each block loads the exported
  FMU) and the same values as MATLAB structs (:mod:`pendfmu.export.simulink`);
- ``rig.ssp`` and ``rig-flat.ssp`` when the export holds the whole rig: the rig as SSP
  archives, with and without the system's own connectors (:mod:`pendfmu.export.rig`).

Which components are exported and which values each receives is decided first, by
:func:`plan_export` (:mod:`pendfmu.export.plan`), so a bad value stops the export before
any file is written.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from pathlib import Path

from pendfmu.errors import UsageError
from pendfmu.escaping import xml_text
from pendfmu.export.fmu import START_FILE, write_parameterized_fmu
from pendfmu.export.modelica import write_modifiers
from pendfmu.export.plan import ExportPlan, plan_export
from pendfmu.export.rig import write_rig_ssps
from pendfmu.export.simulink import block_values, write_simulink_files
from pendfmu.export.ssv import write_parameter_values

__all__ = ["ExportPlan", "START_FILE", "export_all", "export_result", "plan_export", "write_export"]

SSV_FILE = "parameters.ssv"
MODELICA_FILE = "modifiers.mo"


def write_export(plan: ExportPlan, out_dir: str | Path) -> list[Path]:
    """Write the files of a checked plan into a folder: the parameterized FMUs (FMI 2.0,
    and FMI 3.0 under ``fmi3/``), the SSV, Modelica and Simulink files, and the rig's SSP
    archives when the plan holds the whole rig.

    Parameters
    ----------
    plan : ExportPlan
        What to write, from :func:`plan_export` (its values are checked there).
    out_dir : str or Path
        The folder, created if needed; files of the same names in it are replaced.

    Returns
    -------
    list of Path
        The files written, the FMI 2.0 FMUs first.

    Raises
    ------
    UsageError
        `out_dir` exists and is not a folder.
    """
    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise UsageError(f"{out_dir}: exists and is not a directory")
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = [write_parameterized_fmu(name, values, out_dir / f"{name}.fmu", plan.source)
             for name, values in plan.components.items()]
    values = {name: plan.start_values(name) for name in plan.components}
    set_name = xml_text(Path(plan.source).stem) if plan.source.endswith(".json") else "exported"
    paths.append(write_parameter_values(values, out_dir / SSV_FILE, set_name))
    paths.append(write_modifiers(plan, out_dir / MODELICA_FILE))
    blocks = [block_values(name, fmu, values[name], plan.components[name], plan.source)
              for name, fmu in zip(plan.components, paths)]
    paths += write_simulink_files(blocks, out_dir, plan.source)
    paths += [write_parameterized_fmu(name, given, out_dir / "fmi3" / f"{name}.fmu", plan.source, fmi_version=3)
              for name, given in plan.components.items()]
    if plan.holds_the_rig:
        paths += write_rig_ssps(plan, out_dir)
    return paths


def export_all(parameters: Mapping[str, object], out_dir: str | Path, *, components: Iterable[str] | None = None,
               source: str | None = None) -> list[Path]:
    """Check rig parameter values and write the FMUs, SSV, Modelica and Simulink files
    that carry them: :func:`plan_export`, then :func:`write_export`.

    Parameters
    ----------
    parameters : mapping of str to float
        Rig parameter values by name, in SI units, named as in docs/user-guide/model.md
        (``m_p`` [kg], ``l`` [m], ``k_fwc`` [N·s/m], ``F_Kc`` [N], ...).
    out_dir : str or Path
        The folder, created if needed.
    components : iterable of str, optional
        The components whose FMUs are written; by default every component one of the
        given names belongs to (all three when none is given).
    source : str, optional
        Where the values came from (the parameters file), for the descriptions in the
        files.

    Returns
    -------
    list of Path
        What :func:`write_export` returns.

    Raises
    ------
    ParameterFileError
        An unknown name, or a value a component cannot take: nothing is written.
    UsageError
        `out_dir` exists and is not a folder.
    """
    return write_export(plan_export(parameters, components, source), out_dir)


def export_result(result, out_dir: str | Path) -> list[Path]:
    """Write the files of :func:`export_all` for a fit result.

    For a fit of pendfmu's rig, its components with the fitted values; for a fit of a
    user's FMU or SSP system, a copy of that model's FMUs with the fitted values as their
    start values, with the SSV and Simulink files (export.model).

    Parameters
    ----------
    result : FitResult
        The fit (pendfmu.fitting.result); its `parameters` are exported.
    out_dir : str or Path
        The folder, created if needed.

    Returns
    -------
    list of Path
        The files written, the FMUs first.
    """
    if result.model:
        from pendfmu.export.model import export_model
        from pendfmu.simulator.model import Model

        return export_model(Model.load(result.model), result.parameters, out_dir, f"a pendfmu fit ({result.stage})")
    return export_all(result.parameters, out_dir)
