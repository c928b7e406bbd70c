"""What a fit is asked to do: one specification, built alike by the command line and the API.

    spec = FitSpec("cart", ["run1.csv", "run2.csv"], params={"T_i": 3e-4}, fix=["eta"])
    result = pendfmu.fit(spec)                       # the same as the keywords given to fit

`pendfmu fit` only parses its words into a FitSpec and prints what comes back; every
decision (defaults, which stage an option reaches, the PWM ripple of the current stage)
is made below it, so the same request is the same fit wherever it comes from.

An option either applies to the target or is refused before any work, with an
OptionError naming the option and the target: a fit never records an option it did not
apply. For the paper's sequence ("all") a parameter option (free, fix, bounds,
per_recording) goes to each stage that has the parameter, and a name no stage has is
refused. This module checks what can be checked without the recordings; the stage and
model presets (stages.py, models.py) check names against the components and the data.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field, fields, replace
from pathlib import Path

from pendfmu.errors import OptionError
from pendfmu.fitting.optimizer import GlobalOptions

STAGE_NAMES = ("current", "cart", "pendulum")
SEQUENCE = "all"
COSTS = ("plain", "quantized")
UNCERTAINTY_METHODS = ("bootstrap", "jacobian", "sandwich")
INTERPOLATIONS = ("hold", "linear")
STARTS = ("estimated", "measured", "turning")
TURNING = "turning"  # a start that applies to the pendulum stage alone
HARMONIC_CHOICES = ("auto", "off")
REPLICATES = 24  # bootstrap replicates by default: each is one local refit
MIN_REPLICATES = 8  # fewer successful refits than this give no bootstrap interval
STAGE_DRIVES = {"current": ("I_c",), "cart": ("I_c", "I", "u"), "pendulum": ("a",)}


@dataclass(frozen=True)
class FitSpec:
    """A fit's whole request: the target, the recordings and every choice about them.

    Attributes
    ----------
    target : str, path or Model
        A stage of the paper ('current', 'cart', 'pendulum'), the paper's sequence on a
        folder ('all'), or a user's model: an FMU or SSP file, or a loaded Model.
    recordings : tuple
        Recording files (CSV + sidecar, or .mat) or Recording objects, fitted jointly; for
        'all', one folder.
    params : mapping or path
        Known values and the start of the fitted ones, or a parameters or result file.
    free, fix : tuples of names
        Parameters to fit besides a stage's own (a user's model: all of them); parameters
        the fit would estimate that are kept at their known values instead.
    bounds : mapping name -> (low, high)
        Search boxes; the presets' policy for the others.
    drive : str or mapping input -> column, optional
        A stage: the recorded signal that drives it (I_c, I, u, a). A model: its inputs by
        recorded column (default: equal names).
    match : mapping output -> column, optional
        A model: its outputs compared with recorded columns (default: equal names). A
        stage: its recorded rate compared as well (w for the pendulum, v for the cart).
    initial : mapping signal -> parameter, optional
        A model: the parameter a sidecar's initial value of a signal sets.
    interpolation : {'hold', 'linear'} or None
        A model: its drives between samples (None: held).
    per_recording : tuple of names
        Parameters estimated for each recording (window, segment) on its own.
    windows : tuple of (t0, t1)
        Only these time windows of each recording, each from its own initial states.
    segment : float or None
        Each recording (or window) split into segments this long (seconds).
    start : {'estimated', 'measured', 'turning'} or None
        A later window's initial states: estimated (None, the default) or measured. The
        pendulum stage: 'turning' starts each recording (window, segment) at the first
        turning point of its swing, where the rate is known (turning.py).
    cost : {'plain', 'quantized'}
        Plain least squares, or zero inside each reading's quantization step.
    harmonic : {'auto', 'off'}
        The current stage: look for the converter's PWM ripple in the residual and fit it
        ('auto'), or not.
    seed : int or None
        Seed of the global search (None: 0); refused when the global search is off.
    global_search : GlobalOptions
        The global search (enabled, population, generations) and where candidates and
        bootstrap refits run (local workers, a Dask scheduler).
    uncertainty : {'bootstrap', 'jacobian', 'sandwich'}
        Calibrated intervals from refits (a fit that misses what the recordings show gets the
        sandwich ones instead: adequacy.py), the fast Jacobian ones, or the sandwich ones
        (residuals correlated and above the noise: statistics.sandwich_covariance).
    replicates : int or None
        Bootstrap replicates (None: REPLICATES).
    """

    target: str | Path | object
    recordings: tuple = ()
    params: Mapping[str, float] | str | Path = field(default_factory=dict)
    free: tuple[str, ...] = ()
    fix: tuple[str, ...] = ()
    bounds: Mapping[str, tuple[float, float]] = field(default_factory=dict)
    drive: str | Mapping[str, str] | None = None
    match: Mapping[str, str] | None = None
    initial: Mapping[str, str] | None = None
    interpolation: str | None = None
    per_recording: tuple[str, ...] = ()
    windows: tuple[tuple[float, float], ...] = ()
    segment: float | None = None
    start: str | None = None
    cost: str = "plain"
    harmonic: str = "auto"
    seed: int | None = None
    global_search: GlobalOptions = field(default_factory=GlobalOptions)
    uncertainty: str = "bootstrap"
    replicates: int | None = None

    def __post_init__(self) -> None:
        normal = {
            "recordings": _listed(self.recordings), "free": _names("free", self.free),
            "fix": _names("fix", self.fix), "per_recording": _names("per_recording", self.per_recording),
            "bounds": _bounds(self.bounds), "windows": _windows(self.windows),
            "drive": _drive(self.drive), "match": _pairs("match", self.match, single=True),
            "initial": _pairs("initial", self.initial), "global_search": self.global_search or GlobalOptions(),
        }
        for name, value in normal.items():
            object.__setattr__(self, name, value)
        _choice("cost", self.cost, COSTS)
        _choice("uncertainty", self.uncertainty, UNCERTAINTY_METHODS)
        _choice("harmonic", self.harmonic, HARMONIC_CHOICES)
        _choice("interpolation", self.interpolation, INTERPOLATIONS, optional=True)
        _choice("start", self.start, STARTS, optional=True)
        _check_numbers(self)

    @property
    def kind(self) -> str:
        """'stage', 'sequence' or 'model'."""
        if isinstance(self.target, str) and self.target in STAGE_NAMES:
            return "stage"
        return "sequence" if self.target == SEQUENCE else "model"

    @property
    def target_name(self) -> str:
        """The target as messages name it."""
        if self.kind == "stage":
            return f"the {self.target} stage"
        if self.kind == "sequence":
            return "fit all"
        return str(getattr(self.target, "name", self.target))

    @property
    def seed_value(self) -> int:
        """The global search's seed as used: `seed`, or 0 when not given."""
        return 0 if self.seed is None else self.seed

    @property
    def replicate_count(self) -> int:
        """The bootstrap replicates as used: `replicates`, or REPLICATES (24) when not given."""
        return REPLICATES if self.replicates is None else self.replicates

    def with_options(self, **changes) -> FitSpec:
        """A copy with some fields changed (a stage of 'all', a pass of the ripple fit).

        Parameters
        ----------
        **changes
            New values by field name; they are checked as the constructor checks them.

        Returns
        -------
        FitSpec
            The copy; this specification is unchanged (it is frozen).
        """
        return replace(self, **changes)

    def request(self) -> dict:
        """The specification as plain JSON, as provenance records it: enough to repeat the fit.

        Returns
        -------
        dict
            Every field by name, as JSON values: recordings as their paths, a target or
            params that is not text or a mapping as its text (a file's path), tuples as
            lists, the global search's settings as a mapping.
        """
        document = {}
        for item in fields(self):
            value = getattr(self, item.name)
            if item.name == "global_search":
                value = asdict(value)
            elif item.name == "recordings":
                value = [str(getattr(r, "path", r)) for r in value]
            elif item.name == "target" or item.name == "params":
                value = value if isinstance(value, (dict, str)) else str(getattr(value, "source", value))
            elif item.name == "windows":
                value = [[_json_number(low), _json_number(high)] for low, high in value]
            elif item.name == "bounds":
                value = {name: list(box) for name, box in value.items()}
            elif isinstance(value, tuple):
                value = list(value)
            elif isinstance(value, Mapping):
                value = dict(value)
            document[item.name] = value
        return document


