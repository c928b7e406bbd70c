"""The FMI 3.0 FMUs (fmus/fmi3/<Name>.fmu): valid, the same behaviour as the FMI 2.0 ones.

Both versions compile the same model, solver and instance code (framework/instance.c)
behind different facades, so they must give the same trajectories to the bit, not just to
a tolerance; the analytic tests of the FMI 2.0 FMUs (Fig. 3 breakaway, pendulum period)
are repeated through fmpy's FMI 3.0 classes as an independent driver.
"""

from __future__ import annotations

import ctypes
import math
import re
import shutil
import subprocess
import zipfile

import numpy as np
import pytest
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.fmi3 import FMU3Model, FMU3Slave
from fmpy.validation import validate_fmu

from pendfmu.components import ALL_COMPONENTS
from pendfmu.fmubuild import build_all, ensure_fmu
from pendfmu.fmubuild.compiler import FMI_HEADERS, compile_sources

from fig3 import BREAKAWAY, OMEGA, PARAMETERS, PERIOD, edges

NAMES = list(ALL_COMPONENTS)


@pytest.fixture(scope="module", autouse=True)
def fmi3_fmus():
    return build_all(fmi_version=3)


class Fmu3:
    """One FMI 3.0 instance through fmpy, initialized with `parameters`; its log is kept."""

    def __init__(self, name, interface="CoSimulation", parameters=(), event_mode=False, token=None, path=None):
        path = path or ensure_fmu(name, 3)
        self.md = read_model_description(str(path))
        self.variables = {v.name: v for v in self.md.modelVariables}
        self.directory = extract(str(path))
        self.co_simulation = interface == "CoSimulation"
        self.event_mode = event_mode or not self.co_simulation
        self.messages = []
        kind = FMU3Slave if self.co_simulation else FMU3Model
        self.fmu = kind(guid=token or self.md.guid, unzipDirectory=self.directory, modelIdentifier=name,
                        instanceName=name)
        log = self._log
        try:
            if self.co_simulation:
                self.fmu.instantiate(eventModeUsed=event_mode, logMessage=log)
            else:
                self.fmu.instantiate(logMessage=log)
        except Exception:
            shutil.rmtree(self.directory, ignore_errors=True)
            raise
        self.time = 0.0
        self.set(**dict(parameters))
        self.fmu.enterInitializationMode(startTime=0.0)
        self.fmu.exitInitializationMode()
        self.next_event_time = math.inf
        if self.event_mode:
            self.next_event_time = self.update_discrete_states()
            self.leave_event_mode()

    def _log(self, environment, status, category, message):
        self.messages.append(message.decode())

    def vr(self, name):
        return self.variables[name].valueReference

    def set(self, **values):
        for name, value in values.items():
            setter = {"Float64": self.fmu.setFloat64, "Int32": self.fmu.setInt32,
                      "Boolean": self.fmu.setBoolean}[self.variables[name].type]
            setter([self.vr(name)], [value])

    def get(self, *names):
        getter = {"Float64": self.fmu.getFloat64, "Int32": self.fmu.getInt32, "Boolean": self.fmu.getBoolean}
        return [getter[self.variables[n].type]([self.vr(n)])[0] for n in names]

    def update_discrete_states(self):
        """Event Mode: event iterations until the FMU needs none; returns the next event time."""
        while True:
            need_update, terminate, _, _, defined, next_time = self.fmu.updateDiscreteStates()
            assert not terminate
            if not need_update:
                return next_time if defined else math.inf

    def leave_event_mode(self):
        (self.fmu.enterStepMode if self.co_simulation else self.fmu.enterContinuousTimeMode)()

    def step(self, h, inputs=None):
        """A Co-Simulation step; with event mode, a time event at its end is taken in Event
        Mode with the inputs of that instant (`inputs` at the new time)."""
        if inputs:
            self.set(**inputs(self.time))
        event, terminate, early, last_time = self.fmu.doStep(self.time, h)
        assert not terminate and not early and last_time == pytest.approx(self.time + h, abs=1e-12)
        self.time += h
        if event:
            self.fmu.enterEventMode()
            if inputs:
                self.set(**inputs(self.time))
            self.update_discrete_states()
            self.leave_event_mode()
        return event

    def run(self, times, outputs, inputs=None):
        rows = [self.get(*outputs)]
        for k in range(1, len(times)):
            self.step(times[k] - times[k - 1], inputs)
            rows.append(self.get(*outputs))
        rows = np.array(rows, dtype=float)
        return {"time": np.asarray(times), **{name: rows[:, j] for j, name in enumerate(outputs)}}

    def close(self):
        try:
            self.fmu.freeInstance()
        finally:
            shutil.rmtree(self.directory, ignore_errors=True)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


