"""`pendfmu export` for Simulink: set_parameters.m and parameters.mat.

The .mat file is read back with scipy and with GNU Octave; the MATLAB function is run by
Octave against small stand-ins of Simulink's set_param, get_param, gcs and find_system that
hold a few blocks and record every set_param call. What is asserted comes from the component
table and the parameters given (not from the export's own output), and every value text
must parse back to the same double.
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import zipfile
from pathlib import Path

import pytest
from fmpy import read_model_description
from scipy.io import loadmat

from pendfmu.cli import main
from pendfmu.components import COMPONENTS
from pendfmu.export import export_all
from pendfmu.export.simulink import DEFAULT_ORIGIN, BlockValues, write_simulink_files
from pendfmu.fmubuild import ensure_fmu

PARAMS = {"k_fwc": 25.5, "m_p": 0.1 + 0.2, "T_i": 4e-4, "phi0": 3.141592653589793 + 0.1, "l": 0.31}

OCTAVE = shutil.which("octave-cli") or shutil.which("octave")
needs_octave = pytest.mark.skipif(OCTAVE is None or shutil.which("unzip") is None,
                                  reason="GNU Octave or unzip is not installed (Debian packages octave, unzip; "
                                         "`make tools` installs them): the exported MATLAB script is not run")

# Stand-ins for Simulink: PENDFMU_MOCK.blocks is a cell of structs (path, params); a block's
# dialog parameters are its params but BlockType; set_param prints each change it makes.
MOCKS = {
    "mock_block.m": """function [params, index] = mock_block(blk)
global PENDFMU_MOCK
for index = 1:numel(PENDFMU_MOCK.blocks)
    if strcmp(PENDFMU_MOCK.blocks{index}.path, blk)
        params = PENDFMU_MOCK.blocks{index}.params;
        return
    end
end
error('Simulink:Commands:InvSimulinkObjectName', 'Invalid Simulink object name: ''%s''.', blk);
end
""",
    "get_param.m": """function value = get_param(blk, name)
params = mock_block(blk);
if strcmp(name, 'DialogParameters')
    value = struct();
    names = fieldnames(params);
    for k = 1:numel(names)
        if ~strcmp(names{k}, 'BlockType'), value.(names{k}) = struct(); end
    end
elseif isfield(params, name)
    value = params.(name);
else
    error('Simulink:Commands:ParamUnknown', '''%s'' has no parameter named ''%s''', blk, name);
end
end
""",
    "set_param.m": """function set_param(blk, varargin)
global PENDFMU_MOCK
[params, index] = mock_block(blk);
for k = 1:2:numel(varargin)
    if ~isfield(params, varargin{k}) || strcmp(varargin{k}, 'BlockType')
        error('Simulink:Commands:ParamUnknown', '''%s'' has no parameter named ''%s''', blk, varargin{k});
    end
    PENDFMU_MOCK.blocks{index}.params.(varargin{k}) = varargin{k + 1};
    fprintf('MOCK|set_param|%s|%s|%s\\n', blk, varargin{k}, varargin{k + 1});
end
end
""",
    "gcs.m": """function system = gcs()
global PENDFMU_MOCK
system = PENDFMU_MOCK.system;
end
""",
    "find_system.m": """function found = find_system(system, varargin)
global PENDFMU_MOCK
found = {};
for i = 1:numel(PENDFMU_MOCK.blocks)
    b = PENDFMU_MOCK.blocks{i};
    slash = find(b.path == '/', 1, 'last');
    match = strcmp(b.path(1:slash - 1), system);
    for k = 1:2:numel(varargin)
        if strcmp(varargin{k}, 'Name')
            match = match && strcmp(b.path(slash + 1:end), varargin{k + 1});
        elseif ~strcmp(varargin{k}, 'SearchDepth')
            match = match && isfield(b.params, varargin{k}) && strcmp(b.params.(varargin{k}), varargin{k + 1});
        end
    end
    if match, found{end + 1, 1} = b.path; end
end
end
""",
}


def expected_starts(name: str) -> dict[str, float]:
    """Every parameter of component `name`: from PARAMS, else the table's default."""
    return {p: PARAMS.get(p, float(v.start)) for p, v in COMPONENTS[name].parameters.items()}


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    out = tmp_path_factory.mktemp("export")
    export_all(PARAMS, out, source="P.json")
    return out


@pytest.fixture(scope="module")
def mocks(tmp_path_factory):
    folder = tmp_path_factory.mktemp("simulink-mocks")
    for name, text in MOCKS.items():
        (folder / name).write_text(text)
    return folder


def q(text: str) -> str:
    """A MATLAB character vector literal."""
    return "'" + text.replace("'", "''") + "'"


