"""`pendfmu export`: parameterized FMUs, the SSV file and the Modelica modifiers.

The exported FMUs must behave as the original FMU given the same start values (same
binary, bit-identical results), declare those values in their model description, keep
them across fmi2Reset, and refuse a start file that does not belong to them.
"""

from __future__ import annotations

import json
import math
import zipfile
from ctypes import byref
from pathlib import Path

import numpy as np
import pytest
import rumoca
from fmpy import calloc, extract, free, read_model_description, simulate_fmu
from fmpy.fmi2 import FMU2Slave, fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE
from fmpy.fmi2 import fmi2CallbackFunctions, fmi2CallbackLoggerTYPE
from fmpy.logging import addLoggerProxy
from fmpy.validation import validate_fmu
from lxml import etree
from scipy.special import ellipk

from pendfmu.cli import main
from pendfmu.components import COMPONENTS
from pendfmu.export import START_FILE, export_all, plan_export
from pendfmu.fmubuild import ensure_fmu
from pendfmu.parameters import ParameterFileError
from pendfmu.simulator import ComponentFMU
from pendfmu.ssp import read_ssv, schema_dir

MODELICA = Path(__file__).resolve().parents[1] / "modelica"

# An undamped pendulum released 0.1 rad from hanging, a lighter and longer one than the
# default, a cart with other friction, a slower current loop.
PARAMS = {"k_fwp": 0.0, "T_Kp": 0.0, "T_Sp": 0.0, "phi0": math.pi + 0.1, "m_p": 0.25, "l": 0.31,
          "k_fwc": 25.5, "F_Kc": 7.25, "v0": 0.4, "T_i": 4e-4, "dIdt_max": 2000.0}


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    out = tmp_path_factory.mktemp("export")
    paths = export_all(PARAMS, out, source="P.json")
    return out, paths


def fmu_members(path) -> dict[str, bytes]:
    with zipfile.ZipFile(path) as fmu:
        return {name: fmu.read(name) for name in fmu.namelist()}


def expected_starts(name: str) -> dict[str, float]:
    """Every parameter of component `name`: from PARAMS, else the table's default."""
    return {p: PARAMS.get(p, float(v.start)) for p, v in COMPONENTS[name].parameters.items()}


# -- the files


def test_writes_three_fmus_the_ssv_and_the_modelica_text(exported):
    out, paths = exported
    assert [p.relative_to(out).as_posix() for p in paths] == [
        "CurrentLoop.fmu", "Cart.fmu", "Pendulum.fmu", "parameters.ssv", "modifiers.mo", "set_parameters.m",
        "parameters.mat", "fmi3/CurrentLoop.fmu", "fmi3/Cart.fmu", "fmi3/Pendulum.fmu", "rig.ssp", "rig-flat.ssp"]
    assert all(p.is_file() for p in paths)
    assert not list(out.glob(".*.part"))


def test_the_rig_ssps_state_every_exported_value_with_and_without_system_connectors(exported):
    """rig.ssp and rig-flat.ssp (pendfmu/export/rig.py): every parameter of every component
    as the FMUs declare it; the flat one without the system's own connectors, same wiring."""
    from pendfmu.ssp import read_ssp

    out, _ = exported
    full, flat = read_ssp(out / "rig.ssp"), read_ssp(out / "rig-flat.ssp")
    for system in (full, flat):
        assert {name: {p: v.value for p, v in values.items()} for name, values in system.parameters.items()} \
            == {name: expected_starts(name) for name in COMPONENTS}
    assert [c.name for c in full.connectors][:1] == ["I_c"] and flat.connectors == ()
    assert flat.component_connections() == full.component_connections()


@pytest.mark.parametrize("name", sorted(COMPONENTS))
def test_exported_fmu_passes_fmpy_validation(exported, name):
    assert validate_fmu(str(exported[0] / f"{name}.fmu")) == []


@pytest.mark.parametrize("name", sorted(COMPONENTS))
def test_the_fmi3_twin_declares_the_same_start_values(exported, name):
    """fmi3/<Name>.fmu: valid FMI 3.0, every parameter's start value the FMI 2.0 copy's."""
    fmi2, fmi3 = (read_model_description(str(exported[0] / sub / f"{name}.fmu")) for sub in ("", "fmi3"))
    assert fmi3.fmiVersion == "3.0" and validate_fmu(str(exported[0] / "fmi3" / f"{name}.fmu")) == []
    starts = [{v.name: float(v.start) for v in d.modelVariables if v.causality == "parameter"} for d in (fmi2, fmi3)]
    assert starts[0] == starts[1] and starts[0] == expected_starts(name)