# ---- the files


@pytest.mark.parametrize("name", NAMES)
def test_fmpy_validates_the_fmu(name):
    assert validate_fmu(str(ensure_fmu(name, 3))) == []


@pytest.mark.parametrize("name", NAMES)
def test_each_version_carries_only_its_own_sources(name):
    """The FMI 2.0 FMU gains no fmi3 file, the FMI 3.0 one holds no fmi2 file; each has its
    platform's binaries folder and a build description listing exactly its C files."""
    for version, own, foreign, platform in ((2, "fmi2_api.c", "fmi3", "linux64"),
                                            (3, "fmi3_api.c", "fmi2", "x86_64-linux")):
        with zipfile.ZipFile(ensure_fmu(name, version)) as fmu:
            members = fmu.namelist()
            build = fmu.read("sources/buildDescription.xml").decode()
        sources = {m.removeprefix("sources/") for m in members if m.startswith("sources/")}
        assert own in sources and not any(foreign in s for s in sources)
        assert f"binaries/{platform}/{name}.so" in members
        assert set(re.findall(r'SourceFile name="([^"]+)"', build)) == {s for s in sources if s.endswith(".c")}


def test_the_sources_compile_and_export_every_fmi3_function(tmp_path):
    """An importer compiles sources/ (the build description's files) into a library that
    exports every function of fmi3FunctionTypes.h."""
    with zipfile.ZipFile(ensure_fmu("Cart", 3)) as fmu:
        fmu.extractall(tmp_path)
    library = tmp_path / "rebuilt.so"
    compile_sources(tmp_path / "sources", library)
    exported = set(subprocess.run(["nm", "-D", "--defined-only", str(library)], capture_output=True, text=True,
                                  check=True).stdout.split())
    required = set(re.findall(r"typedef\s+\S+\s*\*?\s*(fmi3\w+)TYPE", (FMI_HEADERS / "fmi3FunctionTypes.h").read_text()))
    assert len(required) > 60
    assert required - exported == set()


@pytest.mark.parametrize("name", NAMES)
def test_variables_follow_the_table(name):
    """The table's variables with their FMI 2.0 value references, then the event indicators
    and time that FMI 3.0 wants as variables."""
    md = read_model_description(str(ensure_fmu(name, 3)))
    component = ALL_COMPONENTS[name]
    by_vr = {v.valueReference: v for v in md.modelVariables}
    for vr, var in enumerate(component.variables):
        xml = by_vr[vr]
        assert (xml.name, xml.causality) == (var.name, var.causality)
        assert xml.type == {"Real": "Float64", "Integer": "Int32", "Boolean": "Boolean"}[var.type]
        if var.type == "Real":
            assert (xml.unit or "") == var.unit
            if var.start is not None:
                assert float(xml.start) == var.start
    n = len(component.variables)
    assert [by_vr[n + k].name for k in range(component.event_indicators)] == [
        f"event_indicator_{k + 1}" for k in range(component.event_indicators)]
    assert by_vr[n + component.event_indicators].causality == "independent"
    assert md.numberOfEventIndicators == component.event_indicators
    assert md.guid != read_model_description(str(ensure_fmu(name, 2))).guid


# ---- the paper's Fig. 3 and the pendulum period, analytic


def test_fig3_breakaway_with_held_force_in_co_simulation():
    """The force held over 1 ms steps first exceeds F_S at the first sample past t_b: the mass
    breaks away at the start of the step that follows that sample (FMI 3.0 has no input
    derivatives, so the held force is the analytic case), then stops and rests at each reversal."""
    step = 1e-3
    times = np.linspace(0.0, 2.0, 2001)
    with Fmu3("Cart", parameters=PARAMETERS) as cart:
        result = cart.run(times, ["x", "v", "mode", "t_mode"], inputs=lambda t: {"I": math.sin(OMEGA * t)})
    changes = edges(result)
    assert changes[0][1:] == (0, 1)
    assert math.isclose(changes[0][0], math.ceil(BREAKAWAY / step) * step, abs_tol=1e-12)
    assert [new for _, _, new in changes] == [1, 0, -1, 0] * 3 + [1]


