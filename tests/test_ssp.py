"""SSP 1.0 files of the rig: SSD, SSV and SSP archive round trips, schema validity, and
clear errors (file, line, element) for files that are wrong."""

from __future__ import annotations

import shutil
import zipfile
from pathlib import Path

import pytest
from fmpy import read_model_description
from lxml import etree

from pendfmu.export.fmu import START_FILE
from pendfmu.fmubuild import ensure_fmu
from pendfmu.ssp import (
    Connection, ParameterSet, ParameterValue, SspError, Unit, read_ssd, read_ssp, read_ssv,
    rig_system, schema_dir, write_ssd, write_ssp, write_ssv,
)

RIG = ("CurrentLoop", "Cart", "Pendulum")


@pytest.fixture(scope="module")
def fmu_dir() -> Path:
    """The built component FMUs (built now if missing or stale)."""
    paths = {name: ensure_fmu(name) for name in RIG}
    return paths["Cart"].parent


def assert_schema_valid(path: Path, schema_file: str) -> None:
    """Validate with the schema directly, independently of pendfmu's reader."""
    schema = etree.XMLSchema(etree.parse(str(schema_dir() / schema_file)))
    assert schema.validate(etree.parse(str(path))), schema.error_log


# ------------------------------------------------------------------------- the rig

def test_self_locking_rig_has_two_connections(fmu_dir):
    system = rig_system(0.4, fmu_dir)
    assert [str(c) for c in system.component_connections()] == ["CurrentLoop.I_mean -> Cart.I", "Cart.a -> Pendulum.a"]


def test_back_drivable_rig_has_five_connections(fmu_dir):
    system = rig_system(0.7, fmu_dir)
    assert len(system.component_connections()) == 5
    assert Connection.between("Pendulum.alpha", "Cart.alpha") in system.connections
    assert system.value("Cart", "eta") == 0.7


def test_connectors_come_from_the_fmu(fmu_dir):
    cart = rig_system(0.4, fmu_dir).components["Cart"]
    assert cart.source == "resources/Cart.fmu"
    assert {c.name: c.kind for c in cart.connectors}["phi"] == "input"
    assert cart.connector("a").unit == "m/s2" and cart.connector("F_A").kind == "output"
    assert cart.connector("F_F") is None  # locals are not connectors


@pytest.mark.parametrize("given", [{"m_p": 0.25, "l": 0.4}, {"Cart.m_p": 0.25, "Pendulum.l": 0.4}])
def test_shared_parameters_go_to_cart_and_pendulum(fmu_dir, given):
    system = rig_system(0.4, fmu_dir, given)
    for component in ("Cart", "Pendulum"):
        assert system.value(component, "m_p") == 0.25
        assert system.value(component, "l") == 0.4
    assert system.parameters["Cart"]["m_p"].unit == "kg"


def test_parameters_default_to_fmu_start_values(fmu_dir):
    system = rig_system(0.4, fmu_dir, {"Cart.k_fwc": 25.0})
    assert system.value("Cart", "k_fwc") == 25.0
    assert system.value("CurrentLoop", "T_i") == 0.3e-3
    assert system.value("Pendulum", "g") == 9.81


@pytest.mark.parametrize("given, match", [
    ({"Cart.m_p": 0.2, "Pendulum.m_p": 0.3}, "contradicts"),
    ({"eta": 0.6}, "contradicts"),
    ({"Cart.nope": 1.0}, "no parameter 'nope'"),
    ({"Wagon.m_c": 1.0}, "no rig component 'Wagon'"),
    ({"m_p": 0.0}, r"Pendulum\.m_p = 0 is outside its physical range \(0\.0, inf\) \[kg\]"),
])
def test_bad_rig_parameters_are_refused(fmu_dir, given, match):
    with pytest.raises(ValueError, match=match):
        rig_system(0.4, fmu_dir, given)


# ------------------------------------------------------------------------- SSD

