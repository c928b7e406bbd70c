"""An input's start value set before initialization, as importers set it: fmpy's
`simulate_fmu(start_values=...)`, an SSV value on an input (OMSimulator), estim8. FMI 2.0 and
3.0 let an importer set every variable with a start value in the instantiated phase, inputs
included; the value must then be the one initialization and the run compute with.

Each component is run through fmpy (an independent driver) in both FMI versions and both
interfaces, with one input's start value changed, and compared with what the model's
equations (docs/user-guide/model.md) give for that constant input. Then the FMU state: a
state saved in the instantiated phase carries the input, and restored bytes hold only what a
setter accepts.
"""

from __future__ import annotations

import math
import struct

import numpy as np
import pytest
from fmpy import simulate_fmu

from pendfmu.components import CART, CURRENT_LOOP, PENDULUM
from pendfmu.fmubuild import build_all, ensure_fmu
from pendfmu.simulator import ComponentFMU, FMUError

VERSIONS_AND_INTERFACES = [(version, interface) for version in (2, 3) for interface in ("CoSimulation",
                                                                                        "ModelExchange")]


@pytest.fixture(scope="module", autouse=True)
def both_versions():
    build_all(fmi_version=2)
    build_all(fmi_version=3)


def run(name, version, interface, start_values, output, stop=0.2):
    """fmpy's run of one component FMU with these start values; ME on CVode, tightly."""
    return simulate_fmu(str(ensure_fmu(name, version)), fmi_type=interface, start_values=start_values,
                        stop_time=stop, output_interval=1e-3, output=output, relative_tolerance=1e-10)


def start(component, name):
    return float(component.variable(name).start)


@pytest.mark.parametrize("version, interface", VERSIONS_AND_INTERFACES)
def test_current_loop_follows_a_command_set_before_initialization(version, interface):
    """I_c = 0.5 A, below the slope limit's reach (0.5 / T_i = 1667 < dIdt_max = 2500 A/s):
    the lag alone, I_mean = I_c (1 - exp(-t / T_i)), rising at I_c / T_i from the start."""
    command, T_i = 0.5, start(CURRENT_LOOP, "T_i")
    result = run("CurrentLoop", version, interface, {"I_c": command}, ["I_mean", "der(I_mean)"], stop=2e-3)
    assert result["der(I_mean)"][0] == pytest.approx(command / T_i, rel=1e-12)
    np.testing.assert_allclose(result["I_mean"], command * (1.0 - np.exp(-result["time"] / T_i)), rtol=0,
                               atol=1e-6 * command)


@pytest.mark.parametrize("version, interface", VERSIONS_AND_INTERFACES)
def test_cart_is_driven_by_a_current_set_before_initialization(version, interface):
    """I = 1 A breaks the cart away at once (F_A = eta k_M k_D I = 15.1 N > F_Sc = 12 N; the
    screw is self-locking at eta = 0.4, so the pendulum's inputs do not act). Sliding forward
    from rest, M v' = F_A - F_Kc - k_fwc v: v = v_end (1 - exp(-t / tau)), tau = M / k_fwc."""
    current = 1.0
    eta, k_M, k_D = (start(CART, n) for n in ("eta", "k_M", "k_D"))
    M, k_fwc, F_Kc = start(CART, "m_c") + start(CART, "m_p"), start(CART, "k_fwc"), start(CART, "F_Kc")
    F_A = eta * k_M * k_D * current
    assert F_A > start(CART, "F_Sc")
    result = run("Cart", version, interface, {"I": current}, ["F_A", "a", "v", "x"])
    assert result["F_A"][0] == pytest.approx(F_A, rel=1e-12)
    assert result["a"][0] == pytest.approx((F_A - F_Kc) / M, rel=1e-12)
    tau, v_end, t = M / k_fwc, (F_A - F_Kc) / k_fwc, result["time"]
    np.testing.assert_allclose(result["v"], v_end * (1.0 - np.exp(-t / tau)), rtol=0, atol=1e-7)
    np.testing.assert_allclose(result["x"], v_end * (t - tau * (1.0 - np.exp(-t / tau))), rtol=0, atol=1e-8)


@pytest.mark.parametrize("version, interface", VERSIONS_AND_INTERFACES)
def test_pendulum_feels_a_cart_acceleration_set_before_initialization(version, interface):
    """a = 2 m/s2 on the hanging pendulum (phi = pi): T_A = m_p l (g sin phi - a cos phi) =
    m_p l a, above the stiction T_Sp, so it starts turning with J alpha = T_A - T_Kp
    (J = 4/3 m_p l^2, the rod)."""
    acceleration = 2.0
    m_p, l, T_Kp = start(PENDULUM, "m_p"), start(PENDULUM, "l"), start(PENDULUM, "T_Kp")
    T_A = m_p * l * acceleration
    assert T_A > start(PENDULUM, "T_Sp")
    result = run("Pendulum", version, interface, {"a": acceleration}, ["T_A", "alpha"])
    assert result["T_A"][0] == pytest.approx(T_A, rel=1e-12)
    assert result["alpha"][0] == pytest.approx((T_A - T_Kp) / (4.0 / 3.0 * m_p * l**2), rel=1e-12)


@pytest.mark.parametrize("version, interface", VERSIONS_AND_INTERFACES)
def test_controller_samples_inputs_set_before_initialization(version, interface):
    """r = 1, u_ff = 0.25 with y = 0 and the defaults (K_p = 1, no integral, derivative,
    delay or saturation): u = K_p (r - y) + u_ff = 1.25 from the first sample, at t = 0, on."""
    result = run("Controller", version, interface, {"r": 1.0, "u_ff": 0.25}, ["u"], stop=0.05)
    np.testing.assert_array_equal(result["u"], 1.25)


def test_a_state_saved_before_initialization_carries_the_input():
    """The input set in the instantiated phase is part of a state saved there: restored into
    another instance, whose own input differs, it initializes to the same outputs."""
    with ComponentFMU("Cart") as one, ComponentFMU("Cart") as two:
        for fmu in (one, two):
            fmu.slave.reset()  # back to the instantiated phase, at the start values
        one.slave.setReal([one.vr["I"]], [1.0])
        blob = one.slave.serializeFMUstate(one.slave.getFMUstate())
        two.slave.setReal([two.vr["I"]], [-3.0])
        two.slave.setFMUstate(two.slave.deSerializeFMUstate(blob))
        for fmu in (one, two):
            fmu.slave.setupExperiment(startTime=0.0)
            fmu.slave.enterInitializationMode()
            fmu.slave.exitInitializationMode()
        assert one.slave.getReal([one.vr["F_A"]]) == two.slave.getReal([two.vr["F_A"]])
        assert one.slave.getReal([one.vr["F_A"]])[0] > 0


def test_restored_bytes_with_a_non_finite_input_are_refused():
    """What no setter accepts (a NaN input), no restored state may hold either."""
    marker = 0.123456789
    with ComponentFMU("Cart") as cart:
        cart.slave.reset()
        cart.slave.setReal([cart.vr["I"]], [marker])
        blob = bytes(cart.slave.serializeFMUstate(cart.slave.getFMUstate()))
        assert struct.pack("=d", marker) in blob
        damaged = blob.replace(struct.pack("=d", marker), struct.pack("=d", math.nan))
        with pytest.raises(FMUError, match="input I = nan is not finite"):
            cart.slave.deSerializeFMUstate(damaged)