def check_applicable(spec: FitSpec) -> None:
    """Refuse, before any work, an option that does not apply to the spec's target."""
    kind = spec.kind
    if kind in ("stage", "sequence"):
        for option in ("initial", "interpolation"):
            if getattr(spec, option) is not None:
                raise OptionError(option, f"is for a model (an FMU or SSP system); {spec.target_name} sets its own")
    if kind == "sequence" and spec.match is not None:
        raise OptionError("match", "fit all compares each stage's own signals; fit the pendulum or the cart stage "
                                   "alone to compare its recorded rate (w, v) as well")
    if spec.harmonic != "auto" and spec.target not in ("current", SEQUENCE):
        raise OptionError("harmonic", f"is the current stage's PWM ripple; {spec.target_name} has none")
    _check_start(spec)
    if not spec.global_search.enabled:
        _check_no_search(spec)
    if spec.replicates is not None and spec.uncertainty != "bootstrap":
        raise OptionError("replicates", f"counts the bootstrap's refits; uncertainty {spec.uncertainty!r} makes none")
    if kind == "sequence":
        _check_sequence(spec)
    elif kind == "stage":
        _check_stage_drive(spec, spec.target)
    if not spec.recordings:
        raise OptionError("recordings", f"{spec.target_name}: give its recordings")