def test_fig3_model_exchange_finds_the_events_of_co_simulation():
    """fmpy's CVode on the FMI 3.0 Model Exchange interface, force as a staircase (exact for
    both interfaces, see test_friction_fig3.run_me_staircase): the same mode changes as the
    Co-Simulation run, stops located to the solver's tolerance."""
    step, stop = 1e-3, 2.0
    t = np.arange(0.0, stop + step / 2, step)
    held = np.sin(OMEGA * t)
    rows = [(t[0], held[0])] + [row for k in range(1, len(t)) for row in ((t[k], held[k - 1]), (t[k], held[k]))]
    me = simulate_fmu(str(ensure_fmu("Cart", 3)), fmi_type="ModelExchange", solver="CVode", stop_time=stop,
                      output_interval=step, relative_tolerance=1e-10, start_values=PARAMETERS,
                      input=np.array(rows, dtype=[("time", float), ("I", float)]), output=["x", "v", "mode", "t_mode"])
    me_edges = edges({name: me[name] for name in me.dtype.names})
    with Fmu3("Cart", parameters=PARAMETERS) as cart:
        cs = cart.run(t, ["x", "v", "mode", "t_mode"], inputs=lambda time: {"I": math.sin(OMEGA * time)})
    cs_edges = edges(cs)
    assert [(o, n) for _, o, n in me_edges] == [(o, n) for _, o, n in cs_edges]
    assert max(abs(a[0] - b[0]) for a, b in zip(me_edges, cs_edges)) < 1e-7
    assert PERIOD > 0


def test_pendulum_small_angle_period():
    """2 pi sqrt(J / (m g l)) for the reference rod (tests/test_pendulum.py)."""
    m, l, g = 0.2, 0.3, 9.81
    j = 4 / 3 * m * l**2
    times = np.linspace(0.0, 5.0, 50001)
    with Fmu3("Pendulum", parameters={"k_fwp": 0.0, "T_Kp": 0.0, "T_Sp": 0.0, "phi0": math.pi + 0.01}) as pendulum:
        theta = pendulum.run(times, ["phi"])["phi"] - math.pi
    up = np.nonzero((theta[:-1] < 0) & (theta[1:] >= 0))[0]
    crossings = times[up] - theta[up] * (times[up + 1] - times[up]) / (theta[up + 1] - theta[up])
    assert np.mean(np.diff(crossings)) == pytest.approx(2 * math.pi * math.sqrt(j / (m * g * l)), rel=2e-5)


# ---- FMU state


ROLLBACK_RUNS = {"Cart": ({"v0": 0.3}, lambda t: {"I": 2.0 * math.sin(20 * t)}, ["x", "v", "mode"]),
                 "Pendulum": ({"phi0": 2.0}, lambda t: {"a": 0.5 * math.sin(9 * t)}, ["phi", "w", "mode"]),
                 "CurrentLoop": ({}, lambda t: {"I_c": 1.5 * math.sin(30 * t)}, ["I"]),
                 "Controller": ({"K_i": 5.0}, lambda t: {"r": 1.0, "y": math.sin(40 * t)}, ["u", "u_I"]),
                 # swinging through upright and back: both of its modes, its estimator moving
                 "RigController": ({"swing_up": True, "k_E": 20.0, "a_swing": 5.0, "k_xs": 8.0, "k_vs": 6.0,
                                    "K_phi": -150.0, "K_w": -25.0, "Lx_x": 0.5, "Lv_x": 10.0, "Lphi_phi": 0.5,
                                    "Lw_phi": 10.0},
                                   lambda t: {"x": 0.02 * math.sin(10 * t), "phi": math.pi + 3.3 * math.sin(6 * t)},
                                   ["I_c", "x_hat", "w_hat", "mode"])}


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("event_mode", [False, True], ids=["step-mode", "event-mode"])
def test_state_rollback_and_serialization_reproduce_a_run(name, event_mode):
    """A state saved at t = 0.1 s, restored after the run went on to 0.2 s, repeats that
    tenth of a second bit for bit; so does its serialized form in a second instance."""
    parameters, inputs, outputs = ROLLBACK_RUNS[name]
    times = np.linspace(0.1, 0.2, 101)
    with Fmu3(name, parameters=parameters, event_mode=event_mode) as one, \
            Fmu3(name, parameters=parameters, event_mode=event_mode) as two:
        one.run(np.linspace(0.0, 0.1, 101), outputs, inputs)
        state = one.fmu.getFMUState()
        blob = one.fmu.serializeFMUState(state)
        first = one.run(times, outputs, inputs)
        one.fmu.setFMUState(state)
        one.time = 0.1
        again = one.run(times, outputs, inputs)
        two.fmu.setFMUState(two.fmu.deserializeFMUState(blob))
        two.time = 0.1
        elsewhere = two.run(times, outputs, inputs)
        one.fmu.freeFMUState(state)
    assert np.ptp(first[outputs[0]]) > 0  # the tenth of a second is not trivial
    for name_ in outputs:
        np.testing.assert_array_equal(again[name_], first[name_])
        np.testing.assert_array_equal(elsewhere[name_], first[name_])


