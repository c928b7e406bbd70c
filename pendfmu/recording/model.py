"""The Recording: a time vector and signals, checked on construction; and the quantizer
of the paper's sensors (docs/user-guide/model.md)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pendfmu.recording.schema import RIG, RecordingError, Vocabulary, _checked_values, _missing_problem, _noise_problem, _quantizer_problem, _resolution_problem
from pendfmu.suggest import did_you_mean


@dataclass(frozen=True)
class SignalInfo:
    """How one signal was measured: what the sidecar's ``"signals"`` entry says of it.

    The fit weighs and compares a signal by these (a quantized encoder is not a noisy
    analogue sensor); each is checked on construction (RecordingError).

    Attributes
    ----------
    resolution : float or None
        The quantization step Δ, in the signal's unit (e.g. m for ``x``, rad for ``phi``);
        None: not stated, e.g. an unquantized or unknown sensor.
    quantizer : str
        How a reading is quantized: ``"round"`` (the paper's default) or ``"floor"``
        (:data:`QUANTIZERS`).
    noise : float or None
        The standard deviation of the sensor noise before quantization, in the signal's
        unit; None: not stated.
    missing : str or float or None
        That some samples are missing and how they are written: ``"nan"``, or a marker
        value like -9999. Those samples become NaN, and a fit leaves them out. None: every
        sample is there, and a NaN is an error.
    """

    resolution: float | None = None
    quantizer: str = "round"
    noise: float | None = None
    missing: str | float | None = None  # how a missing sample is written: "nan", or a number such as -9999

    def __post_init__(self) -> None:
        problem = (_resolution_problem(self.resolution) or _quantizer_problem(self.quantizer)
                   or _noise_problem(self.noise) or _missing_problem(self.missing))
        if problem:
            raise RecordingError(f"SignalInfo: {problem}")


@dataclass(frozen=True, eq=False)
class Recording:
    """One recorded run: ``time`` [s] and the signals sampled at those instants.

    Signals are a ``dict`` of 1-D float64 numpy arrays rather than a pandas DataFrame:
    the simulator and the residuals index them by name and compute with numpy; a dict
    keeps the exact float64 values, has no index that duplicates ``time`` and cannot
    hold a non-numeric column. :meth:`to_frame` gives a DataFrame for plotting.

    The constructor checks everything :func:`read_recording` checks (names, lengths,
    finite values, strictly increasing time, sidecar names), so an adapter for an
    unusual file format just builds a Recording from arrays. The arrays are copied and
    made read-only: a recording is measured data, later stages must not edit it.
    Vector-shaped arrays (N x 1 or 1 x N, as MATLAB stores them) are flattened.

    Attributes
    ----------
    path : Path or None
        The file it was read from; None for a recording built in memory.
    time : ndarray
        The sample instants [s], strictly increasing, not necessarily evenly spaced.
    signals : dict of str to ndarray
        Each signal's samples (one per instant of `time`) by name (:data:`SIGNAL_NAMES`,
        or the names of `vocabulary`), in the signal's SI unit (``x`` [m], ``phi`` [rad],
        ``I`` [A], ...); in file order.
    experiment : str
        The sidecar's name of the experiment (e.g. ``"cart-startup"``); empty when not
        stated.
    signal_info : dict of str to SignalInfo
        How the signals named in it were measured (resolution, quantizer, noise, missing
        samples).
    parameters : dict of str to float
        The parameter values this run was made with, as the sidecar fixes them (SI units;
        e.g. ``m_p`` = 0 [kg] for a run with the pendulum removed).
    initial : dict of str to float
        The known initial values of states at the first sample (e.g. ``phi`` [rad]).
    ignored : tuple of str
        The columns of the file left out: marked ``"ignore"`` in the sidecar, or, from a
        .mat file, variables that are not vectors.
    sidecar : Path or None
        The sidecar file it was read with; None without one.
    vocabulary : Vocabulary
        The names it may use: :data:`RIG` (the rig's, docs/user-guide/model.md), or a user's
        model's.
    span : tuple of (float, float) or None
        The time window [s] of the file this recording was cut to by :meth:`window`;
        None for a whole file.

    Raises
    ------
    RecordingError
        A name, a length, a value or the time vector that cannot be used; the message
        names the sample.
    """

    path: Path | None
    time: np.ndarray
    signals: dict[str, np.ndarray]
    experiment: str = ""
    signal_info: dict[str, SignalInfo] = field(default_factory=dict)
    parameters: dict[str, float] = field(default_factory=dict)
    initial: dict[str, float] = field(default_factory=dict)
    ignored: tuple[str, ...] = ()
    sidecar: Path | None = None  # the sidecar file it was read with, if any
    vocabulary: Vocabulary = field(default=RIG, repr=False)  # the names it may use (schema.Vocabulary)
    span: tuple[float, float] | None = None  # the time window of the file this recording was cut to (window())

    def __post_init__(self) -> None:
        path = None if self.path is None else Path(self.path)
        object.__setattr__(self, "path", path)
        src = self.source
        where = _sample_locator
        time = _as_vector(self.time, src, "time")
        _check_time(time, src, "time", where)
        signals: dict[str, np.ndarray] = {}
        for name, values in dict(self.signals).items():
            known = self.vocabulary.signals
            if name not in known:
                raise RecordingError(f"{src}: {name!r} is not a signal name{did_you_mean(name, known)}; "
                                     f"valid: {', '.join(known)}")
            values = _as_vector(values, src, repr(name))
            _check_length(values, time, src, repr(name))
            info = dict(self.signal_info).get(name)
            missing = info.missing if isinstance(info, SignalInfo) else None
            if missing is not None and missing != "nan":
                values[values == missing] = np.nan
            _check_finite(values, src, repr(name), where, missing is not None, name)
            signals[name] = values
        if not signals:
            raise RecordingError(f"{src}: no signals, only time")
        for name, info in dict(self.signal_info).items():
            if name not in signals:
                raise RecordingError(f"{src}: signal_info for {name!r}, which is not a signal of this recording "
                                     f"(signals: {', '.join(signals)})")
            if not isinstance(info, SignalInfo):
                raise RecordingError(f"{src}: signal_info[{name!r}] must be a SignalInfo, got {type(info).__name__}")
        if not isinstance(self.experiment, str):
            raise RecordingError(f"{src}: experiment must be a string, got {type(self.experiment).__name__}")
        parameters = _checked_values(self.parameters, self.vocabulary.parameter_problem, src, "parameters")
        initial = _checked_values(self.initial, self.vocabulary.initial_problem, src, "initial")
        object.__setattr__(self, "time", _frozen(time))
        object.__setattr__(self, "signals", {n: _frozen(v) for n, v in signals.items()})
        object.__setattr__(self, "signal_info", dict(self.signal_info))
        object.__setattr__(self, "parameters", parameters)
        object.__setattr__(self, "initial", initial)
        object.__setattr__(self, "ignored", tuple(self.ignored))

    def window(self, start: float, stop: float) -> Recording:
        """The samples from `start` to `stop` as a recording of their own, e.g. one segment
        of a long run.

        Its sidecar's "initial" values belong to the run's first sample, so a window that
        starts later does not know them.

        Parameters
        ----------
        start, stop : float
            The window's first and last instants [s], both included.

        Returns
        -------
        Recording
            The window, with `span` set to its first and last sample's time.

        Raises
        ------
        RecordingError
            The window holds fewer than 2 samples.
        """
        step = float(np.median(np.diff(self.time))) if len(self.time) > 1 else 0.0
        keep = (self.time >= start - 1e-9 * step) & (self.time <= stop + 1e-9 * step)
        if keep.sum() < 2:
            raise RecordingError(f"{self.source}: the window {start:g} to {stop:g} s holds {int(keep.sum())} samples; "
                                 f"the recording runs from {self.time[0]:g} to {self.time[-1]:g} s")
        first = int(np.argmax(keep))
        return Recording(self.path, self.time[keep], {n: v[keep] for n, v in self.signals.items()}, self.experiment,
                         self.signal_info, self.parameters, self.initial if first == 0 else {}, self.ignored,
                         self.sidecar, self.vocabulary, (float(self.time[keep][0]), float(self.time[keep][-1])))

    @property
    def label(self) -> str:
        """The recording's name in results and reports: its file's stem, and for a window
        the window's time span."""
        name = Path(self.path).stem if self.path else "recording"
        return name if self.span is None else f"{name}@{self.span[0]:g}-{self.span[1]:g}s"

    @property
    def source(self) -> str:
        """The file this recording came from, as error messages name it."""
        return "<recording in memory>" if self.path is None else str(self.path)

    @property
    def undescribed(self) -> bool:
        """Nothing states how this run was made: no sidecar, and no sensor, parameter or
        initial-state information given otherwise. Its fixed values are then assumed."""
        return self.sidecar is None and not (self.experiment or self.signal_info or self.parameters or self.initial)

    @property
    def names(self) -> tuple[str, ...]:
        """Signal names in file order."""
        return tuple(self.signals)

    def signal(self, name: str) -> np.ndarray:
        """The samples of one signal; a missing one is an error naming file and column.

        Parameters
        ----------
        name : str
            The signal's name.

        Returns
        -------
        ndarray
            Its samples (read-only), one per instant of `time`.

        Raises
        ------
        RecordingError
            The recording has no such column.
        """
        if name not in self.signals:
            known = self.vocabulary.signals
            hint = "" if name in known else (
                f"; {name!r} is not a signal name either{did_you_mean(name, known)} "
                f"(valid: {', '.join(known)})")
            raise RecordingError(f"{self.source}: no column {name!r} (columns: time, {', '.join(self.signals)}){hint}")
        return self.signals[name]

    def resolution(self, name: str) -> float | None:
        """The quantization step of a signal, as the sidecar states it.

        Parameters
        ----------
        name : str
            The signal's name (a column of this recording).

        Returns
        -------
        float or None
            The step Δ in the signal's unit; None when not stated.
        """
        self.signal(name)
        info = self.signal_info.get(name)
        return None if info is None else info.resolution

    def quantizer(self, name: str) -> str:
        """How a signal's readings are quantized, as the sidecar states it.

        Parameters
        ----------
        name : str
            A column of this recording.

        Returns
        -------
        str
            ``"round"`` or ``"floor"``; ``"round"`` when not stated (the paper's sensors).
        """
        self.signal(name)
        info = self.signal_info.get(name)
        return "round" if info is None else info.quantizer

    def to_frame(self):
        """The signals as a table, for plotting and inspection.

        Returns
        -------
        pandas.DataFrame
            A column per signal, indexed by ``time`` [s].
        """
        import pandas as pd

        return pd.DataFrame(dict(self.signals), index=pd.Index(self.time, name="time"))


def quantize(values, resolution: float | None, quantizer: str = "round") -> np.ndarray:
    """What a sensor of step Δ reads: ``Δ·round(value/Δ)`` (the paper's sensors,
    docs/user-guide/model.md) or ``Δ·floor(value/Δ)``.

    ``round`` rounds halves to even (numpy's rint), which has no bias for signals that swing
    about zero.

    Parameters
    ----------
    values : array_like of float
        The true values.
    resolution : float or None
        The step Δ, in the values' unit; None (not stated) returns the values unchanged, so
        callers can pass ``recording.resolution(name)`` straight in.
    quantizer : str, optional
        ``"round"`` or ``"floor"`` (:data:`QUANTIZERS`).

    Returns
    -------
    ndarray
        The readings, a new float64 array.

    Raises
    ------
    RecordingError
        A step that is not a finite positive number, or an unknown quantizer.
    """
    values = np.asarray(values, dtype=np.float64)
    if resolution is None:
        return values.copy()
    problem = _resolution_problem(resolution) or _quantizer_problem(quantizer)
    if problem:
        raise RecordingError(f"quantize: {problem}")
    steps = np.rint(values / resolution) if quantizer == "round" else np.floor(values / resolution)
    return resolution * steps


def _check_time(time: np.ndarray, src: str, label: str, where: Callable[[int], str]) -> None:
    """Time must be finite and strictly increasing; duplicates and steps back are told apart
    because they have different causes (a logger's rounding vs. concatenated runs)."""
    if time.size == 0:
        raise RecordingError(f"{src}: {label} is empty")
    _check_finite(time, src, label, where)
    steps = np.diff(time)
    bad = np.flatnonzero(steps <= 0)
    if bad.size:
        i = int(bad[0])
        before, after = float(time[i]), float(time[i + 1])
        if before == after:
            raise RecordingError(f"{src}: duplicate time stamp {before!r} in {label} at {where(i)} and "
                                 f"{where(i + 1)}; time must strictly increase")
        raise RecordingError(f"{src}: {label} is not strictly increasing at {where(i + 1)}: {after!r} "
                             f"after {before!r} at {where(i)}")


def _check_finite(values: np.ndarray, src: str, label: str, where: Callable[[int], str],
                  missing_allowed: bool = False, signal: str | None = None) -> None:
    """No NaN or Inf: the fit compares every sample, and a gap is not a value, unless the
    sidecar says the signal has missing samples (then NaN marks one; Inf is still wrong).
    `signal`, where given, is named in the hint how to say so."""
    bad = np.flatnonzero(np.isinf(values) if missing_allowed else ~np.isfinite(values))
    if bad.size:
        i = int(bad[0])
        what = "NaN" if np.isnan(values[i]) else "Inf"
        more = f" (and {bad.size - 1} more)" if bad.size > 1 else ""
        hint = (f'; if it marks a missing sample, say so in the sidecar: "signals": {{"{signal}": '
                f'{{"missing": "nan"}}}}' if what == "NaN" and signal else "")
        raise RecordingError(f"{src}: {what} in {label} at {where(i)}{more}{hint}")


def _check_length(values: np.ndarray, time: np.ndarray, src: str, label: str) -> None:
    if len(values) != len(time):
        raise RecordingError(f"{src}: {label} has {len(values)} samples, time has {len(time)}")


def _as_vector(values, src: str, label: str) -> np.ndarray:
    """A float64 copy of a vector-shaped array (N, N x 1, 1 x N)."""
    try:
        array_ = np.array(values, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise RecordingError(f"{src}: {label} is not numeric ({exc})") from None
    if array_.ndim != 1:
        if array_.ndim == 0 or sum(d > 1 for d in array_.shape) > 1:
            raise RecordingError(f"{src}: {label} must be a vector, got shape {array_.shape}")
        array_ = array_.reshape(-1)
    return array_


def _frozen(values: np.ndarray) -> np.ndarray:
    values.setflags(write=False)
    return values


def _sample_locator(index: int) -> str:
    """Sample `index` (0-based) named as MATLAB would index it."""
    return f"sample {index + 1}"
