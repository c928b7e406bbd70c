"""The foreign FMUs of issue 13 (tests/foreign/) against independent answers, and the
hand-written baseline fit (scripts/foreign_baseline.py) against the truth.

These FMUs are the fixtures the generic fitting engine will be tested with, so they are
checked here on their own: closed forms of the cart's sliding, stopping and reversing
phases, exact rest below breakaway, reset and FMU-state rollback (pendfmu.testing's
checks), the refusals (bad
values, no reset, no state) with their logged messages, and that every one validates
and runs under fmpy's `simulate_fmu` as the interface it declares.
"""

from __future__ import annotations

import contextlib
import ctypes
import importlib.util
import math
import shutil
from pathlib import Path

import fmpy
import numpy as np
import pytest
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import (FMU2Model, FMU2Slave, fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                       fmi2CallbackFunctions, fmi2CallbackLoggerTYPE)
from fmpy.logging import addLoggerProxy
from fmpy.validation import validate_fmu

from foreign.build import CFLAGS, INTERFACE, build_all
from foreign import recordings
from pendfmu.testing import assert_deterministic, assert_reset_restores, assert_state_rollback

SCRIPTS = Path(__file__).resolve().parents[1] / "scripts"

# A cart without the Stribeck dip (F_s = F_c): its sliding phases have closed forms.
PLAIN = {"m": 2.0, "k_u": 4.0, "c_v": 8.0, "F_c": 3.0, "F_s": 3.0, "v_s": 1e3, "F_0": 0.5}


@pytest.fixture(scope="module")
def fmus(tmp_path_factory) -> dict[str, Path]:
    return build_all(tmp_path_factory.mktemp("foreign-fmus"))


class Unit:
    """One instance of a foreign FMU through fmpy's low-level classes, with its log."""

    def __init__(self, fmu: Path, name: str = "unit"):
        self.description = read_model_description(str(fmu))
        self.vr = {v.name: v.valueReference for v in self.description.modelVariables}
        self.unzipped = extract(str(fmu))
        cs = self.description.coSimulation
        kind, interface = (FMU2Slave, cs) if cs else (FMU2Model, self.description.modelExchange)
        self.fmu = kind(guid=self.description.guid, unzipDirectory=self.unzipped,
                        modelIdentifier=interface.modelIdentifier, instanceName=name)
        self.messages: list[tuple[int, str]] = []
        self.callbacks = fmi2CallbackFunctions()
        self.callbacks.logger = fmi2CallbackLoggerTYPE(self._log)
        self.callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(fmpy.calloc)
        self.callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(fmpy.free)
        addLoggerProxy(ctypes.byref(self.callbacks))
        self.fmu.instantiate(callbacks=self.callbacks)

    def _log(self, environment, instance, status, category, message):
        self.messages.append((status, message.decode()))

    def set(self, **values: float):
        self.fmu.setReal([self.vr[n] for n in values], list(values.values()))

    def get(self, *names: str) -> list[float]:
        return self.fmu.getReal([self.vr[n] for n in names])

    def start(self, **parameters: float):
        self.set(**parameters)
        self.fmu.setupExperiment(startTime=0.0)
        self.fmu.enterInitializationMode()
        self.fmu.exitInitializationMode()

    def steps(self, u, dt=1e-3, t0=0.0, input_name="u", outputs=("x", "v")) -> np.ndarray:
        """Holds u[k] over step k; returns the outputs after every step, one row each."""
        rows = []
        for k, uk in enumerate(u):
            self.set(**{input_name: float(uk)})
            self.fmu.doStep(t0 + k * dt, dt)
            rows.append(self.get(*outputs))
        return np.array(rows)

    def close(self):
        self.fmu.freeInstance()
        shutil.rmtree(self.unzipped, ignore_errors=True)


@contextlib.contextmanager
def opened(fmu: Path, name: str = "unit"):
    unit = Unit(fmu, name)
    try:
        yield unit
    finally:
        unit.close()


def linear_cart(m, c, force, v0, t):
    """x(t) - x(0) and v(t) of m v' = force - c v: an independent closed form."""
    v_end, rate = force / c, c / m
    decay = np.exp(-rate * t)
    return v_end * t + (v0 - v_end) * (1 - decay) / rate, v_end + (v0 - v_end) * decay