# ---- FMI 2.0 and FMI 3.0: the same trajectories


def input_signals(name):
    """Smooth, distinct inputs for every Real input of the component, on a 1 ms grid."""
    names = [v.name for v in ALL_COMPONENTS[name].of(causality="input", type="Real")]
    t = np.linspace(0.0, 1.0, 1001)
    columns = [t] + [(0.5 + k) * np.sin((5 + 3 * k) * t + k) for k in range(len(names))]
    return np.array(list(zip(*columns)), dtype=[("time", float)] + [(n, float) for n in names])


def first_row_per_time(result):
    """fmpy records a Co-Simulation point twice when Event Mode follows it: keep the row
    before the event, the one an FMI 2.0 run records there."""
    keep = np.r_[True, result["time"][1:] != result["time"][:-1]]
    return result[keep]


@pytest.mark.parametrize("name", NAMES)
@pytest.mark.parametrize("fmi_type, event_mode", [("CoSimulation", False), ("CoSimulation", True),
                                                  ("ModelExchange", None)], ids=["CS", "CS-event-mode", "ME"])
def test_fmi2_and_fmi3_trajectories_are_identical(name, fmi_type, event_mode):
    """The same C code computes both versions (instance.c under either facade), and fmpy
    drives both with the same sequence of calls at the same times, so every recorded value
    must be equal to the bit (CVode in ME included: it sees the same right-hand side).
    With event mode a Controller sample at a communication point is taken in Event Mode
    with the inputs of that point; FMI 2.0 takes it at the start of the next step with the
    same inputs, so the trajectories agree too."""
    options = dict(fmi_type=fmi_type, stop_time=1.0, output_interval=1e-3, input=input_signals(name),
                   start_values=ROLLBACK_RUNS[name][0])
    fmi2 = simulate_fmu(str(ensure_fmu(name, 2)), **options)
    fmi3 = simulate_fmu(str(ensure_fmu(name, 3)), **options, **({"use_event_mode": event_mode} if event_mode else {}))
    if event_mode:
        fmi3 = first_row_per_time(fmi3)
    assert fmi2.dtype.names == fmi3.dtype.names and len(fmi2) == len(fmi3)
    moving = 0
    for column in fmi2.dtype.names:
        np.testing.assert_array_equal(fmi3[column], fmi2[column], err_msg=column)
        moving += np.ptp(fmi2[column].astype(float)) > 0
    assert moving > 1  # time and at least one output change: the comparison is not of constants


# ---- time events of the Controller


def test_controller_time_events_in_model_exchange():
    """Each event update announces the next sample, t_start + k T_s, as nextEventTime."""
    T_s = 2.5e-3
    with Fmu3("Controller", "ModelExchange", parameters={"T_s": T_s}) as controller:
        announced = [controller.next_event_time]  # after initialization, which took the sample at 0
        for _ in range(7):
            controller.fmu.setTime(announced[-1])
            controller.fmu.enterEventMode()
            announced.append(controller.update_discrete_states())
            controller.fmu.enterContinuousTimeMode()
        np.testing.assert_allclose(announced, T_s * np.arange(1, 9), rtol=0, atol=1e-15)


