"""The one checked binding (pendfmu/simulator/fmi.py): every FMI call that fails raises
FMUError with the instance, the function, the time, the status and what the FMU logged, in
FMI 2.0 and 3.0, Co-Simulation and Model Exchange; the FMU's messages reach the instance
that logged them; the native loop gets the library's own functions."""

from __future__ import annotations

import contextlib
import ctypes
from types import SimpleNamespace

import pytest

from pendfmu.errors import BadInput, FMUError
from pendfmu.fmubuild import ensure_fmu
from pendfmu.simulator.fmi import FMU2CS, FMU2ME, FMU3CS, FMU3ME, instantiate_fmu, unpacked_fmu
from pendfmu.simulator.native import unit_of

ERROR = 3  # fmi2Error, fmi3Error

CLASSES = {(2, "CS"): FMU2CS, (2, "ME"): FMU2ME, (3, "CS"): FMU3CS, (3, "ME"): FMU3ME}
START = {2: lambda fmu: fmu.setupExperiment(startTime=0.0), 3: lambda fmu: None}
ENTER = {2: lambda fmu: fmu.enterInitializationMode(), 3: lambda fmu: fmu.enterInitializationMode(startTime=0.0)}
GET_REAL = {2: "getReal", 3: "getFloat64"}


@contextlib.contextmanager
def opened(name: str, version: int, interface: str, instance: str = "unit"):
    """An initialized instance of pendfmu's component `name` as FMI `version` `interface`,
    closed afterwards."""
    directory, description = unpacked_fmu(f"{name}{version}", ensure_fmu(name, fmi_version=version))
    fmu = instantiate_fmu(directory, description, interface, instance)
    try:
        START[version](fmu)
        ENTER[version](fmu)
        fmu.exitInitializationMode()
        if interface == "ME":
            fmu.enterContinuousTimeMode()
        yield fmu
    finally:
        fmu.close()


@pytest.mark.parametrize("version, interface", list(CLASSES))
def test_a_failing_call_raises_fmu_error_with_the_fmus_words(version, interface):
    with opened("Cart", version, interface) as fmu:
        assert type(fmu) is CLASSES[(version, interface)]
        function = f"fmi{version}Get{'Real' if version == 2 else 'Float64'}"
        with pytest.raises(FMUError) as caught:
            getattr(fmu, GET_REAL[version])([999])
        error = caught.value
        assert (error.instance, error.function, error.status, error.time) == ("unit", function, ERROR, 0.0)
        assert error.messages == [f"{function}: unknown value reference 999"]  # what the Cart's C code logs
        assert str(error) == f"unit at t = 0 s: {function}: unknown value reference 999 ({function} returned Error)"


@pytest.mark.parametrize("version", [2, 3])
def test_the_time_follows_the_steps_and_a_failed_step_is_reported_at_its_start(version):
    with opened("Cart", version, "CS") as fmu:
        fmu.doStep(0.0, 1e-3)
        fmu.doStep(1e-3, 1e-3)
        assert fmu.time == pytest.approx(2e-3, abs=1e-15)
        with pytest.raises(FMUError, match=r"^unit at t = 5 s: .*step starts at t = 5 but the FMU is at t = 0.002"):
            fmu.doStep(5.0, 1e-3)
        assert fmu.time == pytest.approx(2e-3, abs=1e-15)  # the instance did not move


@pytest.mark.parametrize("version", [2, 3])
def test_model_exchange_reports_the_time_it_was_set_to(version):
    with opened("Pendulum", version, "ME") as fmu:
        fmu.setTime(0.25)
        with pytest.raises(FMUError) as caught:
            getattr(fmu, GET_REAL[version])([999])
        assert caught.value.time == 0.25 and str(caught.value).startswith("unit at t = 0.25 s: ")


@pytest.mark.parametrize("version", [2, 3])
def test_a_wrong_guid_is_refused_with_the_fmus_reason(version):
    directory, description = unpacked_fmu(f"Cart{version}", ensure_fmu("Cart", fmi_version=version))
    with pytest.raises(FMUError, match="{not-the-guid}") as caught:
        instantiate_fmu(directory, description, "CS", "wrong", guid="{not-the-guid}")
    assert caught.value.instance == "wrong" and caught.value.time is None
    assert caught.value.function == ("fmi2Instantiate" if version == 2 else "fmi3InstantiateCoSimulation")
    assert "returned no instance" in str(caught.value) and caught.value.messages


def test_each_instance_keeps_its_own_messages():
    """fmpy's logger proxy holds one logger per process: without the binding's routing by
    component environment the Cart's message went to the instance made last."""
    with opened("Cart", 2, "CS", "cart") as cart, opened("Pendulum", 2, "CS", "pendulum") as pendulum:
        with pytest.raises(FMUError, match="unknown value reference 999"):
            cart.getReal([999])
        with pytest.raises(FMUError, match="unknown value reference 998"):
            pendulum.getReal([998])
        assert cart.messages == ["fmi2GetReal: unknown value reference 999"]
        assert pendulum.messages == ["fmi2GetReal: unknown value reference 998"]


def test_a_failure_the_fmu_said_nothing_about_still_says_what_failed():
    with opened("Cart", 2, "CS", "quiet") as fmu:
        error = fmu.failure("an FMI call of the native loop failed", since=len(fmu.messages), time=0.5)
        assert str(error) == "quiet at t = 0.5 s: an FMI call of the native loop failed; the FMU logged nothing"
        assert error.messages == [] and error.function is None


def test_the_native_loop_gets_the_librarys_own_functions():
    with opened("Cart", 2, "CS") as fmu:
        unit = unit_of(fmu)
        assert unit.component == fmu.component
        for field, function in (("set_real", "fmi2SetReal"), ("get_real", "fmi2GetReal"), ("do_step", "fmi2DoStep"),
                                ("set_input_derivatives", "fmi2SetRealInputDerivatives")):
            assert getattr(unit, field) == ctypes.cast(getattr(fmu.dll, function), ctypes.c_void_p).value


def test_an_interface_the_fmu_does_not_declare_is_bad_input():
    directory, description = unpacked_fmu("Cart2", ensure_fmu("Cart"))
    without = SimpleNamespace(fmiVersion="2.0", coSimulation=None, modelExchange=description.modelExchange,
                              guid=description.guid)  # as a Model-Exchange-only FMU declares
    with pytest.raises(BadInput, match="no CS interface of FMI 2.0"):
        instantiate_fmu(directory, without, "CS")