@pytest.mark.parametrize("name", sorted(COMPONENTS))
def test_binaries_and_sources_are_byte_identical(exported, name):
    original, copy = fmu_members(ensure_fmu(name)), fmu_members(exported[0] / f"{name}.fmu")
    assert set(copy) == set(original) | {START_FILE}
    kept = [m for m in original if m != "modelDescription.xml"]
    assert any(m.startswith("binaries/") for m in kept) and any(m.startswith("sources/") for m in kept)
    for member in kept:
        assert copy[member] == original[member], member


@pytest.mark.parametrize("name", sorted(COMPONENTS))
def test_model_description_differs_only_in_guid_provenance_and_given_starts(exported, name):
    original = etree.fromstring(fmu_members(ensure_fmu(name))["modelDescription.xml"])
    copy = etree.fromstring(fmu_members(exported[0] / f"{name}.fmu")["modelDescription.xml"])
    assert copy.get("guid") != original.get("guid")
    assert copy.get("description").startswith(original.get("description"))
    assert "parameterized by pendfmu export from P.json" in copy.get("description")
    assert "export" in copy.get("generationTool")
    given = set(PARAMS) & set(COMPONENTS[name].parameters)
    changed = set()
    for a, b in zip(original.iter(), copy.iter(), strict=True):
        assert a.tag == b.tag and (a.text or "").strip() == (b.text or "").strip()
        diff = {k for k in set(a.attrib) | set(b.attrib) if a.get(k) != b.get(k)}
        if a.tag == "fmiModelDescription":
            assert diff == {"guid", "description", "generationTool", "generationDateAndTime"}
        elif diff:
            assert diff == {"start"} and a.getparent().get("causality") == "parameter"
            changed.add(a.getparent().get("name"))
    assert changed == {p for p in given if PARAMS[p] != COMPONENTS[name].parameters[p].start}


def test_guid_is_fresh_for_every_export(exported, tmp_path):
    again = export_all(PARAMS, tmp_path, components=["Cart"])[0]
    guids = {read_model_description(str(p)).guid for p in (ensure_fmu("Cart"), exported[0] / "Cart.fmu", again)}
    assert len(guids) == 3
    assert all(g.startswith("{") and g.endswith("}") and len(g) == 38 for g in guids)


@pytest.mark.parametrize("name", sorted(COMPONENTS))
def test_start_values_read_back_from_xml_and_start_file(exported, name):
    path = exported[0] / f"{name}.fmu"
    md = read_model_description(str(path))
    declared = {v.name: float(v.start) for v in md.modelVariables if v.causality == "parameter"}
    assert declared == expected_starts(name)
    lines = fmu_members(path)[START_FILE].decode().splitlines()
    assert lines[0] == f"guid {md.guid}"
    by_vr = {int(vr): float(value) for vr, value in (ln.split() for ln in lines[1:] if not ln.startswith("#"))}
    assert by_vr == {v.valueReference: declared[v.name] for v in md.modelVariables if v.causality == "parameter"}
    assert max(map(len, lines)) < 200  # the binary reads lines of up to 255 characters


# -- behaviour


def test_pendulum_swings_with_the_exported_parameters_without_start_values(exported):
    """Undamped (k_fwp = T_Kp = T_Sp = 0), released 0.1 rad from hanging: the period is
    the exact one of a physical pendulum, 4 sqrt(J/(m g l)) K(sin^2(0.05))."""
    result = simulate_fmu(str(exported[0] / "Pendulum.fmu"), stop_time=12.0, output_interval=1e-3,
                          output=["phi", "w"])
    theta = result["phi"] - math.pi
    assert theta[0] == pytest.approx(0.1, abs=1e-15)
    assert np.max(np.abs(theta)) == pytest.approx(0.1, rel=1e-6)  # no damping: amplitude kept
    up = np.flatnonzero((theta[:-1] < 0) & (theta[1:] >= 0))
    t = result["time"]
    crossings = t[up] - theta[up] * (t[up + 1] - t[up]) / (theta[up + 1] - theta[up])
    period = np.mean(np.diff(crossings))
    m, l, g = PARAMS["m_p"], PARAMS["l"], 9.81
    J = 4 / 3 * m * l ** 2
    exact = 4 * math.sqrt(J / (m * g * l)) * ellipk(math.sin(0.05) ** 2)
    assert len(crossings) >= 8
    assert period == pytest.approx(exact, rel=1e-8)  # measured 6e-11


