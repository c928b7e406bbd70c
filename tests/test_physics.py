"""Rules between parameters (pendfmu/physics.py), checked before any work: the pendulum's
inertia about the pivot is at least m_p l^2 (a centre-of-mass value is the easy mistake with
published data), a friction asymmetry is at most its mean; an inertia about the centre of
mass is accepted as J_cm and converted with the m_p and l of each run."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest

from pendfmu import physics
from pendfmu.cli import main
from pendfmu.export import plan_export
from pendfmu.fitting.optimizer import GlobalOptions
from pendfmu.fitting.identification import fit
from pendfmu.physics import PhysicsError
from pendfmu.recording import read_recording
from pendfmu.simulator import component
from pendfmu.simulator.rig import experiment_parameters

ROD = {"m_p": 0.2, "l": 0.3}  # m_p l^2 = 0.018 kg m2
POINT_MASS = 0.2 * 0.3 * 0.3


@pytest.fixture(scope="module")
def decay(tmp_path_factory):
    """A short free decay of the virtual rig (its sidecar sets nothing)."""
    import math

    from pendfmu.virtual_rig import Trial, write_experiments

    out = tmp_path_factory.mktemp("decay")
    experiment = Trial("decay", "pendulum", 3.0, 2e-3, ("phi",), lambda t: 0.0,
                            truth_overrides={"phi0": math.pi + 0.5, "w0": 0.0}, known_initial=("w",))
    write_experiments(out, {"k_fwp": 2e-3}, seed=4, experiments=[experiment])
    return out / "decay.csv"


@pytest.fixture
def no_fmu(monkeypatch):
    """Any FMU instantiated fails the test: a refusal must come before any simulation."""
    def refuse(*args, **kwargs):
        raise AssertionError("an FMU was instantiated")

    monkeypatch.setattr(component.ComponentFMU, "__init__", refuse)


def with_sidecar_parameters(recording, folder, parameters, name=None):
    """A copy of `recording` (named `name`) whose sidecar sets `parameters`."""
    copy = folder / (name or recording.name)
    shutil.copy(recording, copy)
    sidecar = json.loads(recording.with_suffix(".json").read_text())
    sidecar["parameters"] = parameters
    copy.with_suffix(".json").write_text(json.dumps(sidecar))
    return copy


def test_the_inertia_about_the_pivot_is_at_least_the_point_mass():
    assert physics.problems({**ROD, "J_p": POINT_MASS}) == []
    assert physics.problems({**ROD, "J_p": 0.0}) == []  # the uniform rod
    (problem,) = physics.problems({**ROD, "J_p": 0.0015})
    assert "J_p = 0.0015 kg.m2 is below m_p*l^2 = 0.018 kg.m2" in problem
    assert "about the pivot" in problem and "centre of mass" in problem and "J_cm" in problem


def test_a_centre_of_mass_inertia_becomes_the_pivot_one_with_the_values_own_mass_and_arm():
    assert physics.settled({"J_cm": 0.002, "m_p": 0.5, "l": 0.2}) == {"J_p": 0.002 + 0.5 * 0.2 * 0.2, "m_p": 0.5,
                                                                       "l": 0.2}
    assert physics.settled({"J_cm": 0.002})["J_p"] == 0.002 + POINT_MASS  # the table's m_p and l


def test_one_source_may_not_give_the_inertia_both_ways():
    with pytest.raises(PhysicsError, match="J_p = 0.02 and J_cm = 0.002 both given"):
        physics.overlay({}, {"J_p": 0.02, "J_cm": 0.002}, "P.json")
    # a later source replaces the earlier one's other spelling
    assert physics.overlay({"J_p": 0.02, "m_p": 0.2}, {"J_cm": 0.002}) == {"m_p": 0.2, "J_cm": 0.002}


@pytest.mark.parametrize("mean, asymmetry, values", [("k_fwc", "dk_fwc", {"k_fwc": 2.0, "dk_fwc": -3.0}),
                                                     ("T_Kp", "dT_Kp", {"dT_Kp": 0.01})])
def test_a_friction_asymmetry_is_at_most_its_mean(mean, asymmetry, values):
    (problem,) = physics.problems(values)
    assert problem.startswith(f"|{asymmetry}| = ") and f"exceeds {mean} = " in problem


def test_search_limits_follow_the_rules():
    assert physics.limits("J_p", {"m_p": (0.1, 0.3), "l": (0.2, 0.2)}) == (pytest.approx(0.1 * 0.04), np.inf)
    assert physics.limits("dk_fwp", {"k_fwp": (1e-3, 5e-3)}) == (-5e-3, 5e-3)
    assert physics.limits("k_fwc", {"dk_fwc": (2.0, 3.0)}) == (2.0, np.inf)
    assert physics.limits("eta", {}) == (-np.inf, np.inf)


def test_a_centre_of_mass_inertia_as_j_p_is_exit_2_before_any_simulation(decay, tmp_path, capsys, no_fmu):
    """The mistake of the real decay: J_p from published data about the centre of mass. The
    fit refuses it with exit 2, having instantiated no FMU and written nothing."""
    params = tmp_path / "P.json"
    params.write_text(json.dumps({"parameters": {"J_p": 0.0015}}))
    out = tmp_path / "fit.json"
    assert main(["fit", "pendulum", str(decay), "--params", str(params), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "J_p = 0.0015 kg.m2 is below m_p*l^2" in err and "J_cm" in err and "centre of mass" in err
    assert len(err.strip().splitlines()) == 1
    assert not out.exists()


def test_a_parameters_file_with_mass_arm_and_inertia_is_refused_naming_it(decay, tmp_path, capsys):
    params = tmp_path / "P.json"
    params.write_text(json.dumps({"parameters": {"m_p": 0.2, "l": 0.3, "J_p": 0.0015}}))
    assert main(["fit", "pendulum", str(decay), "--params", str(params), "--out", str(tmp_path / "o.json")]) == 2
    assert f"{params}: J_p = 0.0015" in capsys.readouterr().err


def test_the_inertia_both_ways_in_a_sidecar_is_refused_naming_it(decay, tmp_path, capsys):
    recording = with_sidecar_parameters(decay, tmp_path, {"J_p": 0.02, "J_cm": 0.002})
    assert main(["fit", "pendulum", str(recording), "--out", str(tmp_path / "o.json")]) == 2
    err = capsys.readouterr().err
    assert str(recording) in err and "both given" in err


def test_a_sidecar_mass_applies_to_a_centre_of_mass_inertia_from_the_parameters(decay, tmp_path):
    recording = read_recording(with_sidecar_parameters(decay, tmp_path, {"m_p": 0.3}))
    values = experiment_parameters({"J_cm": 0.002, "l": 0.25}, recording)
    assert values["J_p"] == 0.002 + 0.3 * 0.25 * 0.25 and "J_cm" not in values


def test_a_fit_given_j_cm_equals_one_given_the_converted_j_p(decay):
    """J_cm in the params and in a sidecar gives the fit that the converted J_p gives."""
    def run(params):
        return fit("pendulum", [decay], params, global_search=GlobalOptions(enabled=False),
                   progress=False, uncertainty="jacobian")

    by_centre = run({"J_cm": 0.004, **ROD})
    by_pivot = run({"J_p": 0.004 + POINT_MASS, **ROD})
    assert by_centre.parameters == by_pivot.parameters
    assert by_centre.parameters["J_p"] == 0.004 + POINT_MASS and "J_cm" not in by_centre.parameters
    assert {n: e.value for n, e in by_centre.estimates.items()} == {n: e.value for n, e in by_pivot.estimates.items()}


def test_export_system_and_rig_take_j_cm_and_refuse_the_impossible(tmp_path):
    from pendfmu.ssp.compose import compose
    from pendfmu.virtual_rig import write_experiments

    assert plan_export({"J_cm": 0.002}).components["Pendulum"]["J_p"] == 0.002 + POINT_MASS
    system = compose({"Pendulum": "Pendulum"}, [], {"Pendulum.J_cm": 0.002, "m_p": 0.3})
    assert system.parameters["Pendulum"]["J_p"].value == 0.002 + 0.3 * 0.3 * 0.3
    with pytest.raises(PhysicsError, match=r"component Cart: \|dk_fwc\| = 40"):
        compose({"Cart": "Cart"}, [], {"dk_fwc": 40.0})
    with pytest.raises(PhysicsError, match="J_p = 0.001 kg.m2 is below"):
        write_experiments(tmp_path / "rig", {"J_p": 0.001})
    assert not any((tmp_path / "rig").glob("*.csv"))


# -- search boxes cut to the rules (fitting/boxes.py)


def test_a_free_inertia_is_searched_only_where_every_recording_allows_it(decay, tmp_path):
    """J_p >= m_p l^2 for each recording's own m_p: the larger one (a sidecar's 0.3 kg) rules."""
    from pendfmu.fitting.stages import make_experiment, stage_free_parameters
    from pendfmu.parameters import rig_values

    values = rig_values({})
    experiments = [make_experiment(read_recording(r), "pendulum", values)
                   for r in (decay, with_sidecar_parameters(decay, tmp_path, {"m_p": 0.3}, "heavier.csv"))]
    (inertia,) = [p for p in stage_free_parameters("pendulum", experiments, ["J_p"], [], {}, values)
                  if p.name == "J_p"]
    assert (inertia.low, inertia.high, inertia.log) == (0.3 * 0.3 * 0.3, 10.0, True)


def test_an_asymmetry_box_is_cut_to_its_mean(cart_recording):
    from pendfmu.fitting.stages import make_experiment, stage_free_parameters
    from pendfmu.parameters import rig_values

    values = rig_values({})
    experiments = [make_experiment(read_recording(cart_recording), "cart", values)]
    boxes = {p.name: p for p in stage_free_parameters("cart", experiments, ["dk_fwc"], ["k_fwc"],
                                                      {"dk_fwc": (-100.0, 100.0)}, values)}
    assert (boxes["dk_fwc"].low, boxes["dk_fwc"].high) == (-30.0, 30.0)  # k_fwc = 30 N s/m, fixed


def test_a_user_models_box_is_cut_to_the_rules_and_its_declared_range(decay):
    from pendfmu.fitting.models import initial_map, model_experiments, model_free_parameters, read_for
    from pendfmu.simulator.model import Model
    from pendfmu.fmubuild import ensure_fmu

    model = Model.load(ensure_fmu("Pendulum"))
    initial = initial_map(model, None)
    experiments = model_experiments(model, read_for(model, [decay], None, None, initial), model.defaults(), None,
                                    None, initial)
    boxes = {p.name: p for p in model_free_parameters(model, ["J_p", "m_p"], [], {"J_p": (1e-6, 1.0),
                                                                                 "m_p": (-1.0, 0.5)},
                                                      model.defaults(), experiments)}
    assert (boxes["m_p"].low, boxes["m_p"].high) == (0.0, 0.5)  # its declared range (0, inf)
    assert (boxes["J_p"].low, boxes["J_p"].high) == (1e-6, 1.0)  # m_p free down to 0: no floor
    boxes = {p.name: p for p in model_free_parameters(model, ["J_p"], [], {"J_p": (1e-6, 1.0)}, model.defaults(),
                                                      experiments)}
    assert (boxes["J_p"].low, boxes["J_p"].high) == (POINT_MASS, 1.0)


@pytest.mark.parametrize("command", ["fit all", "simulate", "rig", "export", "system"])
def test_every_command_refuses_a_centre_of_mass_j_p_before_work(command, decay, cart_recording, tmp_path, capsys,
                                                                 no_fmu):
    """Where values are assembled (fit all, simulate, rig, export, system): exit 2 with the
    message that tells pivot from centre of mass, and no FMU instantiated."""
    params = tmp_path / "P.json"
    params.write_text(json.dumps({"parameters": {"J_p": 0.0015}}))
    folder = tmp_path / "folder"
    folder.mkdir()
    for recording in (decay, cart_recording):
        shutil.copy(recording, folder)
        shutil.copy(recording.with_suffix(".json"), folder)
    out = tmp_path / "out"
    argv = {"fit all": ["fit", "all", str(folder), "--params", str(params), "--out", str(out)],
            "simulate": ["simulate", "--params", str(params), "--input",
                         str(with_sidecar_parameters(cart_recording, tmp_path, {}, "run.csv")), "--out", f"{out}.csv"],
            "rig": ["rig", "--params", str(params), "--out", str(out)],
            "export": ["export", "--params", str(params), "--out", str(out)],
            "system": ["system", "--component", "Pendulum", "--set", "J_p=0.0015", "--out", f"{out}.ssp"]}[command]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "J_p = 0.0015 kg.m2 is below m_p*l^2" in err and "J_cm" in err, err
    assert not list(tmp_path.glob("out*")) and not (out.exists() and any(out.iterdir()))
