"""Which component receives which value: the checks every export shares.

A parameters file names rig parameters (``{"parameters": {"k_fwc": 25.0, "m_p": 0.2}}``).
:func:`plan_export` decides, before anything is written, which components get an FMU and
which values each of them receives, so that the FMUs, the SSV file and the Modelica text
describe the same thing and a bad value stops the export before any file exists.

Shared parameters (``m_p`` and ``l`` in Cart and Pendulum, ``solver_step`` everywhere)
go to every exported component that has them. A component only ever receives values
inside *its own* range: its binary would refuse anything else at instantiation. The one
case the ranges allow to differ is ``m_p = 0``: a cart whose pendulum is removed (the
paper's experiment 2), but no pendulum at all. Then the Pendulum is left out of a
default export, with a note saying why; asking for it explicitly is an error naming the
component, the parameter and the range.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

from pendfmu.components import COMPONENTS, Component
from pendfmu.parameters import ParameterFileError, check_parameters, parameter_owners
from pendfmu.physics import settled
from pendfmu.ranges import outside
from pendfmu.ssp.rig import RIG_COMPONENTS


@dataclass
class ExportPlan:
    """What an export writes, decided before any file is.

    Attributes
    ----------
    given : dict of str to float
        The checked values as the user gave them (``J_cm`` already converted to ``J_p``).
    components : dict of str to dict of str to float
        Each component to be exported, with the values it receives (a subset of `given`).
    skipped : dict of str to str
        Each component left out of a default export, with the reason.
    notes : list of str
        Anything else the user should be told (values that no exported component takes).
    source : str
        Where the values came from, for the descriptions in the files.
    """

    given: dict[str, float]
    components: dict[str, dict[str, float]]
    skipped: dict[str, str] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    source: str = "parameters given in Python"

    def start_values(self, name: str) -> dict[str, float]:
        """Every parameter of a component: its given value, else the FMU's default.

        The SSV file and the Modelica text state the whole component, not only the changes,
        so that they do not depend on the defaults of whichever build they are used with.

        Parameters
        ----------
        name : str
            One of the plan's `components`.

        Returns
        -------
        dict of str to float
            Each of the component's parameters with its value.
        """
        given = self.components[name]
        return {p: given.get(p, float(v.start)) for p, v in COMPONENTS[name].parameters.items()}

    @property
    def holds_the_rig(self) -> bool:
        """Whether every component of the rig is exported: then so is the rig as SSP files."""
        return all(name in self.components for name in RIG_COMPONENTS)


def refusal(component: Component, name: str, value: float) -> str | None:
    """Why `component` cannot take `name` = `value` (None when it can)."""
    return outside(f"{component.name}.{name}", value, [component.parameters[name]])


def _takers(name: str, value: float) -> str:
    """The components that accept `name` = `value`, for a message."""
    return " and ".join(c for c in parameter_owners(name) if not refusal(COMPONENTS[c], name, value))


def _default_selection(given: Mapping[str, float]) -> list[str]:
    """The components any given value belongs to; all three when nothing is given."""
    chosen = [c for c in COMPONENTS if any(n in COMPONENTS[c].parameters for n in given)]
    return chosen or list(COMPONENTS)


def _explicit_selection(components: Iterable[str]) -> list[str]:
    """The requested component names in table order, each checked to exist."""
    requested = list(dict.fromkeys(components))
    unknown = [c for c in requested if c not in COMPONENTS]
    if unknown:
        raise ParameterFileError(f"no component {', '.join(map(repr, unknown))}; known: {', '.join(COMPONENTS)}")
    return [c for c in COMPONENTS if c in requested]


def plan_export(parameters: Mapping[str, object], components: Iterable[str] | None = None,
                source: str | None = None) -> ExportPlan:
    """Check parameter values and decide which component FMUs get which values.

    Parameters
    ----------
    parameters : mapping of str to float
        Rig parameter values by name (SI units, named as in docs/user-guide/model.md).
    components : iterable of str, optional
        The components to export; by default every component that has one of the given
        parameters (all three if none is given).
    source : str, optional
        Where the values came from (the parameters file), named in error messages and in
        the exported files' descriptions.

    Returns
    -------
    ExportPlan
        The components and the values each receives, with what is left out and why.

    Raises
    ------
    ParameterFileError
        An unknown name, a value that is not a finite number, a value outside every
        owner's range, or a value a requested component refuses (see the module
        docstring for m_p = 0).
    """
    where = source or ""
    given = settled(check_parameters(parameters, where), where)  # J_cm exported as J_p
    explicit = components is not None
    selected = _explicit_selection(components) if explicit else _default_selection(given)
    plan = ExportPlan(given, {}, source=source or ExportPlan.source)
    for name in selected:
        component = COMPONENTS[name]
        values = {p: v for p, v in given.items() if p in component.parameters}
        refused = {p: r for p, v in values.items() if (r := refusal(component, p, v))}
        if not refused:
            plan.components[name] = values
        elif explicit:
            raise ParameterFileError(f"{where + ': ' if where else ''}{next(iter(refused.values()))}")
        else:
            # Only a shared value gets here: check_parameters accepted it for another owner.
            plan.skipped[name] = "; ".join(f"{r}, a value only {_takers(p, values[p])} can take"
                                           for p, r in refused.items())
    if not plan.components:
        raise ParameterFileError("nothing to export: no component was selected")
    for p in given:
        if not parameter_owners(p):
            plan.notes.append(f"{p} is not exported: a parameter of the recordings, not of a component")
        elif not any(p in COMPONENTS[c].parameters for c in plan.components):
            owners = ", ".join(parameter_owners(p))
            plan.notes.append(f"{p} is not exported: its component ({owners}) is not exported")
    if not plan.holds_the_rig:
        plan.notes.append(f"the rig is not exported as SSP files: they need {', '.join(RIG_COMPONENTS)}, and this "
                          f"export holds {', '.join(plan.components)}")
    return plan
