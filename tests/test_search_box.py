"""Issue 14 item 5, a search box from the data: a friction parameter the user gave no value
for is searched in a box derived from the rig's own sizes and the recordings
(stages.DERIVED_BOUNDS), not a decade around the reference rig's value; every --bounds name
is checked; a --bounds for an initial state is honoured, and the flag that asks for one
says how to write it.

(a) the reference rig's truths lie inside their derived boxes; (b) a small pendulum (20 g,
7 cm, the Furuta pendulum's size) whose pivot friction is a hundredth of the reference
rig's: the old box misses it, the derived one holds it, and a fit given only the mass and
length finds it within its intervals; (c) the name checks and the phi0 bound.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import pendfmu
from pendfmu.cli import main
from pendfmu.components import rig_defaults
from pendfmu.errors import BadInput, OptionError
from pendfmu.fmubuild.compiler import FMUS_DIR
from pendfmu.fitting.stages import DERIVED_BOUNDS, make_experiment, rig_scales, stage_free_parameters, stage_setup
from pendfmu.recording import Recording, SignalInfo
from pendfmu.recording.writer import write_recording
from pendfmu.simulator.replay import Replay
from pendfmu.virtual_rig import write_experiments

OPTIONS = pendfmu.GlobalOptions(workers=1)
STEP = 2 * math.pi / 4000  # a 4000-count encoder, the Furuta pendulum's
SMALL = {"m_p": 0.02, "l": 0.07}  # what a user of a small pendulum knows: mass and length
SMALL_FRICTION = {"k_fwp": 1.5e-5, "T_Kp": 1.5e-4, "T_Sp": 3e-4}  # ~1/100 of the reference rig's


def boxes(stage, experiments, values, given, **kwargs):
    return {p.name: p for p in stage_free_parameters(stage, experiments, kwargs.get("free"), kwargs.get("fix", []),
                                                     kwargs.get("bounds", {}), values, given)}


def inside(box, value, margin=1.0):
    """value in [low, high], at least `margin` times from either end (log scale)."""
    return box.low * margin <= value <= box.high / margin


# -- (a) the reference rig


@pytest.fixture(scope="module")
def reference_rig(tmp_path_factory):
    folder = tmp_path_factory.mktemp("reference-rig")
    write_experiments(folder, {}, seed=11)
    return folder


def test_the_reference_rigs_truths_lie_well_inside_the_derived_boxes(reference_rig):
    """Nothing given: every friction parameter's box from the rig's sizes and the runs holds
    the reference rig's value at least a factor 3 from either end (measured: F_Kc 0.07 and k_fwc
    0.32 of the cart's scales, T_Kp 3.4e-3 and k_fwp 8.4e-3 of the pendulum's)."""
    from pendfmu.recording import read_recording

    truth = rig_defaults()
    carts = [make_experiment(read_recording(reference_rig / f"{name}.csv"), "cart", truth)
             for name in ("cart-startup-2A", "cart-startup-3A", "cart-ramp")]
    cart = boxes("cart", carts, truth, set())
    assert cart["F_Sc"].relative_to == "F_Kc"  # stiction relative to Coulomb friction, as before
    for name in ("k_fwc", "F_Kc"):
        assert inside(cart[name], truth[name], 3.0), (name, cart[name], truth[name])
    scales = rig_scales(truth, carts)
    assert scales["force"] == pytest.approx(truth["k_M"] * truth["k_D"] * 3.0, rel=0.02)  # the 3 A run's current
    decay = [make_experiment(read_recording(reference_rig / "pendulum-decay.csv"), "pendulum", truth)]
    pendulum = boxes("pendulum", decay, truth, set())
    for name in ("k_fwp", "T_Kp"):
        assert inside(pendulum[name], truth[name], 3.0), (name, pendulum[name], truth[name])
    # a stiction searched alone (Coulomb friction fixed): from the Coulomb friction (below
    # it has no effect) to the derived box's top
    alone = boxes("pendulum", decay, truth, set(), fix=["T_Kp"])
    assert alone["T_Sp"].low == truth["T_Kp"] and inside(alone["T_Sp"], truth["T_Sp"])
    assert alone["T_Sp"].high == pytest.approx(DERIVED_BOUNDS["T_Sp"][2] * rig_scales(truth, decay)["torque"])
    # at most a few decades (the global search gets lost in five)
    for box in (cart["k_fwc"], cart["F_Kc"], pendulum["k_fwp"], pendulum["T_Kp"]):
        assert box.log and math.log10(box.high / box.low) <= 4.0


def test_given_values_keep_the_decade_around_them(reference_rig):
    """A value the user gave (params or a sidecar) is still searched a decade either side;
    so are all values when no `given` is passed (the API as before): the paper's standard
    fits, which give every value, take the same boxes as before."""
    from pendfmu.recording import read_recording

    truth = rig_defaults()
    decay = [make_experiment(read_recording(reference_rig / "pendulum-decay.csv"), "pendulum", truth)]
    for given in (None, {"k_fwp", "T_Kp"}):
        box = boxes("pendulum", decay, truth, given)
        assert (box["k_fwp"].low, box["k_fwp"].high) == pytest.approx((1e-4, 1e-2))
        assert (box["T_Kp"].low, box["T_Kp"].high) == pytest.approx((2e-4, 2e-2))


# -- (b) a small pendulum


def small_decay(duration=4.0, phi0=math.pi - 1.2):
    """A free decay of the small pendulum made with the pendulum stage's own model, read by
    a 4000-count encoder (rounded to its steps)."""
    t = np.arange(0.0, duration, 1e-3)
    replay = Replay(stage_setup("pendulum", "").model, t, {})
    try:
        phi = replay.simulate({**rig_defaults(), **SMALL, **SMALL_FRICTION, "J_p": 0.0, "phi0": phi0, "w0": 0.0},
                              ["phi"])["phi"]
    finally:
        replay.close()
    return Recording(None, t, {"phi": np.round(phi / STEP) * STEP}, signal_info={"phi": SignalInfo(STEP)})


def test_a_small_pendulums_friction_is_in_the_derived_box_not_the_old_one():
    values = {**rig_defaults(), **SMALL}
    experiments = [make_experiment(small_decay(1.0), "pendulum", values)]
    derived = boxes("pendulum", experiments, values, set(SMALL))
    old = boxes("pendulum", experiments, values, None)  # a decade around the reference rig's values
    for name in ("k_fwp", "T_Kp"):
        assert inside(derived[name], SMALL_FRICTION[name], 3.0), (name, derived[name])
        assert not inside(old[name], SMALL_FRICTION[name]), (name, old[name])
    # the scales: m_p g l and m_p g l / omega_0 with J_p = (4/3) m_p l^2 (J_p = 0: a rod)
    torque = SMALL["m_p"] * 9.81 * SMALL["l"]
    omega = math.sqrt(torque / (4 / 3 * SMALL["m_p"] * SMALL["l"] ** 2))
    assert derived["T_Kp"].low == pytest.approx(DERIVED_BOUNDS["T_Kp"][1] * torque)
    assert derived["k_fwp"].high == pytest.approx(DERIVED_BOUNDS["k_fwp"][2] * torque / omega)


def test_a_small_pendulums_friction_is_fitted_without_a_friction_value():
    """Given only m_p and l: the fit finds k_fwp and T_Kp, each truth inside its interval
    (measured: +0.23 % and -0.16 %); T_Sp only bounded by a free decay, its set holding the truth."""
    result = pendfmu.fit("pendulum", [small_decay()], params=SMALL, seed=0, uncertainty="jacobian",
                         global_search=OPTIONS, progress=False)
    for name in ("k_fwp", "T_Kp"):
        low, high = result.estimates[name].ci95
        assert low <= SMALL_FRICTION[name] <= high, (name, result.estimates[name])
        assert result.parameters[name] == pytest.approx(SMALL_FRICTION[name], rel=0.05)
        assert not [f for f in result.estimates[name].flags if "bound" in f], result.estimates[name].flags
    stiction = result.estimates["T_Sp"]
    assert stiction.method == "bounded" and stiction.ci95[0] <= SMALL_FRICTION["T_Sp"] <= stiction.ci95[1]


# -- (c) bounds names, and a bound for an initial state


def test_every_bounds_name_is_checked():
    values = {**rig_defaults(), **SMALL}
    experiments = [make_experiment(small_decay(0.5), "pendulum", values)]
    with pytest.raises(OptionError, match="'T_Kq' is not one \\(did you mean 'T_Kp'"):
        boxes("pendulum", experiments, values, set(), bounds={"T_Kq": (1e-6, 1e-3)})
    with pytest.raises(OptionError, match="'T_Kp' is not estimated by the pendulum stage"):
        boxes("pendulum", experiments, values, set(), fix=["T_Kp"], bounds={"T_Kp": (1e-6, 1e-3)})
    with pytest.raises(OptionError, match="'phi_scale' is not estimated"):
        pendfmu.fit("pendulum", [small_decay(0.5)], params=SMALL, bounds={"phi_scale": (0.9, 1.1)},
                    global_search=OPTIONS, progress=False)  # phi_scale is not freed
    # a user's FMU: the same check (models.py)
    rec = Recording(None, np.arange(0.0, 0.5, 1e-3), {"phi": np.full(500, math.pi), "a": np.zeros(500)})
    fmu = str(FMUS_DIR / "Pendulum.fmu")
    with pytest.raises(BadInput, match="no parameter 'nonsense'"):
        pendfmu.fit(fmu, [rec], free=["k_fwp"], bounds={"nonsense": (0.0, 1.0)}, global_search=OPTIONS,
                    progress=False)
    with pytest.raises(OptionError, match="'T_Kp' is not estimated by Pendulum"):
        pendfmu.fit(fmu, [rec], free=["k_fwp"], bounds={"T_Kp": (0.0, 1.0)}, global_search=OPTIONS, progress=False)


def test_a_phi0_bound_is_used_and_the_flags_advice_works(tmp_path):
    """--bounds phi0=LOW:HIGH sets the release angle's box (for every recording); a box that
    excludes the truth ends the estimate at its edge with a flag whose advice, typed as
    written with numbers for LOW:HIGH, is accepted and frees it."""
    rec = small_decay(1.5)
    csv = write_recording(Recording(tmp_path / "decay", rec.time, rec.signals, signal_info=rec.signal_info),
                          tmp_path / "decay.csv")
    values = {**rig_defaults(), **SMALL}
    experiments = [make_experiment(rec, "pendulum", values)]
    box = {p.label: p for p in stage_free_parameters("pendulum", experiments, None, [], {"phi0": (1.9, 1.95)},
                                                     values, set(SMALL))}
    (phi0,) = [p for label, p in box.items() if label.startswith("phi0[")]
    assert (phi0.low, phi0.high) == (1.9, 1.95)
    params = tmp_path / "params.json"
    params.write_text(json.dumps({"parameters": SMALL}))
    common = ["fit", "pendulum", str(csv), "--params", str(params), "--uncertainty", "jacobian", "--seed", "0",
              "--workers", "1"]
    out = tmp_path / "narrow.json"
    truth = math.pi - 1.2  # 1.94159
    main([*common, "--bounds", "phi0=1.9:1.95", "--out", str(out)])
    document = json.loads(out.read_text())
    assert document["initial"]["decay"]["phi0"] == pytest.approx(truth, abs=2 * STEP)
    main([*common, "--bounds", "phi0=1.95:2.0", "--out", str(out)])
    document = json.loads(out.read_text())
    assert document["initial"]["decay"]["phi0"] == pytest.approx(1.95, abs=1e-6)  # held at the box's edge
    (flag,) = [f for f in document["flags"]["phi0[decay]"] if "bound" in f]
    assert "widen its bounds (phi0=LOW:HIGH)" in flag, flag  # the option's value, as --bounds or bounds= takes it
    advice = flag[flag.index("bounds (") + len("bounds ("):].split(")")[0]
    wide = advice.replace("LOW:HIGH", f"{truth - 0.05}:{truth + 0.05}")
    assert main([*common, "--bounds", wide, "--out", str(out)]) == 0
    document = json.loads(out.read_text())
    assert document["initial"]["decay"]["phi0"] == pytest.approx(truth, abs=2 * STEP)
    assert not [f for f in document["flags"].get("phi0[decay]", []) if "bound" in f]