# --- every FMU --------------------------------------------------------------------------

@pytest.mark.parametrize("name", sorted(INTERFACE))
def test_every_foreign_fmu_validates_and_declares_its_interface(fmus, name):
    assert validate_fmu(str(fmus[name])) == []
    description = read_model_description(str(fmus[name]))
    assert (description.coSimulation is not None) == (INTERFACE[name] == "CS")
    assert (description.modelExchange is not None) == (INTERFACE[name] == "ME")
    assert {"-Wall", "-Wextra", "-Werror"} <= set(CFLAGS)


@pytest.mark.parametrize("name", sorted(INTERFACE))
def test_the_binary_starts_from_the_declared_start_values(fmus, name):
    """The hand-written XML and the C tables agree: every declared start value is what the
    binary holds after instantiation, and an undeclared value reference is refused."""
    with opened(fmus[name]) as unit:
        for variable in unit.description.modelVariables:
            if variable.type == "Real" and variable.start is not None:
                assert unit.get(variable.name) == [float(variable.start)], variable.name
        with pytest.raises(FMICallException):
            unit.fmu.getReal([31])
        assert "unknown value reference 31" in unit.messages[-1][1]


@pytest.mark.parametrize("name, start_values, input_name", [
    ("ForeignCart", {"u": 2.0, **PLAIN}, "u"),
    ("NoStateCart", {"u": 1.0}, "u"),
    ("MEOnly", {"u": 0.5}, "u"),
    ("Colliding", {"I": 2.0}, "I"),
])
def test_every_foreign_fmu_runs_under_simulate_fmu(fmus, name, start_values, input_name):
    fmi_type = "CoSimulation" if INTERFACE[name] == "CS" else "ModelExchange"
    result = simulate_fmu(str(fmus[name]), fmi_type=fmi_type, stop_time=0.5, output_interval=1e-3,
                          start_values=start_values, output=["x", "v"])
    assert len(result) == 501 and np.all(np.isfinite(result["x"])) and result["x"][-1] > 0.0


@pytest.mark.parametrize("name, variable, value, expected", [
    ("ForeignCart", "m", -2.0, "m = -2 is out of range: a mass must be > 0"),
    ("ForeignCart", "v_s", 0.0, "v_s = 0 is out of range"),
    ("ForeignCart", "F_s", -1.0, "F_s = -1 is out of range"),
    ("ForeignCart", "h_max", math.inf, "h_max = inf: not a finite number"),
    ("ForeignCart", "k_u", math.nan, "k_u = nan: not a finite number"),
    ("NoStateCart", "m", -1.0, "m = -1 is out of range"),
    ("NoStateCart", "c", 0.0, "c = 0 is out of range"),
    ("MEOnly", "omega", -1.0, "omega = -1 is out of range"),
    ("Colliding", "eta", 1.5, "eta = 1.5 is out of range: an efficiency must be in (0, 1]"),
    ("Colliding", "m_p", 0.0, "m_p = 0 is out of range"),
])
def test_a_bad_parameter_is_an_error_with_a_logged_reason(fmus, name, variable, value, expected):
    with opened(fmus[name]) as unit:
        with pytest.raises(FMICallException):
            unit.set(**{variable: value})
        assert unit.messages[-1] == (3, unit.messages[-1][1]) and expected in unit.messages[-1][1]
        assert unit.get(variable) != [value]  # refused, not stored


@pytest.mark.parametrize("name, input_name", [("ForeignCart", "u"), ("NoStateCart", "u"),
                                              ("MEOnly", "u"), ("Colliding", "I")])
@pytest.mark.parametrize("value", [math.nan, math.inf, -math.inf])
def test_a_non_finite_input_while_running_is_an_error_never_a_crash(fmus, name, input_name, value):
    with opened(fmus[name]) as unit:
        unit.start()
        with pytest.raises(FMICallException):
            unit.set(**{input_name: value})
        assert "not a finite number" in unit.messages[-1][1]
        if INTERFACE[name] == "CS":  # the failed instance refuses to go on, and says so
            with pytest.raises(FMICallException):
                unit.fmu.doStep(0.0, 1e-3)
            assert "not allowed in failed" in unit.messages[-1][1]