@pytest.mark.parametrize("name, output", [("Pendulum", ["phi", "w", "T_F"]), ("Cart", ["x", "v", "mode"])])
def test_exported_fmu_equals_original_given_the_start_values(exported, name, output):
    """Same binary, same values: bit-identical results (the cart brakes from v0 = 0.4)."""
    starts = {p: v for p, v in PARAMS.items() if p in COMPONENTS[name].parameters}
    copy = simulate_fmu(str(exported[0] / f"{name}.fmu"), stop_time=1.0, output_interval=1e-3, output=output)
    original = simulate_fmu(str(ensure_fmu(name)), stop_time=1.0, output_interval=1e-3, output=output,
                            start_values=starts)
    for column in output:
        np.testing.assert_array_equal(copy[column], original[column], err_msg=column)
    default = simulate_fmu(str(ensure_fmu(name)), stop_time=1.0, output_interval=1e-3, output=output)
    assert not np.array_equal(copy[output[0]], default[output[0]])  # the export changed something


def test_model_exchange_uses_the_exported_values_too(exported):
    result = simulate_fmu(str(exported[0] / "Cart.fmu"), fmi_type="ModelExchange", stop_time=0.2,
                          output_interval=1e-3, output=["v"])
    assert result["v"][0] == 0.4
    assert result["v"][-1] == 0.0  # braked to a stop by k_fwc and F_Kc


def test_reset_keeps_the_exported_start_values(exported):
    with ComponentFMU("Pendulum", {"k_fwp": 0.5}, fmu=exported[0] / "Pendulum.fmu") as pendulum:
        assert pendulum.get("k_fwp", "phi") == [0.5, PARAMS["phi0"]]
        slave = pendulum.slave
        slave.reset()
        slave.setupExperiment(startTime=0.0)
        slave.enterInitializationMode()
        slave.exitInitializationMode()
        assert pendulum.get("k_fwp", "m_p", "phi", "T_Sp") == [0.0, 0.25, PARAMS["phi0"], 0.0]


def test_m_p_zero_exports_the_cart_and_leaves_out_the_pendulum(tmp_path):
    plan = plan_export({"m_p": 0.0, "k_fwc": 20.0})
    assert list(plan.components) == ["Cart"]
    assert "Pendulum" in plan.skipped and "(0.0, inf)" in plan.skipped["Pendulum"]
    paths = export_all({"m_p": 0.0, "k_fwc": 20.0, "v0": 0.3}, tmp_path)
    assert [p.name for p in paths] == ["Cart.fmu", "parameters.ssv", "modifiers.mo", "set_parameters.m", "parameters.mat",
                                       "Cart.fmu"]  # the last: fmi3/Cart.fmu
    result = simulate_fmu(str(paths[0]), stop_time=0.1, output_interval=1e-3, output=["v"])
    assert result["v"][0] == 0.3 and result["v"][-1] == 0.0
    assert "IdentifiedCartStartStop" in (tmp_path / "modifiers.mo").read_text()


def test_a_component_asked_for_refuses_a_value_outside_its_range(tmp_path):
    with pytest.raises(ParameterFileError, match=r"Pendulum\.m_p = 0 is outside its physical range \(0\.0, inf\) \[kg\]"):
        export_all({"m_p": 0.0}, tmp_path, components=["Cart", "Pendulum"])
    assert not list(tmp_path.iterdir())  # checked before anything is written


# -- tampered start files


def instantiate(fmu: Path, tmp_path: Path) -> list[str]:
    """Instantiate `fmu` in Co-Simulation; return what it logged, or fail if it worked."""
    directory = tmp_path / f"unzipped-{fmu.stem}"
    extract(str(fmu), str(directory))
    md = read_model_description(str(fmu))
    messages: list[str] = []
    callbacks = fmi2CallbackFunctions()
    callbacks.logger = fmi2CallbackLoggerTYPE(lambda env, name, status, category, message:
                                              messages.append(message.decode()))
    callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
    callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
    addLoggerProxy(byref(callbacks))
    slave = FMU2Slave(guid=md.guid, unzipDirectory=str(directory), modelIdentifier=md.coSimulation.modelIdentifier,
                      instanceName="tampered")
    try:
        with pytest.raises(Exception, match="Failed to instantiate"):
            slave.instantiate(callbacks=callbacks)
    finally:
        slave.freeLibrary()
    return messages


def tampered(exported_fmu: Path, tmp_path: Path, edit) -> Path:
    """A copy of `exported_fmu` whose start file is replaced by edit(lines)."""
    target = tmp_path / exported_fmu.name
    members = fmu_members(exported_fmu)
    lines = members[START_FILE].decode().splitlines()
    members[START_FILE] = ("\n".join(edit(lines)) + "\n").encode()
    with zipfile.ZipFile(target, "w") as fmu:
        for name, data in members.items():
            fmu.writestr(name, data)
    return target


