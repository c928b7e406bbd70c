"""The virtual rig: experiments, sensor models, seeding, truth file."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from pendfmu.components import COMPONENTS, rig_defaults
from pendfmu.recording import read_recording
from pendfmu.virtual_rig import (ADC_BITS, ADC_RANGE, RIPPLE, Trial, reference_truth, standard_experiments,
                                 steps, write_experiments)

SHORT = [
    Trial("current", "current", 0.004, 20e-6, ("I_c", "I"), steps((0, 0.0), (1e-3, 2.0))),
    Trial("cart", "cart", 0.3, 2e-4, ("I_c", "I", "x"), steps((0, 0.0), (0.01, 2.0)),
               sidecar_parameters={"m_p": 0.0}, known_initial=("x", "v")),
    Trial("decay", "pendulum", 1.0, 2e-4, ("phi",), lambda t: 0.0, truth_overrides={"phi0": math.pi + 0.6}),
    Trial("rig", "rig", 0.3, 2e-4, ("I_c", "x", "phi"), steps((0, 0.0), (0.01, 2.0)),
               truth_overrides={"phi0": math.pi + 0.1}, known_initial=("phi",)),
]


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    out = tmp_path_factory.mktemp("rig")
    write_experiments(out, seed=7, experiments=SHORT)
    return out


def multiples_of(values, step):
    return np.allclose(values / step, np.round(values / step), rtol=0, atol=1e-6)


def test_pendulum_encoder_is_10_bit(recorded):
    for name in ("decay", "rig"):
        phi = read_recording(recorded / f"{name}.csv").signal("phi")
        assert multiples_of(phi, 2 * math.pi / 1024)
        assert len(np.unique(phi)) > 10  # it moved


def test_motor_encoder_has_1024_counts_per_revolution(recorded):
    recording = read_recording(recorded / "cart.csv")
    step = 2 * math.pi / (1024 * reference_truth()["k_D"])
    assert recording.resolution("x") == pytest.approx(step, rel=1e-15)
    assert multiples_of(recording.signal("x"), step)


def test_current_adc_is_12_bit_with_noise(recorded):
    recording = read_recording(recorded / "current.csv")
    current, command = recording.signal("I"), recording.signal("I_c")
    assert multiples_of(current, 2 * ADC_RANGE / 2**ADC_BITS)
    settled = recording.time > 3.5e-3  # 2.5 ms after the step: the lag's error is e^-8 of 0.75 A
    residual = current[settled] - command[settled]
    # Ripple 0.03 A amplitude (rms 0.021) plus 4 mA noise plus quantization: rms ~ 0.022 A.
    assert 0.015 < np.std(residual) < 0.03
    assert recording.signal_info["I"].noise == pytest.approx(4e-3)


def test_sidecar_states_fixed_parameters_and_known_initial_states(recorded):
    cart = read_recording(recorded / "cart.csv")
    assert cart.parameters == {"m_p": 0.0}
    assert cart.initial == {"x": 0.0, "v": 0.0}
    rig = read_recording(recorded / "rig.csv")
    # Known initial angle is the encoder's reading of the release angle.
    assert rig.initial["phi"] == pytest.approx(math.pi + 0.1, abs=math.pi / 1024)
    assert multiples_of(np.array([rig.initial["phi"]]), 2 * math.pi / 1024)


def test_the_truth_is_the_tables_defaults_but_for_the_converters_ripple():
    truth = reference_truth()
    assert {name: value for name, value in truth.items() if name not in RIPPLE} == \
        {name: value for name, value in rig_defaults().items() if name not in RIPPLE}
    assert set(truth) == set(rig_defaults()) and all(truth[name] != rig_defaults()[name] for name in RIPPLE)


def test_a_shared_parameter_has_one_default_unit_and_range():
    """rig_defaults and the checks take a shared name's (m_p, l) first table row: the rows
    must agree on what the first one says, but for the Cart's m_p = 0 (pendulum removed)."""
    for name in ("m_p", "l"):
        rows = [c.parameters[name] for c in COMPONENTS.values() if name in c.parameters]
        assert len(rows) == 2 and len({(row.start, row.unit, row.high) for row in rows}) == 1, name


def test_truth_is_written_beside(recorded):
    truth = json.loads((recorded / "truth.json").read_text())
    assert truth["seed"] == 7
    assert truth["parameters"]["F_Sc"] == 12.0 and truth["parameters"]["a_h"] == 0.03


def test_same_seed_same_files_other_seed_other_noise(recorded, tmp_path):
    write_experiments(tmp_path / "a", seed=7, experiments=SHORT[:1])
    write_experiments(tmp_path / "b", seed=8, experiments=SHORT[:1])
    original = (recorded / "current.csv").read_bytes()
    assert (tmp_path / "a" / "current.csv").read_bytes() == original
    assert (tmp_path / "b" / "current.csv").read_bytes() != original


def test_cart_without_pendulum_moves_as_the_cart_alone(recorded):
    """m_p = 0: the cart's position is the CurrentLoop -> Cart chain, pendulum absent."""
    x = read_recording(recorded / "cart.csv").signal("x")
    assert x[-1] > 0.05 and np.all(np.diff(x) >= 0)


def test_standard_set_covers_the_papers_sequence():
    kinds = [e.kind for e in standard_experiments()]
    assert kinds.count("current") == 1 and kinds.count("cart") == 3 and kinds.count("pendulum") == 2
    assert kinds.count("rig") == 4  # coupled step and three bang-bang start angles