def _check_start(spec: FitSpec) -> None:
    """'turning' is the pendulum stage's; the other starts set the states of a late window."""
    if spec.start == TURNING:
        if spec.target != "pendulum":
            raise OptionError("start", f"'turning' starts a swing at its first turning point: the pendulum stage's; "
                                       f"{spec.target_name} has no swing (fit the pendulum stage)")
    elif spec.start is not None and not (spec.windows or spec.segment):
        raise OptionError("start", "sets the initial states of a window or segment that starts late; give "
                                   "windows or a segment length, or leave it out ('turning': the pendulum "
                                   "stage from its first turning point)")


def _check_no_search(spec: FitSpec) -> None:
    """Settings of a global search that is switched off apply to nothing."""
    if spec.seed is not None:
        raise OptionError("seed", "seeds the global search, which is switched off")
    default = GlobalOptions()
    for name, word in (("popsize", "population"), ("maxiter", "generations")):
        if getattr(spec.global_search, name) != getattr(default, name):
            raise OptionError(f"global_search.{name}", f"the {word} of a global search that is switched off")


def _check_sequence(spec: FitSpec) -> None:
    from pendfmu.virtual_rig import read_truth

    if len(spec.recordings) != 1 or not isinstance(spec.recordings[0], (str, Path)):
        raise OptionError("recordings", "fit all takes one folder of recordings")
    if not Path(spec.recordings[0]).is_dir():
        raise OptionError("recordings", f"fit all takes one folder of recordings; {spec.recordings[0]} is not a folder")
    read_truth(spec.recordings[0])  # a virtual rig's truth, shown against the result: checked before the fit
    for option in ("windows", "segment"):
        if getattr(spec, option):
            raise OptionError(option, "fit all fits each stage's recordings whole; fit the stage alone to fit "
                                      "parts of its recordings")
    if spec.drive is not None and not stages_driven_by(spec.drive):
        raise OptionError("drive", f"{spec.drive!r} drives none of the stages (current: I_c; cart: I_c, I or u; "
                                   f"pendulum: a)")


def _check_stage_drive(spec: FitSpec, stage: str) -> None:
    if spec.drive is None:
        return
    if not isinstance(spec.drive, str) or spec.drive not in STAGE_DRIVES[stage]:
        raise OptionError("drive", f"the {stage} stage is driven by one recorded signal, "
                                   f"{' or '.join(STAGE_DRIVES[stage])}, not {spec.drive!r}")


def stages_driven_by(drive: str | Mapping | None) -> list[str]:
    """The stages a recorded drive signal can drive (the sequence passes it to those)."""
    return [stage for stage, drives in STAGE_DRIVES.items() if isinstance(drive, str) and drive in drives]


def for_stage(spec: FitSpec, stage: str, fitted: Mapping[str, Sequence[str]]) -> FitSpec:
    """The spec of one stage of 'all': each parameter option keeps the names that stage has.

    `fitted` maps each option (free, fix, bounds, per_recording) to the names the stage
    accepts for it (stages.accepted_names)."""
    parameters = {option: _kept(getattr(spec, option), fitted[option])
                  for option in ("free", "fix", "bounds", "per_recording")}
    drive = spec.drive if stage in stages_driven_by(spec.drive) else None
    harmonic = spec.harmonic if stage == "current" else "auto"
    return spec.with_options(target=stage, drive=drive, harmonic=harmonic, **parameters)


def unplaced(spec: FitSpec, accepted: Mapping[str, Mapping[str, Sequence[str]]]) -> None:
    """Refuse a parameter option of 'all' that no stage takes: `accepted` maps each stage
    that runs to what it accepts per option (for_stage)."""
    for option in ("free", "fix", "bounds", "per_recording"):
        for name in getattr(spec, option):
            if not any(name in taken[option] for taken in accepted.values()):
                places = "; ".join(f"{stage}: {', '.join(taken[option]) or 'none'}" for stage, taken in
                                   accepted.items())
                raise OptionError(option, f"{name!r} is not a parameter any stage of fit all takes here ({places})")


def _kept(value, names: Sequence[str]):
    if isinstance(value, Mapping):
        return {name: box for name, box in value.items() if name in names}
    return tuple(name for name in value if name in names)