def test_a_parameter_cannot_change_while_stepping(fmus):
    with opened(fmus["ForeignCart"]) as unit:
        unit.start(**PLAIN)
        with pytest.raises(FMICallException):
            unit.set(F_s=4.0)
        assert "fixed after initialization" in unit.messages[-1][1]


# --- ForeignCart: stick-slip against closed forms ------------------------------------------

def test_above_breakaway_the_cart_approaches_its_terminal_speed_exponentially(fmus):
    u = 2.0
    with opened(fmus["ForeignCart"]) as unit:
        unit.start(**PLAIN, x0=0.1)
        xv = unit.steps(np.full(1000, u))
    t = np.arange(1, 1001) * 1e-3
    force = PLAIN["k_u"] * u + PLAIN["F_0"] - PLAIN["F_c"]
    x, v = linear_cart(PLAIN["m"], PLAIN["c_v"], force, 0.0, t)
    assert np.max(np.abs(xv[:, 0] - 0.1 - x)) < 1e-10 and np.max(np.abs(xv[:, 1] - v)) < 1e-10


def test_a_coarse_internal_step_on_a_stiff_cart_stays_stable(fmus):
    """h_max 10 ms with m/c_v = 2 ms: the FMU shortens its substeps to the time constant."""
    stiff = {**PLAIN, "c_v": 1000.0, "h_max": 1e-2}
    with opened(fmus["ForeignCart"]) as unit:
        unit.start(**stiff)
        xv = unit.steps(np.full(50, 2.0))
    x, v = linear_cart(2.0, 1000.0, 4.0 * 2.0 + 0.5 - 3.0, 0.0, np.arange(1, 51) * 1e-3)
    assert np.max(np.abs(xv[:, 1] - v)) < 1e-3 * v[-1] and np.max(np.abs(xv[:, 0] - x)) < 1e-3 * x[-1]


@pytest.mark.parametrize("u", [1.0, 1.125, -1.375, 0.0])
def test_at_or_below_breakaway_the_cart_does_not_move_at_all(fmus, u):
    """|k_u u + F_0| <= F_s (1.125 V and -1.375 V are exactly at F_s = 5 N): x stays x0
    bit for bit, v is exactly 0, the mode says stuck."""
    with opened(fmus["ForeignCart"]) as unit:
        unit.start(**recordings.TRUTH, x0=0.123)
        xv = unit.steps(np.full(500, u))
        assert unit.fmu.getInteger([unit.vr["mode"]]) == [0]
    assert np.all(xv[:, 0] == 0.123) and np.all(xv[:, 1] == 0.0)


def test_a_sliding_cart_stops_inside_a_step_and_stays_stuck(fmus):
    """From v0 = 0.3 m/s with no drive, the cart stops at t* = (m/c) ln(1 + c v0/F_c) at
    x* = (m v0 - F_c t*)/c, inside a 1 ms step, and never moves again."""
    m, c, F_c, v0 = PLAIN["m"], PLAIN["c_v"], PLAIN["F_c"], 0.3
    t_stop = m / c * math.log1p(c * v0 / F_c)
    x_stop = (m * v0 - F_c * t_stop) / c
    with opened(fmus["ForeignCart"]) as unit:
        unit.start(**{**PLAIN, "F_0": 0.0}, v0=v0)
        xv = unit.steps(np.zeros(200))
    t = np.arange(1, 201) * 1e-3
    sliding = t < t_stop
    x, v = linear_cart(m, c, -F_c, v0, t[sliding])
    assert np.max(np.abs(xv[sliding, 0] - x)) < 1e-10 and np.max(np.abs(xv[sliding, 1] - v)) < 1e-10
    assert np.all(xv[~sliding, 1] == 0.0) and np.max(np.abs(xv[~sliding, 0] - x_stop)) < 1e-10
    assert t_stop % 1e-3 > 1e-4  # the stop is well inside a step