def test_ssd_round_trip(fmu_dir, tmp_path):
    system = rig_system(0.7, fmu_dir, {"m_p": 0.25, "T_i": 4e-4}, stop_time=2.5, step_size=1e-3)
    ssd = tmp_path / "SystemStructure.ssd"
    written = write_ssd(system, ssd)
    assert written[0] == ssd
    assert sorted(p.relative_to(tmp_path).as_posix() for p in written[1:]) == [
        "resources/Cart.ssv", "resources/CurrentLoop.ssv", "resources/Pendulum.ssv"]
    assert_schema_valid(ssd, "SystemStructureDescription.xsd")
    for ssv in written[1:]:
        assert_schema_valid(ssv, "SystemStructureParameterValues.xsd")
    back = read_ssd(ssd)
    assert back == system
    assert back.experiment.step_size == 1e-3 and back.experiment.stop_time == 2.5
    assert back.components["Cart"].fmu is None  # FMUs were not copied next to this SSD


def test_ssd_as_written_before_system_connectors_still_reads(fmu_dir, tmp_path):
    """A file of the earlier layout (no system connectors, no annotation on the system) reads
    as the same rig without its own connectors."""
    system = rig_system(0.4, fmu_dir, {"m_c": 1.5})
    written = tmp_path / "SystemStructure.ssd"
    write_ssd(system, written)
    root = etree.parse(str(written)).getroot()
    ssd = "{http://ssp-standard.org/SSP1/SystemStructureDescription}"
    system_el = root.find(f"{ssd}System")
    for tag in ("Connectors", "Annotations"):
        system_el.remove(system_el.find(f"{ssd}{tag}"))
    for connection in list(system_el.iterfind(f"{ssd}Connections/{ssd}Connection")):
        if connection.get("startElement") is None or connection.get("endElement") is None:
            connection.getparent().remove(connection)
    old = tmp_path / "old.ssd"
    old.write_bytes(etree.tostring(root))
    back = read_ssd(old)
    assert back.connectors == () and back.connections == system.component_connections()
    assert back.parameters == system.parameters and back.components == system.components


def test_ssd_binds_one_named_set_per_component(fmu_dir, tmp_path):
    ssd = tmp_path / "SystemStructure.ssd"
    write_ssd(rig_system(0.4, fmu_dir, parameter_set="bench"), ssd)
    ns = {"ssd": "http://ssp-standard.org/SSP1/SystemStructureDescription"}
    root = etree.parse(str(ssd)).getroot()
    bindings = root.findall(".//ssd:Component/ssd:ParameterBindings/ssd:ParameterBinding", ns)
    assert [b.get("source") for b in bindings] == [f"resources/{c}.ssv" for c in RIG]
    assert {read_ssv(tmp_path / b.get("source")).name for b in bindings} == {"bench"}


# ------------------------------------------------------------------------- SSV

def test_ssv_round_trip(tmp_path):
    units = {"kg": Unit("kg", kg=1), "degC": Unit("degC", K=1, offset=273.15)}
    parameter_set = ParameterSet("bench", {
        "m_p": ParameterValue(0.1 + 0.2, "kg"),
        "T0": ParameterValue(-1e-300, "degC"),
        "limit": ParameterValue(float("inf")),
        "count": ParameterValue(3, type="Integer"),
        "enabled": ParameterValue(True, type="Boolean"),
        "label": ParameterValue("rig <A> & \"B\"", type="String"),
    }, units)
    path = write_ssv(parameter_set, tmp_path / "bench.ssv")
    assert_schema_valid(path, "SystemStructureParameterValues.xsd")
    assert read_ssv(path) == parameter_set


def test_ssv_with_undefined_unit_is_not_written(tmp_path):
    with pytest.raises(SspError, match="unit 'kg'"):
        write_ssv(ParameterSet("s", {"m": ParameterValue(1.0, "kg")}), tmp_path / "s.ssv")
    assert not (tmp_path / "s.ssv").exists()


def test_schema_invalid_ssv_names_file_and_line(tmp_path):
    path = write_ssv(ParameterSet("s", {"m": ParameterValue(1.0)}), tmp_path / "s.ssv")
    path.write_text(path.read_text().replace('value="1.0"', 'value="heavy"'))
    with pytest.raises(SspError) as error:
        read_ssv(path)
    assert error.value.file == str(path) and error.value.line == _line_of(path, 'value="heavy"')
    assert "ssv:Real" in str(error.value) and "heavy" in str(error.value)


# ------------------------------------------------------------------------- SSP archive