def _listed(recordings) -> tuple:
    if recordings is None:
        return ()
    if isinstance(recordings, (str, Path)):
        return (recordings,)
    return tuple(recordings)


def _names(option: str, names) -> tuple[str, ...]:
    if names is None:
        return ()
    if isinstance(names, str):
        names = [names]
    names = tuple(names)
    for name in names:
        if not isinstance(name, str) or not name:
            raise OptionError(option, f"expected parameter names, got {name!r}")
    return tuple(dict.fromkeys(names))


def _bounds(bounds) -> dict[str, tuple[float, float]]:
    """name -> (low, high) from a mapping or from 'NAME=LOW:HIGH' texts (the command line's)."""
    if not bounds:
        return {}
    items = bounds.items() if isinstance(bounds, Mapping) else (_bound_text(text) for text in bounds)
    result = {}
    for name, box in items:
        try:
            low, high = (float(end) for end in box)
        except (TypeError, ValueError):
            raise OptionError("bounds", f"{name}: expected two numbers (low, high), got {box!r}") from None
        if not low < high:
            raise OptionError("bounds", f"{name}={low:g}:{high:g}: LOW must be below HIGH")
        result[name] = (low, high)
    return result


def _bound_text(text: str) -> tuple[str, tuple[float, float]]:
    name, _, span = str(text).partition("=")
    low, colon, high = span.partition(":")
    try:
        if not (name and colon):
            raise ValueError
        return name, (float(low), float(high))
    except ValueError:
        raise OptionError("bounds", f"{text!r}: expected NAME=LOW:HIGH with numbers") from None


def _windows(windows) -> tuple[tuple[float, float], ...]:
    """(t0, t1) pairs from pairs or from 'T0:T1' texts (either side empty: open)."""
    result = []
    for window in windows or ():
        if isinstance(window, str):
            first, colon, last = window.partition(":")
            try:
                if not colon:
                    raise ValueError
                pair = (float(first) if first.strip() else -math.inf, float(last) if last.strip() else math.inf)
            except ValueError:
                raise OptionError("windows", f"{window!r}: give it as T0:T1 in seconds (e.g. 2.5:7)") from None
        else:
            pair = tuple(float(end) for end in window)
        if len(pair) != 2 or not pair[1] > pair[0]:
            raise OptionError("windows", f"{window!r}: T0 must be below T1")
        result.append(pair)
    return tuple(result)


def _drive(drive):
    """A stage's drive is one column (str); a model's a mapping input -> column."""
    if drive is None or isinstance(drive, str):
        return drive
    if not isinstance(drive, Mapping) and len(drive) == 1 and "=" not in drive[0]:
        return drive[0]
    return _pairs("drive", drive, single=True)


def _pairs(option: str, items, single: bool = False) -> dict[str, str] | None:
    """{name: value} from a mapping or from 'NAME=VALUE' texts; with `single`, a bare
    'NAME' means NAME=NAME (an input driven by the column of its name)."""
    if items is None:
        return None
    if isinstance(items, Mapping):
        return {str(k): str(v) for k, v in items.items()}
    result = {}
    for item in items:
        name, _, value = str(item).partition("=")
        if not name or not (value or single):
            raise OptionError(option, f"{item!r}: expected NAME=VALUE")
        result[name] = value or name
    return result


def _choice(option: str, value, choices: Sequence[str], optional: bool = False) -> None:
    if value is None and optional:
        return
    if value not in choices:
        raise OptionError(option, f"{value!r} is not one of {', '.join(choices)}")


def _check_numbers(spec: FitSpec) -> None:
    if spec.seed is not None and (isinstance(spec.seed, bool) or not isinstance(spec.seed, int)):
        raise OptionError("seed", f"expected an integer, got {spec.seed!r}")
    if spec.replicates is not None and (isinstance(spec.replicates, bool) or not isinstance(spec.replicates, int)
                                        or spec.replicates < MIN_REPLICATES):
        raise OptionError("replicates", f"{spec.replicates!r}: at least {MIN_REPLICATES} (the interval's quantile "
                                        f"needs them)")
    if spec.segment is not None and not (isinstance(spec.segment, (int, float)) and math.isfinite(spec.segment)
                                         and spec.segment > 0):
        raise OptionError("segment", f"{spec.segment!r}: must be a positive number of seconds")
    search = spec.global_search
    for name, least in (("workers", 0), ("popsize", 1), ("maxiter", 1)):
        value = getattr(search, name)
        if isinstance(value, bool) or not isinstance(value, int) or value < least:
            raise OptionError(f"global_search.{name}", f"{value!r}: a whole number of at least {least}")


def _json_number(value: float) -> float | None:
    return value if math.isfinite(value) else None