def test_a_cart_pushed_back_hard_reverses_at_its_stop(fmus):
    """A cart moving forward under a constant backward force above F_s stops at t1 and
    slides backward from there: both phases in closed form."""
    m, c, F_c, v0, u = PLAIN["m"], PLAIN["c_v"], PLAIN["F_c"], 0.4, -2.0
    force = PLAIN["k_u"] * u + PLAIN["F_0"]  # -7.5 N, |F| > F_s
    t1 = m / c * math.log1p(c * v0 / (F_c - force))
    x1, _ = linear_cart(m, c, force - F_c, v0, t1)
    with opened(fmus["ForeignCart"]) as unit:
        unit.start(**PLAIN, v0=v0)
        xv = unit.steps(np.full(300, u))
        assert unit.fmu.getInteger([unit.vr["mode"]]) == [-1]
    t = np.arange(1, 301) * 1e-3
    after = t > t1
    x, v = linear_cart(m, c, force + F_c, 0.0, t[after] - t1)
    assert np.max(np.abs(xv[after, 0] - (x1 + x))) < 1e-9 and np.max(np.abs(xv[after, 1] - v)) < 1e-9


def test_one_long_step_equals_many_short_ones(fmus):
    """Variable communication steps: with the same internal step, a 0.3 s step and three
    hundred 1 ms steps agree, a stop and a Stribeck breakaway included."""
    parameters = {**recordings.TRUTH, "h_max": 1e-4, "v0": -0.2}
    with opened(fmus["ForeignCart"]) as unit:
        unit.start(**parameters)
        short = unit.steps(np.full(300, 1.6))[-1]
    with opened(fmus["ForeignCart"]) as unit:
        unit.start(**parameters)
        unit.set(u=1.6)
        unit.fmu.doStep(0.0, 0.3)
        long = np.array(unit.get("x", "v"))
    assert np.max(np.abs(short - long)) < 1e-12 and short[1] > 0.0


def test_reset_restores_the_start_values_and_takes_new_parameters(fmus):
    """pendfmu.testing's reset check: after fmi2Reset a run equals a fresh instance's (F_s
    back at its start value), and F_s = 6 set after the reset acts like a fresh instance
    with F_s = 6 (which changes the outputs, else the check could not tell)."""
    assert_reset_restores(fmus["ForeignCart"], parameter="F_s", value=6.0, refusal_ok=False)


def test_state_rollback_and_serialization_reproduce_a_run_exactly(fmus):
    """pendfmu.testing's rollback check (saves in each mode, restored in the same instance and
    through serialization)."""
    assert_state_rollback(fmus["ForeignCart"])


def test_a_serialized_state_restores_in_another_instance_with_other_parameters(fmus):
    u = recordings.voltage_profiles()["fit_steps"][1]
    with opened(fmus["ForeignCart"]) as unit:
        unit.start(**recordings.TRUTH)
        unit.steps(u[:700])
        state = unit.fmu.getFMUstate()
        serialized = unit.fmu.serializeFMUstate(state)
        later = unit.steps(u[700:], t0=0.7)
        unit.fmu.freeFMUstate(state)
    with opened(fmus["ForeignCart"], "other") as unit:
        unit.start(**{**recordings.TRUTH, "F_c": 1.0})
        restored = unit.fmu.deSerializeFMUstate(serialized)
        unit.fmu.setFMUstate(restored)
        elsewhere = unit.steps(u[700:], t0=0.7)
        unit.fmu.freeFMUstate(restored)
    assert np.array_equal(later, elsewhere)
    assert np.ptp(later[:, 0]) > 0.1  # it moved, through stops and breakaways


# --- NoStateCart, MEOnly, Colliding -------------------------------------------------------

def test_no_state_cart_cannot_be_reset_or_saved_but_a_new_instance_works(fmus):
    with opened(fmus["NoStateCart"]) as unit:
        unit.start(m=2.0, k=4.0, c=8.0)
        first = unit.steps(np.full(100, 1.5))
        with pytest.raises(FMICallException):
            unit.fmu.getFMUstate()
        assert "does not support FMU states" in unit.messages[-1][1]
        with pytest.raises(FMICallException):
            unit.fmu.reset()
        assert "fmi2Reset is not supported by NoStateCart" in unit.messages[-1][1]
    assert_deterministic(fmus["NoStateCart"])  # a new instance gives the same run, bit for bit
    x, v = linear_cart(2.0, 8.0, 6.0, 0.0, np.arange(1, 101) * 1e-3)
    assert np.max(np.abs(first - np.column_stack([x, v]))) < 1e-14
    assert read_model_description(str(fmus["NoStateCart"])).coSimulation.canGetAndSetFMUstate is False


