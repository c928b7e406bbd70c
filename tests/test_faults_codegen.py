"""Generated code stays code whatever the user's strings hold (issue 28, part 6).

A parameters file's path and an FMU's variable names reach the exported modifiers.mo,
set_parameters.m, the copies' model descriptions, the SSV file, the start file the FMUs'
C code reads, and the report. FMI allows any character in a name, and a path may hold
line breaks too: the hostile strings here hold line breaks (LF, CR, U+2028), both quotes,
comment openers and closers of every language ('//', '%{', '*/', '#'), markup, and
non-ASCII. Each file is read back by an independent reader (GNU Octave, rumoca, lxml, the
start file's own line rules) and must hold exactly the strings given, as data.
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pytest
import rumoca
from lxml import etree

from pendfmu.cli import main
from pendfmu.export import fmu as fmu_export
from pendfmu.fitting.result import ExperimentFit
from pendfmu.fmubuild import ensure_fmu
from pendfmu.report.interactive import recording_plot
from pendfmu.ssp import read_ssv

# A path (as typed: '//' is one separator) and a variable name that end comments, strings and
# lines in every language written.
HOSTILE_PATH = "it's \"fit\"\n*/ model Injected end Injected; //%{\r\nerror('injected') # é€\u2028.json"
HOSTILE_NAME = "m\"c'\n*/ // %{\r# <b>é€\u2028</b>"
MODELICA = Path(__file__).resolve().parents[1] / "modelica"
OCTAVE = shutil.which("octave-cli") or shutil.which("octave")


def hostile_fmu(path: Path) -> Path:
    """pendfmu's Cart FMU with its parameter m_c renamed HOSTILE_NAME (a user's FMU may name
    a variable so: FMI 2.0 restricts names only under variableNamingConvention structured)."""
    with zipfile.ZipFile(ensure_fmu("Cart")) as original, zipfile.ZipFile(path, "w") as copy:
        for info in original.infolist():
            data = original.read(info)
            if info.filename == "modelDescription.xml":
                root = etree.fromstring(data)
                next(v for v in root.iter("ScalarVariable") if v.get("name") == "m_c").set("name", HOSTILE_NAME)
                data = etree.tostring(root, xml_declaration=True, encoding="UTF-8")
            copy.writestr(info, data)
    return path


@pytest.fixture(scope="module")
def exports(tmp_path_factory):
    """`pendfmu export` of the rig (from a plainly named and a hostile parameters file) and of
    the hostile FMU (its hostile parameter given in the hostile file): folder by case."""
    folder = tmp_path_factory.mktemp("hostile")
    plain, hostile, names = str(folder / "plain.json"), f"{folder}/{HOSTILE_PATH}", f"{folder}/names/{HOSTILE_PATH}"
    for path, values in ((plain, {"k_fwc": 25.5, "m_p": 0.3}), (hostile, {"k_fwc": 25.5, "m_p": 0.3}),
                         (names, {HOSTILE_NAME: 2.5, "k_fwc": 31.25})):
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        Path(path).write_text(json.dumps({"parameters": values}))
    fmu = hostile_fmu(folder / "H.fmu")
    runs = {"plain": ["--params", plain], "hostile": ["--params", hostile], "fmu": ["--fmu", str(fmu), "--params", names]}
    for case, arguments in runs.items():
        assert main(["export", *arguments, "--out", str(folder / case)]) == 0, case
    return {case: folder / case for case in runs} | {"source": hostile, "names source": names}


def modelica_string(literal: str) -> str:
    """A Modelica string literal's value (Modelica 3.5, 2.4.6), written for this test."""
    escapes = {"n": "\n", "r": "\r", "t": "\t", "v": "\v", "f": "\f", "a": "\a", "b": "\b", "\\": "\\", '"': '"',
               "'": "'", "?": "?"}
    return re.sub(r"\\(.)", lambda found: escapes[found.group(1)], literal[1:-1])


def test_a_hostile_params_path_changes_only_comments_and_the_package_description_of_modifiers_mo(exports):
    plain = (exports["plain"] / "modifiers.mo").read_text(encoding="utf-8").split("\n")
    hostile = (exports["hostile"] / "modifiers.mo").read_text(encoding="utf-8").split("\n")
    assert len(hostile) == len(plain)  # no line was added: every comment stayed one line
    changed = [(a, b) for a, b in zip(plain, hostile) if a != b]
    package = [b for a, b in changed if not a.startswith("//")]
    assert all(b.startswith("// ") for a, b in changed if a.startswith("//"))
    (line,) = package
    head, literal = line.split(" ", 2)[:2], line.split(" ", 2)[2]
    assert head == ["package", "PendfmuExport"] and re.fullmatch(r'"([^"\\]|\\.)*"', literal)
    assert modelica_string(literal) == f"Parameters exported by pendfmu from {exports['source']}"
    values = [{p.name: p.value for p in rumoca.Session(roots=[str(MODELICA)]).load(
        str(exports[case] / "modifiers.mo"), model="PendfmuExport.IdentifiedComponents").parameters}
        for case in ("plain", "hostile")]
    assert values[0] == values[1] and values[0]["cart.k_fwc"] == 25.5