def block(path: str, params: dict[str, str], block_type: str = "FMU") -> str:
    """Octave code adding a mock block with these dialog parameters."""
    fields = ", ".join(f"{q(k)}, {q(v)}" for k, v in {"BlockType": block_type, **params}.items())
    return f"PENDFMU_MOCK.blocks{{end + 1}} = struct('path', {q(path)}, 'params', struct({fields}));"


def fmu_block(path: str, component: str, fmu: str, leave_out: str = "") -> str:
    """A mock FMU Import block loading `fmu` with the parameters of `component` (all '0')."""
    params = {"FMUName": fmu, **{p: "0" for p in COMPONENTS[component].parameters if p != leave_out}}
    return block(path, params)


def run_octave(mocks: Path, cwd: Path, blocks: list[str], call: str, on_path=(), after: str = ""):
    """Run `call` in Octave with the mock blocks; return (set_param calls, error message, stdout)."""
    code = "\n".join(["global PENDFMU_MOCK", "PENDFMU_MOCK.system = 'rig';", "PENDFMU_MOCK.blocks = {};", *blocks,
                      *(f"addpath({q(str(p))});" for p in (mocks, *on_path)),
                      f"try\n  {call};\ncatch err\n  fprintf('ERROR|%s\\n', err.message);\nend", after])
    run = subprocess.run([OCTAVE, "--quiet", "--norc", "--no-window-system", "--eval", code], cwd=cwd,
                         capture_output=True, text=True, timeout=120)
    lines = run.stdout.splitlines()
    assert run.returncode == 0, run.stdout + run.stderr
    calls = [tuple(line.split("|")[2:]) for line in lines if line.startswith("MOCK|set_param|")]
    errors = [line[len("ERROR|"):] for line in lines if line.startswith("ERROR|")]
    return calls, (errors[0] if errors else None), run.stdout


def by_block(calls) -> dict[str, dict[str, str]]:
    """The calls as block -> parameter -> text (each parameter set once)."""
    result: dict[str, dict[str, str]] = {}
    for blk, name, text in calls:
        assert name not in result.setdefault(blk, {}), f"{blk}: {name} set twice"
        result[blk][name] = text
    return result


def assert_exact(texts: dict[str, str], component: str) -> None:
    expected = expected_starts(component)
    assert set(texts) == set(expected), component
    for name, text in texts.items():
        assert float(text) == expected[name], (component, name, text)


# -- parameters.mat, read with scipy


def test_mat_file_holds_every_value_exactly_with_unit_origin_and_guid(exported):
    data = loadmat(exported / "parameters.mat", simplify_cells=True)
    meta = data["pendfmu_export"]
    assert meta["source"] == "P.json" and meta["generated_by"].startswith("pendfmu ")
    assert [b["component"] for b in meta["blocks"]] == list(COMPONENTS)
    for entry in meta["blocks"]:
        name = entry["component"]
        table = COMPONENTS[name].parameters
        assert entry["fmu"] == f"{name}.fmu"
        assert entry["guid"] == read_model_description(str(exported / f"{name}.fmu")).guid
        assert list(entry["names"]) == list(table)
        assert dict(zip(entry["names"], entry["values"].tolist())) == expected_starts(name)
        assert list(entry["units"]) == [table[p].unit or "" for p in table]
        assert list(entry["origins"]) == ["P.json" if p in PARAMS else DEFAULT_ORIGIN for p in table]
        assert set(entry["types"]) == {"Real"}
        assert data[name] == expected_starts(name)  # the struct Cart.k_fwc ...


def test_script_tables_carry_17_significant_digits(exported):
    text = (exported / "set_parameters.m").read_text()
    rows = re.findall(r"^    '(\w+)'\s+'([^']*)'\s+'[^']*'\s+'Real'", text, re.M)
    written = {}
    for name, value in rows:
        written.setdefault(name, set()).add(value)
    for component in COMPONENTS:
        for name, value in expected_starts(component).items():
            assert f"{value:.17g}" in written[name] and float(f"{value:.17g}") == value


# -- the MATLAB function, run by Octave


@needs_octave
def test_sets_every_exported_value_on_the_blocks_named_like_the_components(exported, mocks, tmp_path):
    blocks = [fmu_block(f"rig/{c}", c, f"{c}.fmu") for c in COMPONENTS]
    calls, error, out = run_octave(mocks, tmp_path, blocks, "set_parameters()", [exported])
    assert error is None, out
    changed = by_block(calls)
    assert set(changed) == {f"rig/{c}" for c in COMPONENTS}
    for component in COMPONENTS:
        assert_exact(changed[f"rig/{component}"], component)
    assert f"Cart: set {len(COMPONENTS['Cart'].parameters)} parameters on 'rig/Cart' (Cart.fmu)" in out
    assert "k_fwc = 25.5 [N.s/m]  (P.json)" in out and f"m_c = 3 [kg]  ({DEFAULT_ORIGIN})" in out


