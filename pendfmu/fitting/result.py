"""The result of a fit, as a plain container: values, intervals, flags, fit statistics,
provenance; and its file (write_json, read_result).

What the numbers mean and how they were computed lives beside the code that computes
them (statistics.py, uncertainty.py, stiction.py); how they are shown lives in the report
(pendfmu.report), which reads results and is never read by them.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pendfmu.atomic import write_atomically
from pendfmu.fitting.diagnostics import Diagnostics, of_signals
from pendfmu.fitting.envelope import envelope_indices
from pendfmu.fitting.labels import is_own, label
from pendfmu.jsontext import parse_json


FLAG_KINDS = ("at-bound", "unbounded", "wide-interval", "correlated", "not-determined", "bounded-only", "no-interval",
              "model-inadequate", "not-separately-identified", "fit-failed", "note")
"""The kinds of flags, for programs: the text says the same to a person, with the reason."""


class Flag(str):
    """What a user must know about an estimate: its text, and its kind (FLAG_KINDS), by which
    a program can tell one flag from another without reading the words."""

    kind: str

    def __new__(cls, text: str, kind: str = "note") -> Flag:
        if kind not in FLAG_KINDS:
            raise ValueError(f"flag kind {kind!r} is not one of {', '.join(FLAG_KINDS)}")
        flag = super().__new__(cls, text)
        flag.kind = kind
        return flag

    def __reduce__(self):  # pickled to worker processes with its kind
        return (Flag, (str(self), self.kind))


def kinds(flags) -> list[str]:
    """The kinds of a list of flags (plain text from an old result file: "note")."""
    return [getattr(flag, "kind", "note") for flag in flags]


@dataclass
class Estimate:
    """One fitted quantity, with its uncertainty and what the user must know about it.

    Attributes
    ----------
    label : str
        The quantity's name: a parameter (``k_fwc``), or a per-recording estimate with
        its recording (``phi0[run1]``).
    value : float
        The estimate, in the parameter's SI unit (docs/user-guide/model.md).
    stderr : float or None
        Its standard error; None when none could be given.
    ci95 : tuple of (float, float) or None
        The 95 % interval (an unbounded side is +-inf); None when none could be given.
    low, high : float
        The search bounds (NaN in a result read back without them).
    flags : list of str
        What the user must know about it: Flag objects, a text with a kind (FLAG_KINDS).
    method : str
        What gave the interval: "jacobian", "bootstrap", "sandwich", "bounded", ...
        ("none" for a value read back without one).
    """

    label: str
    value: float
    stderr: float | None
    ci95: tuple[float, float] | None
    low: float
    high: float
    flags: list[str] = field(default_factory=list)
    method: str = "jacobian"


@dataclass
class ExperimentFit:
    """Recorded against simulated signals of one recording, for reports."""

    name: str
    time: np.ndarray
    recorded: dict[str, np.ndarray]
    simulated: dict[str, np.ndarray]
    resolution: dict[str, float] = field(default_factory=dict)  # quantization step per recorded signal, if stated
    scale: dict[str, float] = field(default_factory=dict)  # the error scale (noise sigma) the cost divides by
    values: dict[str, float] = field(default_factory=dict)  # every parameter value this recording ran with
    overrides: dict[str, float] = field(default_factory=dict)  # what its sidecar set (parameters, initial states)
    # the RMS error per signal over every sample, when time/recorded/simulated are a
    # display envelope (a result read back from its file): the envelope's own RMS is not it
    rms: dict[str, float] = field(default_factory=dict)
    samples: int | None = None  # the recording's samples, when the arrays hold fewer
    # per signal the residual diagnostics of every sample (diagnostics.py) as a result file
    # stores them beside the envelope (read back); empty for a fit's own, whose arrays are whole
    diagnostics: dict[str, dict] = field(default_factory=dict)


@dataclass
class FitResult:
    """A fit's values, intervals, flags, warnings and provenance: what :func:`pendfmu.fit`
    returns and a result file holds (:meth:`write_json`, :func:`read_result`).

    A plain container: what the numbers mean lives beside the code that computes them, how
    they are shown lives in the report (pendfmu.report).

    Attributes
    ----------
    stage : str
        What was fitted: "current", "cart", "pendulum", "all" (the paper's sequence), or a
        user's model's name.
    parameters : dict of str to float
        Every value the fit ran with, fitted and known, by name (SI units, docs/user-guide/model.md).
    estimates : dict of str to Estimate
        The fitted ones, by label (``k_fwc``; ``phi0[run1]`` for one recording's own).
    correlation : dict of str to dict of str to float
        The estimates' correlations, by label and label (None where a standard error is 0
        or undefined).
    cost : float
        Half the sum of the squared residuals, each divided by its signal's error scale (in
        "all", the stages' sum).
    nrmse : dict of str to float
        Per signal (``"cart.x"`` in "all"), the RMS error over all recordings divided by
        the recorded range.
    nfev : int
        The cost evaluations (simulations) the fit made.
    failures : int
        The simulations that failed and were penalized.
    seconds : float
        The fit's wall time [s].
    experiments : list of ExperimentFit
        Per recording fitted, its recorded and simulated signals, for reports.
    initial : dict of str to dict of str to float
        Per recording, its estimated initial states.
    notes : list of str
        What the fit did that the user should know (failed simulations, a lost worker).
    validation : dict of str to dict of str to float
        Per recording predicted but not fitted, its errors (e.g. ``"phi_rms_steps"``).
    warnings : list of str
        What looks wrong (mis-scaled data, residuals far above the noise, an estimate at a
        bound, a value assumed for want of a sidecar): printed on the console, and with
        --strict a non-zero exit code.
    uncertainty : dict
        How the intervals were made (method, replicates, time).
    model : str or None
        A user's FMU or SSP file; None for pendfmu's own components.
    replicates : list of dict of str to float
        Per bootstrap replicate, the rig values its refits found (this stage's and, in
        "all", the earlier stages' of the same replicate): later stages start from them,
        and `pendfmu control` verifies its design on them.
    provenance : dict
        Where it came from: inputs with sha256, seed, bounds, start values, free and fixed
        sets, versions, date, command line (fitting/provenance.py).
    predicted : list of ExperimentFit
        The recordings predicted with the result but not fitted.
    assessment : dict
        Whether the fit can be trusted: ``{"verdict": "adequate" | "model-inadequate" |
        "fit-failed", "evidence": [...]}``.
    """

    stage: str
    parameters: dict[str, float]  # every value the stage ran with, fitted and known
    estimates: dict[str, Estimate]  # the fitted ones, by label
    correlation: dict[str, dict[str, float]]
    cost: float
    nrmse: dict[str, float]
    nfev: int
    failures: int
    seconds: float
    experiments: list[ExperimentFit] = field(default_factory=list)
    initial: dict[str, dict[str, float]] = field(default_factory=dict)  # estimated initial states per recording
    notes: list[str] = field(default_factory=list)
    # recordings not fitted but predicted with the result: name -> {"phi_rms_steps": ..., ...}
    validation: dict[str, dict[str, float]] = field(default_factory=dict)
    # what looks wrong (mis-scaled data, residuals far above the noise, an estimate at a
    # bound, a value assumed for want of a sidecar): printed on the console, and with
    # --strict a non-zero exit code
    warnings: list[str] = field(default_factory=list)
    uncertainty: dict = field(default_factory=dict)  # how the intervals were made (method, replicates, time)
    model: str | None = None  # a user's FMU or SSP file (None: pendfmu's own components)
    # per bootstrap replicate, the rig values its refits found (this stage's and, in `fit all`,
    # the earlier stages' of the same replicate; a failed refit's row holds the estimate):
    # later stages start from them, and `pendfmu control` verifies its design on them
    replicates: list[dict[str, float]] = field(default_factory=list, repr=False)
    # where it came from (fitting/provenance.py): inputs with sha256, seed, bounds, start
    # values, free and fixed sets, versions, date, command line
    provenance: dict = field(default_factory=dict)
    # the recordings predicted with the result but not fitted (fit_all: x and phi together)
    predicted: list[ExperimentFit] = field(default_factory=list)
    # whether the fit can be trusted: {"verdict": "adequate" | "model-inadequate" | "fit-failed",
    # "evidence": [what showed it]} (solve.py)
    assessment: dict = field(default_factory=dict)

    @property
    def stderr(self) -> dict[str, float | None]:
        """Each estimate's standard error, by label (None where there is none)."""
        return {k: e.stderr for k, e in self.estimates.items()}

    @property
    def ci95(self) -> dict[str, tuple[float, float] | None]:
        """Each estimate's 95 % interval, by label (None where there is none)."""
        return {k: e.ci95 for k, e in self.estimates.items()}

    @property
    def flags(self) -> dict[str, list[str]]:
        """The flags of each flagged estimate, by label."""
        return {k: e.flags for k, e in self.estimates.items() if e.flags}

    def to_dict(self) -> dict:
        """The result as the result file's JSON document.

        Long signals are reduced to their display envelope (with each signal's RMS error
        and residual diagnostics of every sample kept beside it): enough to re-render and
        compare reports.

        Returns
        -------
        dict
            ``parameters``, ``stderr``, ``ci95`` (an unbounded side is null),
            ``interval_method``, ``correlation``, ``flags``, ``flag_kinds``, ``initial``,
            ``fit`` (the statistics, notes, warnings, assessment), ``provenance``,
            ``recordings``, ``predicted`` and, after a bootstrap, ``replicates``.
        """
        shared = {k: e for k, e in self.estimates.items() if not is_own(k)}
        return {
            "parameters": dict(self.parameters),
            "stderr": {k: e.stderr for k, e in shared.items()},
            "ci95": {k: _json_interval(e.ci95) for k, e in shared.items()},
            "interval_method": {k: e.method for k, e in shared.items()},
            # the estimates' correlations (None where a standard error is 0 or undefined):
            # what a derived quantity's interval needs besides stderr
            "correlation": {k: {q: c for q, c in row.items() if q in shared}
                            for k, row in self.correlation.items() if k in shared},
            "flags": {k: e.flags for k, e in self.estimates.items() if e.flags},
            "flag_kinds": {k: kinds(e.flags) for k, e in self.estimates.items() if e.flags},
            "initial": self.initial,
            "fit": {"stage": self.stage, "cost": self.cost, "nrmse": self.nrmse, "nfev": self.nfev,
                    "failures": self.failures, "seconds": self.seconds, "notes": self.notes,
                    "warnings": self.warnings, "uncertainty": self.uncertainty, "validation": self.validation,
                    "assessment": self.assessment, **({"model": self.model} if self.model else {})},
            "provenance": self.provenance,
            # per recording the values it ran with and its signals, long ones as their
            # display envelope (fitting/envelope.py): enough to re-render and compare reports
            "recordings": [experiment_dict(e) for e in self.experiments],
            "predicted": [experiment_dict(e) for e in self.predicted],
            **({"replicates": self.replicates} if self.replicates else {}),
        }

    def write_json(self, path: str | Path) -> Path:
        """Write the result file: :meth:`to_dict` as JSON, written whole or not at all.

        Parameters
        ----------
        path : str or Path
            The file, replaced if it exists.

        Returns
        -------
        Path
            The file written.
        """
        return write_atomically(path, json.dumps(self.to_dict(), indent=2, allow_nan=False, default=_plain) + "\n")


def experiment_dict(fit: ExperimentFit) -> dict:
    """One recording's fit for the result file: long signals reduced to their envelope,
    with the RMS error and the residual diagnostics (diagnostics.py) of every sample kept
    beside it; a missing sample (NaN) is null."""
    signals = list(fit.recorded)
    residuals = [np.asarray(fit.recorded[s], float) - np.asarray(fit.simulated[s], float) for s in signals]
    arrays = [np.asarray(fit.recorded[s], float) for s in signals] + [np.asarray(fit.simulated[s], float)
                                                                       for s in signals] + residuals
    reduced = fit.samples is not None and len(fit.time) < fit.samples  # read back: already its envelope
    index = envelope_indices(arrays) if arrays and not reduced else np.arange(len(fit.time))
    rms = {s: (fit.rms[s] if s in fit.rms else _rms(r)) for s, r in zip(signals, residuals)}
    return {"name": fit.name, "samples": fit.samples or len(fit.time), "time": _json_array(fit.time, index),
            "recorded": {s: _json_array(fit.recorded[s], index) for s in signals},
            "simulated": {s: _json_array(fit.simulated[s], index) for s in signals},
            "resolution": dict(fit.resolution), "scale": dict(fit.scale), "rms": rms,
            "values": dict(fit.values), "overrides": dict(fit.overrides),
            "diagnostics": {s: d.to_dict() for s, d in diagnostics_of(fit).items()}}


def whole(fit: ExperimentFit) -> bool:
    """Whether a recording's arrays hold every sample (not a file's display envelope)."""
    return fit.samples is None or len(fit.time) >= fit.samples


def diagnostics_of(fit: ExperimentFit) -> dict[str, Diagnostics]:
    """Each recorded signal's residual diagnostics (diagnostics.py): the ones stored with a
    result read back from its file, else computed from the arrays if they hold every
    sample; none for an envelope without stored ones (a file of an older pendfmu)."""
    if fit.diagnostics:
        return {name: Diagnostics.from_dict(entry) for name, entry in fit.diagnostics.items() if entry}
    return of_signals(fit.time, fit.recorded, fit.simulated) if whole(fit) else {}


def _rms(residual: np.ndarray) -> float | None:
    present = residual[np.isfinite(residual)]
    return float(np.sqrt(np.mean(present**2))) if present.size else None


def _json_array(values, index: np.ndarray) -> list[float | None]:
    return [float(v) if math.isfinite(v) else None for v in np.asarray(values, float)[index]]


def _array(values) -> np.ndarray:
    return np.array([math.nan if v is None else v for v in values], float)


def _experiment_from(entry: dict) -> ExperimentFit:
    return ExperimentFit(
        entry["name"], _array(entry["time"]), {s: _array(v) for s, v in entry["recorded"].items()},
        {s: _array(v) for s, v in entry["simulated"].items()}, dict(entry.get("resolution", {})),
        dict(entry.get("scale", {})), dict(entry.get("values", {})), dict(entry.get("overrides", {})),
        {s: v for s, v in entry.get("rms", {}).items() if v is not None}, entry.get("samples"),
        dict(entry.get("diagnostics", {})))


def read_result(path: str | Path) -> FitResult:
    """Read a result file (:meth:`FitResult.write_json`) back.

    Files written before provenance and recordings were stored read as results without
    them; per-recording estimates (phi0[run1]), whose intervals the file does not keep, come
    back without intervals.

    Parameters
    ----------
    path : str or Path
        The result file (JSON).

    Returns
    -------
    FitResult
        The result; search bounds the file does not hold are NaN.

    Raises
    ------
    BadInput
        The file cannot be read, is not JSON, or is not a result file of pendfmu fit.
    """
    from pendfmu.errors import BadInput

    path = Path(path)
    try:
        document = parse_json(path.read_text(encoding="utf-8"))
    except OSError as error:
        raise BadInput(f"{path}: cannot read the result file ({error.strerror})") from None
    except (json.JSONDecodeError, UnicodeDecodeError) as error:
        raise BadInput(f"{path}: not a result file (not valid JSON: {error})") from None
    if not isinstance(document, dict) or not isinstance(document.get("parameters"), dict) \
            or not isinstance(document.get("fit"), dict) or "stage" not in document["fit"]:
        raise BadInput(f'{path}: not a result file of pendfmu fit (expected "parameters" and "fit" with a "stage")')
    try:
        return _result_from(document)
    except (KeyError, TypeError, ValueError, AttributeError) as error:
        raise BadInput(f"{path}: a result file with a malformed entry ({type(error).__name__}: {error})") from None


def _result_from(document: dict) -> FitResult:
    fit = document["fit"]
    flags = {key: [Flag(text, kind) for text, kind in zip(texts, document.get("flag_kinds", {}).get(key, []) +
                                                           ["note"] * len(texts))]
             for key, texts in document.get("flags", {}).items()}
    methods = document.get("interval_method", {})
    estimates = {}
    for key, stderr in document.get("stderr", {}).items():
        interval = document.get("ci95", {}).get(key)
        ci95 = None if interval is None else (-math.inf if interval[0] is None else float(interval[0]),
                                              math.inf if interval[1] is None else float(interval[1]))
        value = document["parameters"].get(key)
        estimates[key] = Estimate(key, math.nan if value is None else float(value), stderr, ci95,
                                  math.nan, math.nan, list(flags.get(key, [])), methods.get(key, "jacobian"))
    for recording, states in document.get("initial", {}).items():  # per-recording estimates: values only
        for name, value in states.items():
            key = label(name, recording)
            estimates[key] = Estimate(key, float(value), None, None, math.nan, math.nan, list(flags.get(key, [])),
                                      "none")
    for key, key_flags in flags.items():  # a flagged estimate whose value the file does not hold
        estimates.setdefault(key, Estimate(key, math.nan, None, None, math.nan, math.nan, list(key_flags), "none"))
    for stage in document.get("provenance", {}).get("stages", {}).values():
        for key, (low, high) in stage.get("bounds", {}).items():
            if key in estimates:
                estimates[key].low, estimates[key].high = low, high
    return FitResult(
        fit["stage"], dict(document["parameters"]), estimates, document.get("correlation", {}),
        fit.get("cost", math.nan), fit.get("nrmse", {}), fit.get("nfev", 0), fit.get("failures", 0),
        fit.get("seconds", math.nan), [_experiment_from(e) for e in document.get("recordings", [])],
        document.get("initial", {}), list(fit.get("notes", [])), fit.get("validation", {}),
        list(fit.get("warnings", [])), fit.get("uncertainty", {}), fit.get("model"),
        provenance=document.get("provenance", {}),
        predicted=[_experiment_from(e) for e in document.get("predicted", [])], assessment=fit.get("assessment", {}),
        replicates=[{str(k): float(v) for k, v in row.items()} for row in document.get("replicates", [])])


def _json_interval(interval: tuple[float, float] | None) -> list[float | None] | None:
    """An interval for JSON: an unbounded side is null (JSON has no infinity)."""
    if interval is None:
        return None
    return [float(b) if math.isfinite(b) else None for b in interval]


def _plain(value):
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"cannot write {type(value).__name__} to JSON")
