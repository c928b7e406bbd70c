"""A fit of a user's model: an FMU or an SSP system pendfmu did not make.

The same experiments, residuals, optimizer and intervals as the paper's stages; what
differs is where the names come from. A stage knows its drives, matches and free
parameters (stages.py); a user's model gets them from the user, with defaults:

- drives: every model input with a recorded column of the same name is driven by it
  (held between samples unless the user asks for linear and the FMU can interpolate);
- matches: every model output with a recorded column of the same name is compared;
- free: none by default; the user names them (`free`);
- the search box: `bounds`, else the range the model description declares, else a decade
  either side of the start value (a lab engineer's prior is rarely off by more);
- known values: the model description's start values, then `params`, then each
  recording's sidecar ("parameters"; "initial" through `initial`, signal -> parameter,
  by default an output `x` to a parameter `x0` where the model has one).

Names are the model's (simulator/model.py): bare where unambiguous, `Component.name`
always. An unknown name is an error that lists the valid ones.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path

from pendfmu.errors import BadInput, OptionError
from pendfmu.fitting.experiment import Experiment, Setup, StartState, prepare
from pendfmu.fitting.free import Policy, free_parameters
from pendfmu.fitting.residuals import FreeParameter
from pendfmu.recording import Recording, read_recording
from pendfmu.recording.measurement import default_box, is_measurement, measurement_problem, measurement_signal
from pendfmu.simulator.model import Model, ModelError

SEARCH_DECADE = 10.0


def mapping(items: Mapping[str, str] | Sequence[str] | None) -> dict[str, str] | None:
    """{name: column} from a mapping or from 'NAME' / 'NAME=COLUMN' strings (the CLI's)."""
    if items is None:
        return None
    if isinstance(items, Mapping):
        return dict(items)
    result = {}
    for item in items:
        name, _, column = item.partition("=")
        result[name] = column or name
    return result


def checked_values(model: Model, values: Mapping[str, object], where: str = "") -> dict[str, float]:
    """Parameter values for `model`, each checked (its name, a finite number, inside the
    range the model description declares); a problem is an error naming `where`."""
    prefix = f"{where}: " if where else ""
    checked = {}
    for name, value in values.items():
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise BadInput(f"{prefix}parameter {name} = {value!r} is not a number")
        own = name in model.names("parameter")
        problem = (measurement_problem(name, float(value)) if not own and measurement_signal(name)
                   else model.parameter_problem(name, float(value)))
        if problem:
            raise BadInput(f"{prefix}parameter {name} = {value!r}: {problem}")
        checked[name] = float(value)
    return checked


def without_aliases(model: Model, values: Mapping[str, float], names: Sequence[str]) -> dict[str, float]:
    """`values` with each key that sets the same parameter as one of `names` under another
    name ("k_u" when the user wrote "Cart.k_u") moved to that name: one port, one key, so
    the result file says each value once and no order decides which of two spellings wins,
    and the value (an SSP's binding, a start value) stays the known value and the start of
    the fitted one, whose search box is built around it."""
    taken: dict[frozenset, str] = {}
    for name in names:
        try:
            taken.setdefault(frozenset(model.resolve(name, "parameter")), name)
        except ModelError:
            continue  # a measurement parameter, or checked later with its own message
    kept: dict[str, float] = {}
    for key, value in values.items():
        try:
            ports = frozenset(model.resolve(key, "parameter"))
        except ModelError:
            ports = None
        if ports is None or ports not in taken or key in names:
            kept[key] = value
        else:
            kept.setdefault(taken[ports], value)
    return kept


def initial_map(model: Model, given: Mapping[str, str] | None) -> dict[str, str]:
    """Signal -> the parameter of its initial value: `given`, else by the convention of
    the paper's model (docs/user-guide/model.md) and most exported models, an output `x`
    whose initial value is parameter `x0`. A signal written with a prime (x') stands for its
    rate: "x'" -> "v0" lets a window or segment estimate its initial speed from the slope of
    its first readings of x."""
    parameters = set(model.names("parameter"))
    found = {name: f"{name}0" for name in model.names("output") if f"{name}0" in parameters}
    for signal, parameter in (given or {}).items():
        model.resolve(parameter, "parameter")
        found[signal] = parameter
    return found


def read_for(model: Model, recordings: Sequence[str | Path | Recording], drive: Mapping[str, str] | None,
             match: Mapping[str, str] | None, initial: Mapping[str, str], extra: Sequence[str] = ()
             ) -> list[Recording]:
    """The recordings, read with the model's names (and the columns the user maps, and
    `extra` columns a caller takes as they are)."""
    columns = [*(drive or {}).values(), *(match or {}).values(), *extra]
    vocabulary = model.vocabulary(columns, initial)
    return [r if isinstance(r, Recording) else read_recording(r, vocabulary=vocabulary) for r in recordings]


def model_setup(model: Model, recording: Recording, drive: Mapping[str, str] | None,
                match: Mapping[str, str] | None, interpolation: str = "hold",
                initial: Mapping[str, str] | None = None) -> Setup:
    """The drives and matches of one recording (module docstring for the defaults)."""
    columns = set(recording.signals)
    if drive is None:
        drive = {name: name for name in model.drive_names() if name in columns}
    if match is None:
        match = {name: name for name in model.names("output") if "." not in name and name in columns}
    for name in drive:
        model.resolve(name, "input")
        if interpolation == "linear" and not model.interpolates(name):
            raise OptionError("interpolation", f"linear: the FMU that {name} drives cannot interpolate its inputs "
                                               f"(canInterpolateInputs is false); its drives are held")
    for name in match:
        model.resolve(name, "output")
    if not match:
        raise OptionError("match", f"{recording.path}: no recorded column is an output of {model.name} (outputs: "
                                   f"{', '.join(model.names('output'))}); name them: OUTPUT=COLUMN")
    starts = tuple(StartState(parameter, signal.rstrip("'"), rate=signal.endswith("'"))
                   for signal, parameter in (initial or {}).items() if signal.rstrip("'") in columns)
    return Setup(model.name, model, {name: (column, interpolation) for name, column in drive.items()}, dict(match),
                 starts=starts, unseen=_unseen(model, initial or {}, starts))


def _unseen(model: Model, initial: Mapping[str, str], starts: Sequence[StartState]) -> dict[str, str]:
    """Setup.unseen: each initial-state parameter of `initial` (signal -> parameter) that no
    start tells, once per port (x0 and ForeignCart.x0 are one), under its bare name where it
    has one (the name the fit's known values use)."""
    taken = {port for state in starts for port in model.resolve(state.parameter, "parameter")}
    outputs = set(model.names("output"))
    unseen = {}
    for signal, parameter in sorted(initial.items(), key=lambda item: "." in item[1]):
        ports = set(model.resolve(parameter, "parameter"))
        if not signal.endswith("'") and signal in outputs and not ports & taken:
            unseen[parameter] = signal
            taken |= ports
    return unseen


def model_experiments(model: Model, recordings: Sequence[Recording], values: Mapping[str, float],
                      drive: Mapping[str, str] | None, match: Mapping[str, str] | None,
                      initial: Mapping[str, str], interpolation: str = "hold", per_recording: Sequence[str] = (),
                      start: str = "estimated") -> list[Experiment]:
    """One experiment per recording: its setup and its known values (sidecar included)."""
    experiments = []
    for recording in recordings:
        fixed = {**values, **recording.parameters}
        for signal, value in recording.initial.items():
            fixed[initial[signal]] = value
        setup = model_setup(model, recording, drive, match, interpolation, initial)
        experiments.append(prepare(recording, setup, fixed, per_recording, start))
    return experiments


def model_free_parameters(model: Model, free: Sequence[str], fix: Sequence[str],
                          bounds: Mapping[str, tuple[float, float]], values: Mapping[str, float],
                          experiments: Sequence[Experiment] = ()) -> list[FreeParameter]:
    """The user's free parameters with their search boxes (module docstring), then each
    recording's own (free.py; the model's rules: model_policy)."""
    return free_parameters(model_policy(model, values, experiments), experiments, free, fix, bounds, values)


def model_policy(model: Model, values: Mapping[str, float], experiments: Sequence[Experiment]) -> Policy:
    """A user's model's rules for its free parameters: nothing fitted unless named, its own
    parameter names (and sensor parameters of the recorded columns), and its boxes: bounds,
    else the declared range, else a decade either side of the start (module docstring)."""
    columns = {c for e in experiments for c in (*e.match.values(), *(c for c, _ in e.setup.drives.values()))}

    def check(option: str, name: str) -> None:
        if not is_measurement(name, columns):
            model.resolve(name, "parameter")

    def shared_box(name, names, fix, bounds):
        box = _free(model, name, bounds, values, experiments[:1])
        return box.low, box.high, box.log, None

    def own_box(name, bounds, experiment):
        box = _free(model, name, bounds, {**values, **experiment.fixed}, [experiment])
        return box.low, box.high, False

    listing = ", ".join(n for n in model.names("parameter") if "." not in n)
    return Policy(model.name, (), check, shared_box, own_box, lambda name: _declared(model, name), listing)


def _free(model: Model, name: str, bounds: Mapping[str, tuple[float, float]], values: Mapping[str, float],
          experiments: Sequence[Experiment]) -> FreeParameter:
    found = measurement_signal(name)
    if name in bounds:
        low, high = bounds[name]
    elif found and experiments and name not in model.names("parameter"):
        low, high, _ = default_box(name, experiments[0].recording)
    else:
        low, high = _box(model, name, values.get(name))
    log = low > 0 and high / low >= SEARCH_DECADE  # decades apart: searched on the log scale
    return FreeParameter(name, float(low), float(high), log)


def _declared(model: Model, name: str) -> tuple[float | None, float | None]:
    """The range the model description declares for a parameter (every port of its name);
    None for an end it leaves open, and for a measurement parameter."""
    try:
        ports = model.resolve(name, "parameter")
    except ModelError:
        return None, None
    declared = [model.variables[port] for port in ports]
    return (max((d.low for d in declared if d.low is not None), default=None),
            min((d.high for d in declared if d.high is not None), default=None))


def _box(model: Model, name: str, start: float | None) -> tuple[float, float]:
    """The declared range where it is finite, else a decade either side of the start."""
    low, high = _declared(model, name)
    low = -math.inf if low is None else low
    high = math.inf if high is None else high
    if math.isfinite(low) and math.isfinite(high) and high > low:
        return low, high
    if start is None or start == 0 or not math.isfinite(start):
        raise OptionError("bounds", f"{name}: no search box: its start value is {start} and the model declares no "
                                    f"finite range; give one: {name}=LOW:HIGH")
    around = sorted((start / SEARCH_DECADE, start * SEARCH_DECADE))
    return max(low, around[0]), min(high, around[1])


def simulate_model(model: Model, recording: Recording, values: Mapping[str, float],
                   drive: Mapping[str, str] | None = None, interpolation: str = "hold",
                   initial: Mapping[str, str] | None = None):
    """The model driven by a recording (inputs by name unless `drive` maps them), every
    output at the recording's time stamps: a DataFrame with `time` first. Known values:
    the model's defaults, `values`, then the recording's sidecar (its "initial" through
    `initial`, signal -> parameter, by default as `initial_map`)."""
    import pandas as pd

    from pendfmu.simulator.replay import Drive, Replay

    columns = set(recording.signals)
    if drive is None:
        drive = {name: name for name in model.drive_names() if name in columns}
    drives = {name: Drive(recording.signal(column), interpolation) for name, column in drive.items()}
    outputs = [model.name_of(port) for port, v in model.variables.items() if v.causality == "output"]
    fixed = {**model.defaults(), **values, **recording.parameters}
    initial = initial_map(model, initial)
    fixed.update({initial[signal]: value for signal, value in recording.initial.items()})
    replay = Replay(model, recording.time, drives)
    try:
        simulated = replay.simulate(fixed, outputs)
    finally:
        replay.close()
    return pd.DataFrame({"time": recording.time, **simulated})