@needs_octave
def test_values_from_the_mat_file_are_the_same(exported, mocks, tmp_path):
    blocks = [fmu_block(f"rig/{c}", c, f"{c}.fmu") for c in COMPONENTS]
    calls, error, out = run_octave(mocks, tmp_path, blocks, "set_parameters('mat', 'parameters.mat')", [exported])
    assert error is None, out
    changed = by_block(calls)
    for component in COMPONENTS:
        assert_exact(changed[f"rig/{component}"], component)
    assert "from parameters.mat" in out


@needs_octave
def test_missing_block_and_block_of_another_fmu_are_refused_by_name(exported, mocks, tmp_path):
    original = ensure_fmu("Cart")  # same model, but not the exported FMU: another GUID
    blocks = [fmu_block("rig/Cart", "Cart", str(original)), fmu_block("rig/Pendulum", "Pendulum", "Pendulum.fmu")]
    calls, error, out = run_octave(mocks, tmp_path, blocks, "set_parameters('CurrentLoop', 'rig/Current loop')",
                                   [exported])
    assert set(by_block(calls)) == {"rig/Pendulum"}
    assert_exact(by_block(calls)["rig/Pendulum"], "Pendulum")
    guid = read_model_description(str(exported / "Cart.fmu")).guid
    other = read_model_description(str(original)).guid
    assert "CurrentLoop (rig/Current loop): no such block (Invalid Simulink object name: 'rig/Current loop'.)" in error
    assert (f"Cart (rig/Cart): its FMU {original} has GUID {other}, not the exported Cart.fmu's {guid}: another FMU "
            f"or another export") in error
    assert "Cart: NOT SET on 'rig/Cart'" in out


@needs_octave
def test_a_block_lacking_a_parameter_or_of_another_type_is_left_alone(exported, mocks, tmp_path):
    blocks = [fmu_block("rig/Cart", "Cart", "Cart.fmu", leave_out="k_fwc"),
              block("rig/Pendulum", {"Gain": "1"}, "Gain")]
    calls, error, out = run_octave(mocks, tmp_path, blocks, "set_parameters()", [exported])
    assert calls == []
    assert "Cart (rig/Cart): the block has no parameter k_fwc (its parameters: FMUName, m_c," in error
    assert "Pendulum (rig/Pendulum): a Gain block, not an FMU Import block" in error
    assert "CurrentLoop: skipped: no block named CurrentLoop in 'rig'" in out


@needs_octave
def test_a_block_not_named_like_its_component_is_found_by_its_fmu(exported, mocks, tmp_path):
    blocks = [fmu_block("rig/FMU", "Cart", "Cart"), fmu_block("rig/FMU1", "Pendulum", "Pendulum.fmu"),
              fmu_block("rig/FMU2", "Pendulum", "Pendulum.fmu")]
    calls, error, out = run_octave(mocks, tmp_path, blocks, "set_parameters()", [exported])
    assert set(by_block(calls)) == {"rig/FMU"}
    assert_exact(by_block(calls)["rig/FMU"], "Cart")
    assert "no block named Cart in 'rig'; using 'rig/FMU', which loads Cart.fmu" in out
    assert "several FMU blocks in 'rig' load Pendulum.fmu (rig/FMU1, rig/FMU2)" in error


@needs_octave
def test_nothing_found_is_an_error_saying_how_to_name_the_blocks(exported, mocks, tmp_path):
    calls, error, _ = run_octave(mocks, tmp_path, [], "set_parameters('system', 'rig')", [exported])
    assert calls == []
    assert "no block of this export in 'rig'" in error and "set_parameters('CurrentLoop', PATH," in error


@needs_octave
def test_no_current_system_and_an_unknown_system_are_named(exported, mocks, tmp_path):
    no_model = ["PENDFMU_MOCK.system = '';"]  # what gcs gives when no model is open
    calls, error, _ = run_octave(mocks, tmp_path, no_model, "set_parameters('Cart', 'rig/Cart')", [exported])
    assert calls == []
    assert "CurrentLoop: no current system to look in (gcs is empty)" in error
    assert "Cart (rig/Cart): no such block" in error
    calls, error, _ = run_octave(mocks, tmp_path, [], "set_parameters('system', 'other')", [exported])
    assert "no block of this export in 'other'" in error