def test_controller_time_events_in_co_simulation_with_event_mode():
    """Steps of T_s / 2: every second step ends on a sample and asks for Event Mode; the
    proportional output u = K_p (r - y) then shows the inputs set at that sample."""
    T_s = 2e-3
    with Fmu3("Controller", parameters={"T_s": T_s, "K_p": 2.0}, event_mode=True) as controller:
        flags, outputs = [], []
        for k in range(1, 11):
            flags.append(controller.step(T_s / 2, inputs=lambda t: {"r": 1.0, "y": 10 * t}))
            outputs.append(controller.get("u")[0])
    assert flags == [k % 2 == 0 for k in range(1, 11)]
    for k in range(1, 10, 2):  # after step k+1, t = (k+1) T_s / 2 is a sample
        assert outputs[k] == pytest.approx(2.0 * (1.0 - 10 * (k + 1) * T_s / 2), rel=1e-12)


# ---- misuse: fmi3Error with a logged reason, never a crash


def expect_error(fmu3, call, *fragments):
    from fmpy.fmi1 import FMICallException

    with pytest.raises(FMICallException):
        call()
    for fragment in fragments:
        assert fragment in fmu3.messages[-1], fmu3.messages[-1]
    # Recoverable: after a reset the same instance initializes and steps again.
    fmu3.fmu.reset()
    fmu3.fmu.enterInitializationMode(startTime=0.0)
    fmu3.fmu.exitInitializationMode()
    fmu3.time = 0.0
    if fmu3.event_mode:
        fmu3.update_discrete_states()
        fmu3.leave_event_mode()
    if fmu3.co_simulation:
        fmu3.step(1e-3)


def test_wrong_token_is_refused_with_a_message():
    with pytest.raises(Exception, match="Failed to instantiate"):
        Fmu3("Cart", token="{not-the-token}")
    # The refusal is logged through the callback before NULL is returned.
    path = ensure_fmu("Cart", 3)
    directory = extract(str(path))
    try:
        messages = []
        slave = FMU3Slave(guid="{not-the-token}", unzipDirectory=directory, modelIdentifier="Cart",
                          instanceName="x")
        with pytest.raises(Exception):
            slave.instantiate(logMessage=lambda env, status, category, message: messages.append(message.decode()))
        assert "instantiationToken {not-the-token} does not match" in messages[-1]
    finally:
        shutil.rmtree(directory, ignore_errors=True)


@pytest.mark.parametrize("name, value, fragment", [("m_c", -1.0, "m_c = -1"), ("eta", 1.2, "eta = 1.2"),
                                                   ("F_Sc", -0.1, "F_Sc = -0.1")])
def test_non_physical_parameter(name, value, fragment):
    with Fmu3("Cart") as cart:
        cart.fmu.reset()
        expect_error(cart, lambda: cart.set(**{name: value}), "fmi3SetFloat64", fragment, "physical range")


def test_calls_in_the_wrong_state():
    with Fmu3("Cart") as cart:
        cart.fmu.reset()  # Instantiated: no stepping
        expect_error(cart, lambda: cart.fmu.doStep(0.0, 1e-3), "fmi3DoStep may not be called in Instantiated")
        expect_error(cart, cart.fmu.exitInitializationMode, "may not be called in Step Mode")
        expect_error(cart, cart.fmu.enterEventMode, "eventModeUsed = false")
        expect_error(cart, lambda: cart.set(m_c=2.0), "parameter m_c can only be set")
        expect_error(cart, lambda: cart.set(x=1.0), "x is an output")
        expect_error(cart, lambda: cart.fmu.doStep(5.0, 1e-3), "starts at t = 5")
        expect_error(cart, lambda: cart.fmu.getFloat64([999]), "unknown value reference 999")
        expect_error(cart, lambda: cart.fmu.fmi3EnterContinuousTimeMode(cart.fmu.component),
                     "fmi3EnterContinuousTimeMode is not available in Co-Simulation")
        expect_error(cart, lambda: cart.set(event_indicator_1=1.0), "event_indicator_1 is a local")
    with Fmu3("Pendulum", "ModelExchange") as pendulum:
        flag, time = ctypes.c_bool(), ctypes.c_double()
        do_step = lambda: pendulum.fmu.fmi3DoStep(pendulum.fmu.component, 0.0, 1e-3, True, ctypes.byref(flag),  # noqa: E731
                                                  ctypes.byref(flag), ctypes.byref(flag), ctypes.byref(time))
        expect_error(pendulum, do_step, "fmi3DoStep is not available in Model Exchange")
        one_state = (ctypes.c_double * 1)(1.0)
        expect_error(pendulum, lambda: pendulum.fmu.setContinuousStates(one_state, 1), "1 states given, 2 expected")


