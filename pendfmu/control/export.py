"""A design as the RigController FMU: its values written as the FMU's start values.

The component's variable table (components.RIG_CONTROLLER) is the one source; a design
only changes the start values of its parameters, so the FMU built for it is the same C
code with the design's numbers, each still a parameter a user may retune without compiling.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from pendfmu.components import RIG_CONTROLLER, RIG_LQR_STATES, RIG_READINGS, RIG_STATES, Component
from pendfmu.control.design import Design

# RigModel's field -> the FMU parameter of that meaning (the same name where the model page has one)
_RIG_NAMES = {"M": "M", "m": "m_p", "l": "l", "J": "J_p", "g": "g", "eta": "eta", "A": "A_back", "k_F": "k_F",
              "k_fwc": "k_fwc", "F_Kc": "F_Kc", "F_Sc": "F_Sc", "k_fwp": "k_fwp", "T_i": "T_i",
              "dIdt_max": "dIdt_max"}
_LAW_NAMES = ("T_s", "I_max", "x_max", "k_E", "a_swing", "k_xs", "k_vs", "phi_catch", "v_stuck", "F_ramp",
              "x_quantum", "phi_quantum")


def fmu_parameters(design: Design) -> dict[str, float | bool]:
    """The RigController's parameter values for `design`."""
    values: dict[str, float | bool] = {_RIG_NAMES[f]: getattr(design.rig, f) for f in _RIG_NAMES}
    values.update({name: getattr(design, name) for name in _LAW_NAMES})
    values.update({f"K_{s}": k for s, k in zip(RIG_LQR_STATES, design.K)})
    values.update({f"L{s}_{y}": row[j] for s, row in zip(RIG_STATES, design.L) for j, y in enumerate(RIG_READINGS)})
    values.update(swing_up=design.swing_up, compensation=design.compensation, axis=design.axis)
    return values


def designed_component(design: Design) -> Component:
    """The RigController's table with `design`'s values as its parameters' start values."""
    values = fmu_parameters(design)
    variables = tuple(dataclasses.replace(v, start=values[v.name]) if v.name in values else v
                      for v in RIG_CONTROLLER.variables)
    return dataclasses.replace(RIG_CONTROLLER, variables=variables)


def write_fmus(design: Design, folder: str | Path) -> list[Path]:
    """folder/RigController.fmu (FMI 2.0) and folder/fmi3/RigController.fmu, Co-Simulation
    (and Model Exchange), for every platform this machine builds."""
    from pendfmu.fmubuild.compiler import build_fmu

    component = designed_component(design)
    return [build_fmu(component, force=True, fmi_version=version, folder=Path(folder)) for version in (2, 3)]
