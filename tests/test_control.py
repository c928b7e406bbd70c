"""The controller designed from a fit (issue 27): the sampled law in Python, its FMU, and the
closed loop around the independent reference simulator (tests/control_loop.py)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pendfmu.components import rig_defaults
from pendfmu.control import Controller, Options, design
from pendfmu.control.export import fmu_parameters
from pendfmu.simulator import ComponentFMU

T_S = 1e-3
DPHI = 2 * math.pi / 1024


def readings(n: int, turns: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """Quantized encoder readings of a pendulum swinging up through upright and over (both of
    the law's modes, phi from hanging to past upright and `turns` full turns added), the cart
    moving: what the law must handle, not a trajectory of any rig."""
    t = T_S * np.arange(n)
    phi = math.pi + 3.6 * np.sin(2 * math.pi * 0.8 * t) * np.minimum(1.0, t) + 2 * math.pi * turns
    x = 0.05 * np.sin(3.0 * t)
    dx = 2 * math.pi / (1024 * 628.3)
    return dx * np.round(x / dx), DPHI * np.round(phi / DPHI)


def fmu_commands(parameters: dict, x: np.ndarray, phi: np.ndarray, x_ref: float) -> np.ndarray:
    """The FMU's I_c at each sample, the readings set at the communication point before reading it."""
    out = []
    with ComponentFMU("RigController", parameters) as fmu:
        for k, (x_k, phi_k) in enumerate(zip(x, phi)):
            fmu.set(x=x_k, phi=phi_k, x_ref=x_ref)
            out.append(fmu.get("I_c")[0])
            fmu.time = k * T_S
            fmu.step(T_S)
    return np.array(out)


@pytest.mark.parametrize("eta, compensation", [(0.4, True), (0.75, True), (0.4, False)])
def test_fmu_equals_the_python_law_sample_by_sample(eta, compensation):
    params = {**rig_defaults(), "eta": eta}
    the_design = design(params, Options(task="swing-up", compensation=compensation))
    assert the_design.axis == (eta <= 0.5)
    x, phi = readings(2500)
    law = Controller(the_design)
    python = np.array([law.step(x_k, phi_k, 0.01) for x_k, phi_k in zip(x, phi)])
    fmu = fmu_commands(fmu_parameters(the_design), x, phi, 0.01)
    assert np.ptp(python) > 1.0  # the law is exercised, not resting at 0
    np.testing.assert_allclose(fmu, python, rtol=0, atol=1e-9)
