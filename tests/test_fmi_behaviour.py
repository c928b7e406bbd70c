"""FMI mechanics: communication-step independence, FMU state, misuse, memory."""

from __future__ import annotations

import ctypes
import math

import numpy as np
import pytest

from pendfmu.components import ALL_COMPONENTS
from pendfmu.fmubuild.compiler import fmu_path
from pendfmu.simulator import ComponentFMU, FMUError
from pendfmu.simulator.fmi import instantiate_fmu, unpacked_fmu
from pendfmu.testing import assert_state_rollback, fmus_and_interfaces


def pendulum_decay(comm_step):
    times = np.linspace(0.0, 10.0, int(round(10.0 / comm_step)) + 1)
    with ComponentFMU("Pendulum", {"phi0": math.pi + 0.6}) as pendulum:
        result = pendulum.run(times, ["phi", "mode"])
    return {name: values[::int(round(5e-3 / comm_step))] for name, values in result.items()}


def test_results_do_not_depend_on_the_communication_step():
    """Internal steps of 0.1 ms land on both grids; only the sub-steps after an event
    differ, at the level of RK4's local error (~1e-12 rad)."""
    fine, coarse = pendulum_decay(0.2e-3), pendulum_decay(5e-3)
    np.testing.assert_allclose(fine["time"], coarse["time"], rtol=0, atol=1e-12)
    np.testing.assert_array_equal(fine["mode"], coarse["mode"])
    assert np.max(np.abs(fine["phi"] - coarse["phi"])) < 1e-9


def test_cart_results_do_not_depend_on_the_communication_step():
    def run(comm_step):
        times = np.linspace(0.0, 1.0, int(round(1.0 / comm_step)) + 1)
        with ComponentFMU("Cart", {"v0": 0.3}) as cart:
            result = cart.run(times, ["x"], inputs=lambda t: {"I": 1.0})
        return result["x"][::int(round(5e-3 / comm_step))]

    assert np.max(np.abs(run(0.2e-3) - run(5e-3))) < 1e-12


@pytest.mark.parametrize("fmu, interface", fmus_and_interfaces(
    fmu_path(ALL_COMPONENTS[name]) for name in ("Cart", "Pendulum", "CurrentLoop", "Controller")))
def test_state_rollback_is_bit_identical(fmu, interface):
    """pendfmu.testing's rollback check: states saved at several points (the Cart's one while
    sliding), restored after the run went on, and serialized, reproduce the run bit for bit."""
    assert_state_rollback(fmu, interface, stop=0.2)


def test_serialized_state_restores_in_another_instance():
    with ComponentFMU("Pendulum", {"phi0": 2.0}) as one, ComponentFMU("Pendulum", {"phi0": 2.0}) as two:
        for _ in range(100):
            one.step(1e-3)
        blob = one.slave.serializeFMUstate(one.get_state())
        state = two.slave.deSerializeFMUstate(blob)
        two.set_state(state, one.time)
        for fmu in (one, two):
            for _ in range(100):
                fmu.step(1e-3)
        assert one.get("phi", "w") == two.get("phi", "w")


# ---- misuse: every case returns fmi2Error with a logged reason, and the host survives


def expect_error(fmu, call, *fragments):
    with pytest.raises(FMUError) as caught:
        call()
    for fragment in fragments:
        assert fragment in str(caught.value)
    # Recoverable: after a reset the same instance initializes and steps again.
    fmu.slave.reset()
    fmu.slave.setupExperiment(startTime=0.0)
    fmu.slave.enterInitializationMode()
    fmu.slave.exitInitializationMode()
    fmu.time = 0.0
    fmu.step(1e-3)


@pytest.fixture
def cart():
    with ComponentFMU("Cart") as fmu:
        yield fmu


def test_misuse_step_in_wrong_phase(cart):
    cart.slave.reset()  # back to "instantiated": stepping is not allowed there
    expect_error(cart, lambda: cart.slave.doStep(0.0, 1e-3), "fmi2DoStep", "instantiated")
    expect_error(cart, cart.slave.exitInitializationMode, "may not be called in phase 'step complete'")


def test_misuse_unknown_value_reference(cart):
    expect_error(cart, lambda: cart.slave.getReal([999]), "unknown value reference 999")
    expect_error(cart, lambda: cart.slave.setReal([999], [1.0]), "unknown value reference 999")


def test_misuse_non_finite_input(cart):
    expect_error(cart, lambda: cart.slave.setReal([cart.vr["I"]], [float("nan")]), "I = nan", "not a finite")
    expect_error(cart, lambda: cart.slave.setReal([cart.vr["I"]], [float("inf")]), "not a finite")


@pytest.mark.parametrize("name, value, fragment", [("m_c", -1.0, "m_c = -1"), ("l", 0.0, "l = 0"),
                                                   ("eta", 1.2, "eta = 1.2"), ("eta", 0.0, "eta = 0"),
                                                   ("F_Sc", -0.1, "F_Sc = -0.1")])
def test_misuse_non_physical_parameter(name, value, fragment):
    with pytest.raises(FMUError, match="physical range") as caught:
        ComponentFMU("Cart", {name: value})
    assert fragment in str(caught.value)


def test_misuse_pendulum_inertia_below_point_mass():
    with pytest.raises(FMUError, match="J_p = 0.001"):
        ComponentFMU("Pendulum", {"J_p": 0.001})