@needs_octave
def test_octave_reads_the_mat_file_to_the_same_doubles(exported, mocks, tmp_path):
    prints = "; ".join(f"fprintf('V|{c}|{p}|%.17g\\n', S.{c}.{p})" for c in COMPONENTS for p in COMPONENTS[c].parameters)
    after = (f"S = load({q(str(exported / 'parameters.mat'))}); {prints}; "
             "b = S.pendfmu_export.blocks{2}; fprintf('G|%s|%s|%.17g\\n', b.guid, b.names{7}, b.values(7));")
    _, error, out = run_octave(mocks, tmp_path, [], "1", after=after)
    assert error is None
    values = [line.split("|")[1:] for line in out.splitlines() if line.startswith("V|")]
    assert len(values) == sum(len(COMPONENTS[c].parameters) for c in COMPONENTS)
    for component, name, text in values:
        assert float(text) == expected_starts(component)[name]
    (g,) = [line.split("|")[1:] for line in out.splitlines() if line.startswith("G|")]
    name = list(COMPONENTS["Cart"].parameters)[6]
    assert g == [read_model_description(str(exported / "Cart.fmu")).guid, name, g[2]]
    assert float(g[2]) == expected_starts("Cart")[name]


def _tiny_fmu(path: Path, guid: str) -> Path:
    """Just enough FMU for the GUID check: a modelDescription.xml with that guid."""
    with zipfile.ZipFile(path, "w") as fmu:
        fmu.writestr("modelDescription.xml", f'<?xml version="1.0"?>\n<fmiModelDescription fmiVersion="2.0" '
                                             f'modelName="S" guid="{guid}"/>\n')
    return path


@needs_octave
def test_structured_names_set_fields_of_the_struct_parameter(mocks, tmp_path):
    """An FMU variable a.b is a field of the block's struct parameter a (FMUParamMapping
    'Structured'); the fields not exported keep their values."""
    folder = tmp_path / "out"
    folder.mkdir()
    guid = "{0f0e0d0c-0000-4000-8000-000000000001}"
    _tiny_fmu(folder / "S.fmu", guid)
    values = (0.1, 1 / 3, 2.0)
    write_simulink_files([BlockValues("S", "S.fmu", guid, ("a.b", "a.c.d", "k"), values, ("m", "", "s"),
                                      ("Real",) * 3, ("fit.json",) * 3)], folder, "fit.json")
    blocks = [block("rig/S", {"FMUName": "S.fmu", "a": "struct('b',1,'c',struct('d',2,'e',5),'f',7)", "k": "0"})]
    after = ("s = eval(PENDFMU_MOCK.blocks{1}.params.a); "
             "fprintf('S|%.17g|%.17g|%.17g|%.17g\\n', s.b, s.c.d, s.c.e, s.f);")
    calls, error, out = run_octave(mocks, tmp_path, blocks, "set_parameters()", [folder], after)
    assert error is None, out
    changed = by_block(calls)["rig/S"]
    assert set(changed) == {"a", "k"} and float(changed["k"]) == 2.0
    (fields,) = [[float(x) for x in line.split("|")[1:]] for line in out.splitlines() if line.startswith("S|")]
    assert fields == [0.1, 1 / 3, 5.0, 7.0]


# -- the CLI, and export --fmu


def test_cli_says_it_wrote_the_simulink_files(tmp_path, capsys):
    params = tmp_path / "P.json"
    params.write_text(json.dumps({"parameters": {"k_fwc": 25.0}}))
    assert main(["export", "--params", str(params), "--out", str(tmp_path / "o")]) == 0
    out = capsys.readouterr().out
    assert f"wrote {tmp_path / 'o' / 'set_parameters.m'}" in out and f"wrote {tmp_path / 'o' / 'parameters.mat'}" in out


def test_export_for_a_users_fmu_writes_its_values_with_the_kept_guid(tmp_path, capsys):
    fmu = ensure_fmu("Cart")  # stands for a user's FMU: export --fmu treats it as one
    params = tmp_path / "fitted.json"
    params.write_text(json.dumps({"parameters": {"k_fwc": 31.25, "F_Kc": 0.1 + 0.7}}))
    assert main(["export", "--fmu", str(fmu), "--params", str(params), "--out", str(tmp_path / "o")]) == 0
    assert "set_parameters.m" in capsys.readouterr().out
    copy = read_model_description(str(tmp_path / "o" / "Cart.fmu"))
    (entry,) = [loadmat(tmp_path / "o" / "parameters.mat", simplify_cells=True)["pendfmu_export"]["blocks"]]
    assert entry["guid"] == copy.guid == read_model_description(str(fmu)).guid
    starts = {v.name: float(v.start) for v in copy.modelVariables if v.causality == "parameter"}
    assert dict(zip(entry["names"], entry["values"].tolist())) == starts
    assert starts["k_fwc"] == 31.25 and starts["F_Kc"] == 0.1 + 0.7
    origins = dict(zip(entry["names"], entry["origins"]))
    assert origins["k_fwc"] == str(params) and origins["m_c"] == DEFAULT_ORIGIN
