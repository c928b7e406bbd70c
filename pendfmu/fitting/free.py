"""A fit's free parameters and their search boxes: one builder for a stage and a user's model.

What is fitted: the target's own names (a stage's preset; none for a user's model), then
`free`, less `fix`, and each recording's own estimates (the initial states it does not
state, the names asked for per recording). Every name must be one the target knows, a
fixed name one the fit would estimate, a bounded name one it does estimate: anything else
is refused (OptionError) instead of doing nothing.

Where the targets differ is the Policy: which names they know, and the box of a name
(a stage: stages.py's rules -- DEFAULT_BOUNDS, boxes derived from the rig's sizes,
stiction relative to Coulomb friction; a user's model: models.py's -- the declared range,
else a decade around the start). An initial state's box comes from its recording's first
readings, widened through the free sensor parameters (experiment.through_sensor); every
box is then cut to what is physically possible (boxes.py).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

from pendfmu.errors import OptionError
from pendfmu.fitting.boxes import Declared, cut_to_physics
from pendfmu.fitting.experiment import Experiment, through_sensor
from pendfmu.fitting.residuals import FreeParameter
from pendfmu.suggest import did_you_mean

Box = tuple[float, float, bool, str | None]
"""(low, high, logarithmic, relative_to) of a shared parameter."""


@dataclass(frozen=True)
class Policy:
    """What a target decides about its free parameters.

    Attributes
    ----------
    subject : str
        The target as messages name it ("the cart stage", a model's name).
    preset : tuple of str
        The names it fits unless told otherwise (a stage's; none for a user's model).
    check : callable (option, name) -> None
        Raises an OptionError (or ModelError) for a name the target does not know.
    shared_box : callable (name, names, fix, bounds) -> Box
        The box of a parameter all recordings share (`names`: everything fitted).
    own_box : callable (name, bounds, experiment) -> (low, high, logarithmic)
        The box of a recording's own parameter that its data do not bound.
    declared : callable name -> (low, high)
        The range the target declares for a parameter (boxes.cut_to_physics).
    parameters : str
        The parameters it has, listed for a message.
    hint : callable name -> str
        Advice added when a fixed name is not fitted.
    """

    subject: str
    preset: tuple[str, ...]
    check: Callable[[str, str], None]
    shared_box: Callable[[str, Sequence[str], Sequence[str], Mapping[str, tuple[float, float]]], Box]
    own_box: Callable[[str, Mapping[str, tuple[float, float]], Experiment], tuple[float, float, bool]]
    declared: Declared
    parameters: str
    hint: Callable[[str], str] = lambda name: ""


def free_parameters(policy: Policy, experiments: Sequence[Experiment], free: Sequence[str], fix: Sequence[str],
                    bounds: Mapping[str, tuple[float, float]], values: Mapping[str, float]) -> list[FreeParameter]:
    """The fit's free parameters with their boxes: the shared ones first, in the order
    named, then each recording's own."""
    own = list(dict.fromkeys(name for e in experiments for name in e.estimated))
    names = [*policy.preset, *(n for n in free if n not in policy.preset)]
    if not names and not own:
        raise OptionError("free", f"name the parameters of {policy.subject} to fit; its parameters: "
                                  f"{policy.parameters}")
    for option, listed in (("free", names), ("fix", fix), ("per_recording", own), ("bounds", bounds)):
        for name in listed:
            policy.check(option, name)
    _check_fix_and_bounds(policy, [*names, *(n for n in own if n not in names)], fix, bounds)
    shared_names = [n for n in names if n not in own]
    shared = [_shared(name, policy.shared_box(name, shared_names, fix, bounds)) for name in shared_names
              if name not in fix]
    result = shared + _own(policy, experiments, fix, bounds, {p.name: p for p in shared})
    return cut_to_physics(result, {e.name: {**values, **e.fixed} for e in experiments}, policy.declared)


def _check_fix_and_bounds(policy: Policy, fitted: Sequence[str], fix: Sequence[str],
                          bounds: Mapping[str, tuple[float, float]]) -> None:
    for name in fix:
        if name not in fitted:
            raise OptionError("fix", f"{policy.subject} does not fit {name!r}{did_you_mean(name, fitted)}, so there "
                                     f"is nothing to keep fixed (it fits {', '.join(fitted)}){policy.hint(name)}")
    valid = [n for n in fitted if n not in fix]
    for name in bounds:
        if name not in valid:
            raise OptionError("bounds", f"{name!r} is not estimated by {policy.subject}{did_you_mean(name, valid)}; "
                                        f"its free parameters: {', '.join(valid) or 'none'}")


def _own(policy: Policy, experiments: Sequence[Experiment], fix: Sequence[str],
         bounds: Mapping[str, tuple[float, float]], shared: Mapping[str, FreeParameter]) -> list[FreeParameter]:
    """Each recording's own parameters: an initial state its data bound (through the free
    sensor parameters), anything else by the policy."""
    result = []
    for experiment in experiments:
        for name, (_guess, low, high) in experiment.estimated.items():
            if name in fix:
                continue
            if name in bounds or low is None:
                low, high, log = policy.own_box(name, bounds, experiment)
            else:
                low, high = through_sensor(experiment, name, low, high, shared)
                log = False
            result.append(FreeParameter(name, float(low), float(high), log, experiment.name))
    return result


def _shared(name: str, box: Box) -> FreeParameter:
    low, high, log, relative_to = box
    return FreeParameter(name, float(low), float(high), log, relative_to=relative_to)