def test_misuse_setting_an_output_or_a_fixed_parameter(cart):
    expect_error(cart, lambda: cart.slave.setReal([cart.vr["x"]], [1.0]), "x is an output")
    expect_error(cart, lambda: cart.slave.setInteger([cart.vr["mode"]], [1]), "mode is an local")


def test_misuse_parameter_after_initialization(cart):
    expect_error(cart, lambda: cart.slave.setReal([cart.vr["m_c"]], [2.0]), "parameter m_c can only be set")


def test_misuse_bad_input_derivative_order(cart):
    expect_error(cart, lambda: cart.slave.setRealInputDerivatives([cart.vr["I"]], [4], [1.0]), "order 4")
    expect_error(cart, lambda: cart.slave.setRealInputDerivatives([cart.vr["x"]], [1], [1.0]), "not a Real input")


def test_misuse_step_from_the_wrong_time(cart):
    expect_error(cart, lambda: cart.slave.doStep(5.0, 1e-3), "starts at t = 5")


def test_misuse_garbage_state_bytes(cart):
    expect_error(cart, lambda: cart.slave.deSerializeFMUstate(b"\0" * 16), "16 bytes given")
    good = cart.slave.serializeFMUstate(cart.slave.getFMUstate())
    with ComponentFMU("Pendulum") as other:
        with pytest.raises(FMUError, match="not a state of this Pendulum FMU|bytes given"):
            other.slave.deSerializeFMUstate(good)


def test_misuse_model_exchange_call_in_co_simulation(cart):
    library = ctypes.CDLL(str(cart.slave.unzipDirectory) + "/binaries/linux64/Cart.so")
    library.fmi2GetDerivatives.argtypes = [ctypes.c_void_p, ctypes.POINTER(ctypes.c_double), ctypes.c_size_t]
    derivatives = (ctypes.c_double * 2)()
    assert library.fmi2GetDerivatives(cart.slave.component, derivatives, 2) == 3  # fmi2Error
    assert "not available in Co-Simulation" in cart.messages[-1]


def test_wrong_guid_is_refused_with_a_message():
    directory, description = unpacked_fmu("Cart")
    with pytest.raises(FMUError, match="GUID {not-the-guid} does not match") as caught:
        instantiate_fmu(directory, description, "CS", "x", guid="{not-the-guid}")
    assert caught.value.function == "fmi2Instantiate" and caught.value.instance == "x"


def resident_kilobytes():
    with open("/proc/self/statm") as statm:
        return int(statm.read().split()[1]) * 4


def test_instantiate_free_cycles_leave_memory_flat(cart):
    """10,000 cycles: a leaked instance (~1.6 kB) would grow the process by ~16 MB."""
    library = ctypes.CDLL(str(cart.slave.unzipDirectory) + "/binaries/linux64/Cart.so")
    library.fmi2Instantiate.restype = ctypes.c_void_p
    library.fmi2FreeInstance.argtypes = [ctypes.c_void_p]
    guid = cart.slave.guid.encode()

    def cycles(n):
        for _ in range(n):
            handle = library.fmi2Instantiate(b"m", 1, guid, b"", ctypes.byref(cart.slave.callbacks), 0, 0)
            assert handle
            library.fmi2FreeInstance(handle)

    cycles(1000)  # warm up allocator pools
    before = resident_kilobytes()
    cycles(10_000)
    assert resident_kilobytes() - before < 1024


def test_outputs_computed_when_read_after_a_step():
    """After a step only the states are copied to their variables; the other outputs are
    computed when first read. They must equal the pendulum's equation
    (docs/user-guide/model.md) at the new state, and whether or not they are read must not
    change the trajectory by a bit."""
    m, l, g, k, T_K = 0.2, 0.3, 9.81, 1e-3, 2e-3
    J = 4.0 / 3.0 * m * l * l
    steps = [(0.2e-3, {"a": 0.5 * math.sin(3e-3 * n)}) for n in range(3000)]

    def swing(read_all_every_step):
        with ComponentFMU("Pendulum", {"phi0": math.pi + 0.6}) as pendulum:
            seen = []
            for h, inputs in steps:
                pendulum.step(h, inputs)
                phi, w = pendulum.get("phi", "w")
                if read_all_every_step:
                    pendulum.get("alpha", "T_A", "T_F")
                seen.append((phi, w))
            alpha, T_A, T_F = pendulum.get("alpha", "T_A", "T_F")
            mode = pendulum.get("mode")[0]
        return np.array(seen), (phi, w, mode), (alpha, T_A, T_F)

    lazy, (phi, w, mode), (alpha, T_A, T_F) = swing(False)
    eager, _, eager_outputs = swing(True)
    assert np.array_equal(lazy, eager)
    assert (alpha, T_A, T_F) == eager_outputs
    a = steps[-1][1]["a"]
    assert mode == 1 or mode == -1
    assert T_A == pytest.approx(m * l * (g * math.sin(phi) - a * math.cos(phi)), rel=1e-13, abs=1e-15)
    assert T_F == pytest.approx(k * w + T_K * mode, rel=1e-13)
    assert alpha == pytest.approx((T_A - T_F) / J, rel=1e-12, abs=1e-12)