# The appended line's number and the input's value reference follow the Pendulum's variable
# table (they grow when parameters are added), so they are read from it, not written here.
INPUT_A = COMPONENTS["Pendulum"].value_reference("a")


@pytest.mark.parametrize("edit, message", [
    (lambda lines: ["guid {00000000-0000-4000-8000-000000000000}", *lines[1:]], "does not match this binary's"),
    (lambda lines: [*lines, "0 0.0"], "line {appended}: m_p = 0 is outside its physical range"),
    (lambda lines: [*lines, "99 1.0"], "line {appended}: expected '<parameter value reference> <finite value>'"),
    (lambda lines: [*lines, f"{INPUT_A} 1.0"], "line {appended}: expected '<parameter value reference> <finite value>'"),
    (lambda lines: [*lines, "4 nan"], "line {appended}: expected"),
    (lambda lines: [], "does not match this binary's"),
], ids=["guid-mismatch", "out-of-range", "unknown-vr", "not-a-parameter", "not-finite", "empty"])
def test_tampered_start_file_fails_instantiation_with_a_message(exported, tmp_path, edit, message):
    appended = len(fmu_members(exported[0] / "Pendulum.fmu")[START_FILE].decode().splitlines()) + 1
    messages = instantiate(tampered(exported[0] / "Pendulum.fmu", tmp_path, edit), tmp_path)
    message = message.format(appended=appended)
    assert any(message in m for m in messages), messages


def test_untampered_copy_instantiates(exported, tmp_path):
    copy = tampered(exported[0] / "Pendulum.fmu", tmp_path, lambda lines: lines)
    with ComponentFMU("Pendulum", fmu=copy) as pendulum:
        assert pendulum.get("phi") == [PARAMS["phi0"]]


# -- SSV


def test_ssv_validates_and_round_trips(exported):
    path = exported[0] / "parameters.ssv"
    schema = etree.XMLSchema(etree.parse(str(schema_dir() / "SystemStructureParameterValues.xsd")))
    assert schema.validate(etree.parse(str(path))), schema.error_log
    parameter_set = read_ssv(path)
    assert parameter_set.name == "P"
    expected = {f"{c}.{p}": v for c in COMPONENTS for p, v in expected_starts(c).items()}
    assert {k: v.value for k, v in parameter_set.values.items()} == expected
    assert parameter_set.values["Cart.k_fwc"].unit == "N.s/m"
    assert parameter_set.units["N.s/m"].dimension() == (1, 0, -1, 0, 0, 0, 0, 0)


# -- Modelica


def load(path: Path, model: str):
    return rumoca.Session(roots=[str(MODELICA)]).load(str(path), model=f"PendfmuExport.{model}")


def parameter_values(model) -> dict[str, float]:
    return {p.name: p.value for p in model.parameters}


def test_modelica_declarations_carry_every_value(exported):
    values = parameter_values(load(exported[0] / "modifiers.mo", "IdentifiedComponents"))
    instances = {"CurrentLoop": "currentLoop", "Cart": "cart", "Pendulum": "pendulum"}
    for component, instance in instances.items():
        for name, value in expected_starts(component).items():
            if name != "solver_step":
                assert values[f"{instance}.{name}"] == value, f"{instance}.{name}"


def test_modelica_rig_simulates_as_the_rig_with_the_same_parameters(exported):
    """IdentifiedRig (modifiers) and Examples.Rig with the values as overrides give the same
    result: the text means what the parameters say, bound parameters (cart.m_p) included."""
    model = load(exported[0] / "modifiers.mo", "IdentifiedRig")
    values = parameter_values(model)
    assert (values["m_p"], values["l"], values["cart.k_fwc"], values["pendulum.phi0"]) == (
        PARAMS["m_p"], PARAMS["l"], PARAMS["k_fwc"], PARAMS["phi0"])
    result = model.simulate(t=(0.0, 0.1), dt=1e-3)
    overrides = {f"{i}.{p}": v for c, i in (("CurrentLoop", "currentLoop"), ("Cart", "cart"), ("Pendulum", "pendulum"))
                 for p, v in PARAMS.items() if p in COMPONENTS[c].parameters and p not in ("m_p", "l")}
    reference = rumoca.Session(roots=[str(MODELICA)]).load(
        str(MODELICA / "PendulumID" / "package.mo"), model="PendulumID.Examples.Rig").simulate(
        t=(0.0, 0.1), dt=1e-3, params={"m_p": PARAMS["m_p"], "l": PARAMS["l"], **overrides})
    assert result["pendulum.phi"][0] == PARAMS["phi0"] and result["cart.v"][0] == PARAMS["v0"]
    for column in ("cart.x", "cart.v", "pendulum.phi", "currentLoop.I"):
        np.testing.assert_allclose(result[column], reference[column], rtol=0, atol=1e-12, err_msg=column)