def test_ssp_round_trip_with_intact_binaries_and_the_systems_start_values(fmu_dir, tmp_path):
    """The packed FMUs are pendfmu's builds with the system's values as start values (so
    tools that ignore the SSV files still use them: archive.py); every other member, the
    binaries included, is the built FMU's, byte for byte."""
    system = rig_system(0.7, fmu_dir, {"l": 0.35})
    archive = write_ssp(system, tmp_path / "rig.ssp")
    with zipfile.ZipFile(archive) as z:
        names = set(z.namelist())
        assert names == {"SystemStructure.ssd"} | {f"resources/{c}.fmu" for c in RIG} \
            | {f"resources/{c}.ssv" for c in RIG}
        unpacked = tmp_path / "unzipped"
        z.extractall(unpacked)
    for name in RIG:
        packed = unpacked / "resources" / f"{name}.fmu"
        with zipfile.ZipFile(packed) as copy, zipfile.ZipFile(fmu_dir / f"{name}.fmu") as built:
            kept = set(built.namelist()) - {"modelDescription.xml"}
            assert set(copy.namelist()) == kept | {"modelDescription.xml", START_FILE}
            for member in kept:
                assert copy.read(member) == built.read(member), member
        md = read_model_description(str(packed))
        assert md.modelName == name
        starts = {v.name: float(v.start) for v in md.modelVariables if v.causality == "parameter"}
        assert starts == {n: v.value for n, v in system.parameters[name].items()}
    back = read_ssp(archive, tmp_path / "extracted")
    assert back == system
    assert back.components["Pendulum"].fmu == tmp_path / "extracted" / "resources" / "Pendulum.fmu"
    assert back.value("Cart", "l") == back.value("Pendulum", "l") == 0.35


def test_ssp_needs_its_fmus(fmu_dir, tmp_path):
    archive = write_ssp(rig_system(0.4, fmu_dir), tmp_path / "rig.ssp")
    stripped = tmp_path / "stripped.ssp"
    with zipfile.ZipFile(archive) as src, zipfile.ZipFile(stripped, "w") as dst:
        for item in src.infolist():
            if item.filename != "resources/Cart.fmu":
                dst.writestr(item, src.read(item))
    with pytest.raises(SspError, match="resources/Cart.fmu") as error:
        read_ssp(stripped, tmp_path / "x")
    assert str(error.value).startswith(f"{stripped}!SystemStructure.ssd:")


def test_not_an_archive(tmp_path):
    bogus = tmp_path / "bogus.ssp"
    bogus.write_text("hello")
    with pytest.raises(SspError, match="bogus.ssp"):
        read_ssp(bogus, tmp_path / "x")


# ------------------------------------------------------------------------- invalid SSDs

@pytest.fixture
def written_ssd(fmu_dir, tmp_path) -> Path:
    ssd = tmp_path / "SystemStructure.ssd"
    write_ssd(rig_system(0.4, fmu_dir), ssd)
    return ssd


def _line_of(path: Path, text: str) -> int:
    return next(i for i, line in enumerate(path.read_text().splitlines(), 1) if text in line)


def test_connection_to_unknown_connector_names_file_line_element(written_ssd):
    text = written_ssd.read_text()
    written_ssd.write_text(text.replace('endElement="Pendulum" endConnector="a"',
                                        'endElement="Pendulum" endConnector="acc"'))
    with pytest.raises(SspError) as error:
        read_ssd(written_ssd)
    message = str(error.value)
    line = _line_of(written_ssd, 'endConnector="acc"')
    assert message.startswith(f"{written_ssd}:{line}: <ssd:Connection")
    assert "has no connector 'acc'" in message


def test_connection_to_unknown_component(written_ssd):
    written_ssd.write_text(written_ssd.read_text().replace('startElement="CurrentLoop"', 'startElement="Motor"'))
    with pytest.raises(SspError, match="no component 'Motor'") as error:
        read_ssd(written_ssd)
    assert error.value.line == _line_of(written_ssd, 'startElement="Motor"')


def test_connection_from_input_to_input(written_ssd):
    written_ssd.write_text(written_ssd.read_text().replace('startConnector="I_mean" endElement="Cart"',
                                                           'startConnector="I_c" endElement="Cart"'))
    with pytest.raises(SspError, match="from a connector of kind input to one of kind input"):
        read_ssd(written_ssd)