@pytest.mark.skipif(OCTAVE is None, reason="GNU Octave is not installed (Debian package octave): the exported "
                                           "MATLAB script is not read back")
@pytest.mark.parametrize("case", ["hostile", "fmu"])
def test_set_parameters_m_parses_and_holds_the_hostile_strings_exactly(exports, case, tmp_path):
    """Octave reads set_parameters.m (its functions, loaded as a script) and prints, as UTF-8
    hex, the source and every parameter name the tables hold."""
    script = tmp_path / "read_back.m"
    script.write_text("1;\n" + (exports[case] / "set_parameters.m").read_text(encoding="utf-8") + """
hex = @(text) sprintf('%02x', double(text));
printf('SOURCE|%s\\n', hex(exported_source()));
for c = exported_values()
  for k = 1:numel(c{1}.names)
    printf('NAME|%s|%s\\n', hex(c{1}.names{k}), hex(c{1}.origins{k}));
  end
end
""", encoding="utf-8")
    run = subprocess.run([OCTAVE, "--quiet", "--norc", "--no-window-system", str(script)], capture_output=True,
                         text=True, timeout=60, cwd=tmp_path)
    assert run.returncode == 0 and "parse error" not in run.stderr, run.stdout + run.stderr
    lines = [line.split("|") for line in run.stdout.splitlines()]
    source = exports["source" if case == "hostile" else "names source"]
    assert [fields[1] for fields in lines if fields[0] == "SOURCE"] == [source.encode().hex()]
    names = {bytes.fromhex(fields[1]).decode(): bytes.fromhex(fields[2]).decode() for fields in lines
             if fields[0] == "NAME"}
    if case == "fmu":
        assert names[HOSTILE_NAME] == names["k_fwc"] == source and "m_c" not in names
    else:
        assert names["k_fwc"] == source and len(names) > 10


def test_the_fmu_copy_and_the_ssv_hold_the_hostile_name_as_data_and_a_control_character_shown(tmp_path):
    """lxml reads the copy's model description and the SSV file: the hostile name comes back
    exactly, and writing the document again reads back the same. A control character in the
    path (XML cannot hold it, not even escaped) is shown in the description, not refused."""
    params = tmp_path / "bell\x07.json"
    params.write_text(json.dumps({"parameters": {HOSTILE_NAME: 2.5, "k_fwc": 31.25}}))
    fmu = hostile_fmu(tmp_path / "H.fmu")
    assert main(["export", "--fmu", str(fmu), "--params", str(params), "--out", str(tmp_path / "o")]) == 0
    with zipfile.ZipFile(tmp_path / "o" / "Cart.fmu") as copy:
        root = etree.fromstring(copy.read("modelDescription.xml"))
    for document in (root, etree.fromstring(etree.tostring(root))):
        variable = next(v for v in document.iter("ScalarVariable") if v.get("name") == HOSTILE_NAME)
        assert float(variable.find("Real").get("start")) == 2.5
        assert f"{tmp_path}/bell\\x07.json" in document.get("description")
    values = read_ssv(tmp_path / "o" / "parameters.ssv").values
    assert values[f"Cart.{HOSTILE_NAME}"].value == 2.5 and values["Cart.k_fwc"].value == 31.25


def test_the_start_file_keeps_every_hostile_name_inside_one_short_comment_line():
    """start.c reads lines of at most 255 characters: a value line is '<vr> <value>', a
    comment starts with '#'; a name may end neither the line nor the comment."""
    with zipfile.ZipFile(ensure_fmu("Cart")) as fmu:
        root = etree.fromstring(fmu.read("modelDescription.xml"))
    variables = [v for v in root.iter("ScalarVariable") if v.get("causality") == "parameter" and v.find("Real") is not None]
    variables[0].set("name", HOSTILE_NAME)
    variables[1].set("name", "x" * 400)
    root.set("modelName", "Model\nname")
    lines = fmu_export.start_file_text(etree.tostring(root)).split("\n")[:-1]
    assert lines[0].startswith("guid {") and all(len(line) <= 255 for line in lines[1:])
    values = [line for line in lines[1:] if not line.startswith("#")]
    assert len(values) == len(variables) and all(re.fullmatch(r"\d+ \S+", line) for line in values)
    assert len(lines) == 2 + 2 * len(variables)


def test_plot_traces_show_a_signal_name_as_typed():
    """plotly reads tags in trace names and axis titles (<b>, <a href>): a signal's name is
    passed escaped, so that the page shows it as typed."""
    time = np.linspace(0.0, 1.0, 50)
    name = "a<b>x</b> & <a href='javascript:1'>y</a>"
    fit = ExperimentFit("run", time, {name: np.sin(time)}, {name: np.sin(time) + 0.01}, {name: 0.01})
    page = recording_plot(fit, "plot-1")
    shown = json.loads(re.search(r"Plotly.newPlot\(\s*\"plot-1\",\s*(\[.*?\]),\s*\{", page, re.S).group(1))
    assert {trace["name"] for trace in shown} >= {"recorded a&lt;b&gt;x&lt;/b&gt; &amp; &lt;a "
                                                  "href=&#x27;javascript:1&#x27;&gt;y&lt;/a&gt;"}