def test_modelica_rig_takes_a_back_drivable_eta(tmp_path):
    """eta is structural in Examples.Rig (it picks the coupling): set at the Rig's level."""
    export_all({"eta": 0.7, "k_fwc": 20.0}, tmp_path)
    model = load(tmp_path / "modifiers.mo", "IdentifiedRig")
    assert parameter_values(model)["eta"] == 0.7
    result = model.simulate(t=(0.0, 0.1), dt=1e-3)
    assert result.time[-1] == pytest.approx(0.1)


def test_modelica_rig_level_names_exist_in_the_library():
    """The text lifts eta, m_p, l to Examples.Rig and names its instances: check they exist."""
    model = rumoca.Session(roots=[str(MODELICA)]).load(str(MODELICA / "PendulumID" / "package.mo"),
                                                       model="PendulumID.Examples.Rig")
    names = {p.name for p in model.parameters}
    assert {"eta", "m_p", "l", "currentLoop.T_i", "cart.k_fwc", "pendulum.k_fwp"} <= names


def test_modelica_cart_without_pendulum_simulates(tmp_path):
    export_all({"m_p": 0.0, "F_Sc": 10.0}, tmp_path)
    model = load(tmp_path / "modifiers.mo", "IdentifiedCartStartStop")
    assert (parameter_values(model)["cart.m_p"], parameter_values(model)["cart.F_Sc"]) == (0.0, 10.0)
    assert model.simulate(t=(0.0, 0.1), dt=1e-3)["cart.x"][-1] > 0


# -- the command line


def write_params(path: Path, parameters: dict) -> Path:
    path.write_text(json.dumps({"parameters": parameters}))
    return path


def test_cli_writes_the_files(tmp_path, capsys):
    params = write_params(tmp_path / "P.json", {"k_fwc": 25.0, "T_Kp": 1e-3})
    out = tmp_path / "out"
    assert main(["export", "--params", str(params), "--out", str(out)]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["Cart.fmu", "Pendulum.fmu", "fmi3", "modifiers.mo",
                                                     "parameters.mat", "parameters.ssv", "set_parameters.m"]
    assert sorted(p.name for p in (out / "fmi3").iterdir()) == ["Cart.fmu", "Pendulum.fmu"]
    assert capsys.readouterr().out.count("wrote ") == 8
    assert "P.json" in read_model_description(str(out / "Cart.fmu")).description


def test_cli_component_option_selects_fmus(tmp_path, capsys):
    params = write_params(tmp_path / "P.json", {"k_fwc": 25.0})
    assert main(["export", "--params", str(params), "--out", str(tmp_path / "o"), "--component", "CurrentLoop",
                 "--component", "Pendulum"]) == 0
    assert sorted(p.name for p in (tmp_path / "o").glob("*.fmu")) == ["CurrentLoop.fmu", "Pendulum.fmu"]
    assert "k_fwc is not exported" in capsys.readouterr().err


@pytest.mark.parametrize("parameters, expected", [
    ({"k_fwcc": 25.0}, "unknown parameter 'k_fwcc'"),
    ({"T_Kp": -1.0}, "T_Kp = -1 is outside its physical range"),
    ({"eta": "high"}, "eta = 'high' is not a number"),
])
def test_cli_bad_parameter_is_exit_2_in_one_line(tmp_path, capsys, parameters, expected):
    params = write_params(tmp_path / "P.json", parameters)
    code = main(["export", "--params", str(params), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2
    assert expected in err and str(params) in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1
    assert not (tmp_path / "out").exists()


def test_cli_refused_shared_value_is_exit_2_naming_component_parameter_range(tmp_path, capsys):
    params = write_params(tmp_path / "P.json", {"m_p": 0.0})
    assert main(["export", "--params", str(params), "--out", str(tmp_path / "o"), "--component", "Pendulum"]) == 2
    err = capsys.readouterr().err.strip()
    assert "Pendulum.m_p = 0 is outside its physical range (0.0, inf) [kg]" in err and len(err.splitlines()) == 1


def test_cli_out_that_is_a_file_is_exit_2(tmp_path, capsys):
    params = write_params(tmp_path / "P.json", {"k_fwc": 25.0})
    (tmp_path / "taken").write_text("")
    assert main(["export", "--params", str(params), "--out", str(tmp_path / "taken")]) == 2
    assert "exists and is not a directory" in capsys.readouterr().err