def test_me_only_runs_under_cvode_against_its_closed_form(fmus):
    omega, zeta, x0, v0, u = 10.0, 0.1, 0.2, -1.0, 0.5
    result = simulate_fmu(str(fmus["MEOnly"]), fmi_type="ModelExchange", solver="CVode", stop_time=2.0,
                          output_interval=1e-2, relative_tolerance=1e-10,
                          start_values={"omega": omega, "zeta": zeta, "x0": x0, "v0": v0, "u": u})
    t = result["time"]
    wd = omega * math.sqrt(1 - zeta ** 2)
    a, b = x0 - u, (v0 + zeta * omega * (x0 - u)) / wd
    x = u + np.exp(-zeta * omega * t) * (a * np.cos(wd * t) + b * np.sin(wd * t))
    assert np.max(np.abs(result["x"] - x)) < 1e-6
    with pytest.raises(Exception, match="CoSimulation"):
        simulate_fmu(str(fmus["MEOnly"]), fmi_type="CoSimulation", stop_time=1.0)


def test_colliding_names_mean_something_else_here(fmus):
    """Named like pendfmu's Cart (eta, m_p, k_fwc, I, x, v, F_A) but another model with
    other value references; F_A follows I at once (direct feedthrough)."""
    description = read_model_description(str(fmus["Colliding"]))
    names = {v.name: v for v in description.modelVariables}
    assert {"eta", "m_p", "k_fwc", "I", "x", "v", "F_A"} <= set(names)
    assert names["eta"].causality == "parameter" and names["x"].causality == "output"
    with opened(fmus["Colliding"]) as unit:
        unit.start(eta=0.8, m_p=0.5, k_fwc=2.0, k_F=3.0)
        unit.set(I=1.5)
        assert unit.get("F_A") == [0.8 * 3.0 * 1.5]
        xv = unit.steps(np.full(400, 1.5), input_name="I")
    x, v = linear_cart(0.5, 2.0, 0.8 * 3.0 * 1.5, 0.0, np.arange(1, 401) * 1e-3)
    assert np.max(np.abs(xv - np.column_stack([x, v]))) < 1e-13
    with opened(fmus["Colliding"]) as unit:  # no friction: the series branch, x = a t^2 / 2
        unit.start(eta=1.0, m_p=2.0, k_fwc=0.0, k_F=1.0)
        xv = unit.steps(np.full(100, 4.0), input_name="I")
    t = np.arange(1, 101) * 1e-3
    assert np.max(np.abs(xv[:, 0] - t ** 2)) < 1e-15 and np.max(np.abs(xv[:, 1] - 2 * t)) < 1e-15


# --- recordings and the baseline -----------------------------------------------------------

def test_the_recordings_are_quantized_and_cover_stick_and_slip(fmus, tmp_path):
    paths = recordings.write_recordings(fmus["ForeignCart"], tmp_path)
    assert list(paths) == [*recordings.FIT_NAMES, recordings.PREDICTION_NAME]
    for name, path in paths.items():
        data, sidecar = recordings.read(path)
        assert list(data.columns) == ["time", "u", "x"]
        assert np.allclose(np.diff(data["time"]), recordings.SAMPLE_PERIOD, rtol=0, atol=1e-12)
        steps = data["x"] / recordings.RESOLUTION
        assert np.max(np.abs(steps - np.rint(steps))) < 1e-6
        assert sidecar["signals"]["x"] == {"resolution": recordings.RESOLUTION, "quantizer": "round"}
        moving = np.diff(data["x"]) != 0
        assert 0.1 < moving.mean() < 0.95, name  # it both sticks and slides


def test_the_baseline_fit_reaches_every_parameter_within_one_percent(tmp_path):
    spec = importlib.util.spec_from_file_location("foreign_baseline", SCRIPTS / "foreign_baseline.py")
    baseline = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(baseline)
    result = baseline.run_baseline(tmp_path)
    errors = result["relative_error"]
    assert all(abs(errors[p]) < 0.01 for p in recordings.FITTED), errors
    assert result["prediction_rms_steps"] < 1.0
