"""The exported parameters as one SSP 1.0 parameter values file (``parameters.ssv``).

One file for all components, each value named ``Component.parameter`` ("Cart.k_fwc",
"Pendulum.m_p"): SSP 1.0 addresses a parameter of a component by that dotted name when a
ParameterBinding sits on the system, so the file can be bound to a whole rig in one
place. (``pendfmu.ssp`` writes one SSV per component instead, bound on each component with
unprefixed names; both are standard.) Every parameter of every exported component is
written, the given ones and the defaults, like ``pendfmu.ssp.rig_system`` does, so the
file states the whole rig. The file is validated against the SSV schema before it is
written (``pendfmu.ssp.write_ssv``).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from pendfmu.components import COMPONENTS
from pendfmu.fmubuild.units import BASE_UNITS
from pendfmu.ssp import ParameterSet, ParameterValue, Unit, write_ssv


def _unit(name: str) -> Unit:
    """The SSP unit definition of an FMU unit name (same base-unit exponents as the FMU's)."""
    return Unit(name, **BASE_UNITS[name])


def parameter_set(values: Mapping[str, Mapping[str, float]], name: str = "exported") -> ParameterSet:
    """The set of `values` (component -> parameter -> value) with dotted names and units."""
    entries: dict[str, ParameterValue] = {}
    for component, parameters in values.items():
        table = COMPONENTS[component].parameters
        for parameter, value in parameters.items():
            entries[f"{component}.{parameter}"] = ParameterValue(float(value), table[parameter].unit or None, "Real")
    units = {u: _unit(u) for u in sorted({v.unit for v in entries.values() if v.unit})}
    return ParameterSet(name, entries, units)


def write_parameter_values(values: Mapping[str, Mapping[str, float]], path: str | Path,
                           name: str = "exported") -> Path:
    """Write `values` (component -> parameter -> value) as one validated SSV file."""
    return write_ssv(parameter_set(values, name), path)