def test_garbage_state_bytes():
    with Fmu3("Cart") as cart, Fmu3("Pendulum") as pendulum:
        expect_error(cart, lambda: cart.fmu.deserializeFMUState(b"\0" * 16), "16 bytes given")
        good = cart.fmu.serializeFMUState(cart.fmu.getFMUState())
        expect_error(pendulum, lambda: pendulum.fmu.deserializeFMUState(good), "Pendulum")


def test_an_fmi2_state_is_not_an_fmi3_state():
    """The serialized state carries the build's GUID or token: the other version refuses it."""
    from pendfmu.simulator import ComponentFMU

    with ComponentFMU("Cart") as fmi2, Fmu3("Cart") as fmi3:
        blob = fmi2.slave.serializeFMUstate(fmi2.slave.getFMUstate())
        expect_error(fmi3, lambda: fmi3.fmu.deserializeFMUState(blob), "not a state of this Cart FMU")


# ---- building


@pytest.mark.parametrize("argv, versions", [([], {"fmus", "fmi3"}), (["--fmi", "2"], {"fmus"}),
                                            (["--fmi", "3"], {"fmi3"})])
def test_pendfmu_build_builds_both_versions_unless_told(argv, versions, capsys):
    from pendfmu.cli import main

    assert main(["build", *argv]) == 0
    folders = {line.rsplit("/", 2)[-2] for line in capsys.readouterr().out.splitlines()}
    assert folders == versions


def test_an_unknown_fmi_version_is_refused_by_name():
    with pytest.raises(ValueError, match="FMI version 4 is not built; known: 2, 3"):
        ensure_fmu("Cart", 4)


# ---- parameterized export


@pytest.mark.parametrize("interface", ["CoSimulation", "ModelExchange"])
def test_exported_fmi3_fmu_computes_with_its_start_values(tmp_path, interface):
    """pendfmu.export's copy with new start values and token: valid, accepted by the same
    binary through its resources folder, and the run equals setting the values by hand."""
    from pendfmu.export.fmu import write_parameterized_fmu

    values = {**PARAMETERS, "v0": 0.3}  # sliding from the start: Model Exchange's derivatives are not 0
    exported = write_parameterized_fmu("Cart", values, tmp_path / "Cart.fmu", fmi_version=3)
    assert validate_fmu(str(exported)) == []
    md = read_model_description(str(exported))
    assert md.guid != read_model_description(str(ensure_fmu("Cart", 3))).guid
    assert {v.name: float(v.start) for v in md.modelVariables if v.name in values} == values
    times = np.linspace(0.0, 0.3, 301)
    outputs = ["x", "v", "mode"]
    force = lambda t: {"I": math.sin(OMEGA * t)}  # noqa: E731
    with Fmu3("Cart", interface, path=exported) as by_export, Fmu3("Cart", interface, parameters=values) as by_hand:
        assert by_export.get(*values) == list(values.values())
        if interface == "CoSimulation":
            first, second = by_export.run(times, outputs, force), by_hand.run(times, outputs, force)
            with Fmu3("Cart", interface, parameters={"v0": 0.3}) as by_default:
                assert not np.array_equal(by_default.run(times, outputs, force)["x"], first["x"])  # values matter
            for name in outputs:
                np.testing.assert_array_equal(first[name], second[name])
        else:
            for fmu3 in (by_export, by_hand):
                fmu3.fmu.setTime(0.1)
                fmu3.set(I=0.5)
            derivatives = [np.zeros(3), np.zeros(3)]
            for fmu3, dx in zip((by_export, by_hand), derivatives):
                fmu3.fmu.getContinuousStateDerivatives(np.ctypeslib.as_ctypes(dx), 3)
            np.testing.assert_array_equal(derivatives[0], derivatives[1])
            assert np.any(derivatives[0] != 0.0)