def test_connection_from_an_unknown_system_connector(written_ssd):
    written_ssd.write_text(written_ssd.read_text().replace('startConnector="I_c" endElement="CurrentLoop"',
                                                           'startConnector="I_cmd" endElement="CurrentLoop"'))
    with pytest.raises(SspError, match="the system has no connector 'I_cmd' \\(its connectors: I_c, I, x") as error:
        read_ssd(written_ssd)
    assert error.value.line == _line_of(written_ssd, 'startConnector="I_cmd"')


def test_system_output_fed_by_a_component_input(written_ssd):
    written_ssd.write_text(written_ssd.read_text().replace('startElement="Cart" startConnector="x" endConnector="x"',
                                                           'startElement="Cart" startConnector="I" endConnector="x"'))
    with pytest.raises(SspError, match="a component output a system output") as error:
        read_ssd(written_ssd)
    assert error.value.line == _line_of(written_ssd, 'startConnector="I" endConnector="x"')


def test_system_connector_must_be_an_input_or_output(written_ssd):
    text = written_ssd.read_text()
    assert text.index('<ssd:Connector name="I_c" kind="input">') < text.index("<ssd:Elements>")  # the system's
    written_ssd.write_text(text.replace('<ssd:Connector name="I_c" kind="input">',
                                        '<ssd:Connector name="I_c" kind="parameter">', 1))
    with pytest.raises(SspError, match="a system connector is an input or an output") as error:
        read_ssd(written_ssd)
    assert error.value.line == _line_of(written_ssd, 'name="I_c" kind="parameter"')


def test_schema_invalid_ssd_names_file_line_element(written_ssd):
    written_ssd.write_text(written_ssd.read_text().replace('name="x0" kind="parameter"', 'name="x0" kind="sideways"'))
    with pytest.raises(SspError) as error:
        read_ssd(written_ssd)
    assert error.value.file == str(written_ssd)
    assert error.value.line == _line_of(written_ssd, 'kind="sideways"')
    assert error.value.element == '<ssd:Connector name="x0" kind="sideways">'
    assert "SystemStructureDescription.xsd" in str(error.value)


def test_malformed_ssd(written_ssd):
    written_ssd.write_text(written_ssd.read_text().replace("</ssd:Connections>", ""))
    with pytest.raises(SspError, match="not well-formed") as error:
        read_ssd(written_ssd)
    assert error.value.file == str(written_ssd) and error.value.line


def test_parameter_for_unknown_variable_is_located_in_the_ssv(written_ssd):
    ssv = written_ssd.parent / "resources" / "Cart.ssv"
    ssv.write_text(ssv.read_text().replace('name="k_fwc"', 'name="k_fw"'))
    with pytest.raises(SspError, match="no parameter 'k_fw'") as error:
        read_ssd(written_ssd)
    assert error.value.file == str(ssv) and error.value.line == _line_of(ssv, 'name="k_fw"')


def test_connector_that_contradicts_its_fmu(fmu_dir, written_ssd):
    resources = written_ssd.parent / "resources"
    for name in RIG:
        shutil.copyfile(fmu_dir / f"{name}.fmu", resources / f"{name}.fmu")
    assert read_ssd(written_ssd, require_fmus=True).components["Cart"].fmu == resources / "Cart.fmu"
    written_ssd.write_text(written_ssd.read_text().replace('name="F_A" kind="output"', 'name="F_A" kind="input"'))
    with pytest.raises(SspError, match="causality in Cart.fmu is output") as error:
        read_ssd(written_ssd)
    assert error.value.line == _line_of(written_ssd, 'name="F_A"')


def test_invalid_system_is_not_written(fmu_dir, tmp_path):
    system = rig_system(0.4, fmu_dir)
    system.connections.append(Connection.between("Pendulum.phi", "Cart.theta"))
    ssd = tmp_path / "SystemStructure.ssd"
    with pytest.raises(SspError, match=r"Pendulum.phi -> Cart.theta.*has no connector 'theta'"):
        write_ssd(system, ssd)
    assert not ssd.exists() and not (tmp_path / "resources").exists()


def test_input_driven_twice_is_refused(fmu_dir, tmp_path):
    system = rig_system(0.4, fmu_dir)
    system.connections.append(Connection.between("CurrentLoop.I", "Cart.I"))
    with pytest.raises(SspError, match="already driven by CurrentLoop.I_mean -> Cart.I"):
        write_ssp(system, tmp_path / "rig.ssp")
    assert not (tmp_path / "rig.ssp").exists()
