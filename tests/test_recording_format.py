"""The recording format's reference (pendfmu/recording/FORMAT.md, issue 25 item 7) against the
reader, name for name: every column, sidecar key, quantizer, parameter and initial state the
reader accepts is in the document, with the unit of the component tables, and everything
the document lists is accepted. The document's own sidecar example reads; `pendfmu format`
prints the document. So a name added to the reader without the document (or the reverse)
fails here."""

from __future__ import annotations

import json
import re

import pytest

from pendfmu.cli import main
from pendfmu.components import COMPONENTS, parameter_table
from pendfmu.physics import CENTRE_OF_MASS_INERTIA
from pendfmu.recording import INITIAL_NAMES, MAT_TIME_NAMES, PARAMETER_NAMES, QUANTIZERS, SIGNAL_NAMES, \
    format_document, read_recording
from pendfmu.recording.measurement import INPUT_DELAY, measurement_signal
from pendfmu.recording.schema import SIDECAR_KEYS, SIGNAL_INFO_KEYS

DOCUMENT = format_document().read_text(encoding="utf-8")


def section(title: str) -> str:
    """The text under a heading, to the next heading."""
    match = re.search(rf"^#+ {re.escape(title)}\n", DOCUMENT, re.MULTILINE)
    assert match, f"FORMAT.md has no heading {title!r}"
    end = re.compile(r"^#+ ", re.MULTILINE).search(DOCUMENT, match.end())
    return DOCUMENT[match.end():end.start() if end else len(DOCUMENT)]


def table(title: str) -> dict[str, list[str]]:
    """The rows of the tables under a heading: first cell (its `code` name) -> the other cells."""
    rows = {}
    for line in section(title).splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if line.startswith("|") and cells[0].startswith("`"):
            rows[cells[0].strip("`")] = cells[1:]
    return rows


def units() -> dict[str, str]:
    """Each signal's and parameter's unit in the component tables."""
    found = {name: variable.unit for name, variable in parameter_table().items()}
    for component in COMPONENTS.values():
        for variable in component.variables:
            if variable.causality in ("input", "output"):
                found[variable.name] = variable.unit
    return {**found, CENTRE_OF_MASS_INERTIA.name: CENTRE_OF_MASS_INERTIA.unit}


def test_every_column_the_reader_accepts_is_documented_with_its_unit():
    documented = table("Signals (columns)")
    assert set(documented) == set(SIGNAL_NAMES)
    for name, (unit, _what) in documented.items():
        assert unit == units()[name], f"{name}: the document says {unit}, the component table {units()[name]}"


def test_every_sidecar_key_is_documented_and_every_documented_key_is_read():
    assert set(table("The sidecar")) == set(SIDECAR_KEYS)
    assert set(table("`signals.<column>`")) == set(SIGNAL_INFO_KEYS)
    quantizer = table("`signals.<column>`")["quantizer"][0]
    assert set(re.findall(r"`(\w+)`", quantizer)) == set(QUANTIZERS)


def test_every_parameter_and_initial_state_is_documented():
    documented = table("`parameters`")
    plain = {name for name in documented if measurement_signal(name) is None}
    assert plain == set(PARAMETER_NAMES)
    for name in plain:
        assert documented[name][0] == units()[name], name
    patterns = {name for name in documented if measurement_signal(name) is not None}
    assert patterns == {"<signal>_offset", "<signal>_scale", INPUT_DELAY}
    assert set(table("`initial`")) == set(INITIAL_NAMES)


def test_the_time_names_and_conventions_are_stated():
    files = section("Files")
    for name in MAT_TIME_NAMES:
        assert f"`{name}`" in files, name
    conventions = section("Conventions")
    for rule in ("`phi = 0` upright", "`phi = pi` hanging", "continuous", "`phi = pi + angle`",
                 "about its **pivot**", "`J_p = J_cm + m_p·l²`"):
        assert rule in conventions, rule


def test_the_documented_sidecar_example_reads(tmp_path):
    example = re.search(r"^    \{\n.*?^    \}\n", section("The sidecar"), re.MULTILINE | re.DOTALL).group(0)
    sidecar = json.loads(example)
    (tmp_path / "run1.json").write_text(example)
    (tmp_path / "run1.csv").write_text("time,phi,pwm\n0,3.7,0.1\n0.001,3.7,0.2\n")
    recording = read_recording(tmp_path / "run1.csv")
    assert recording.names == ("phi",) and recording.ignored == ("pwm",)
    assert recording.parameters == sidecar["parameters"] and recording.initial == sidecar["initial"]
    assert recording.resolution("phi") == sidecar["signals"]["phi"]["resolution"]


@pytest.mark.parametrize("words", [["format"], ["format", "--path"]])
def test_pendfmu_format_prints_the_document(words, capsys):
    assert main(words) == 0
    out = capsys.readouterr().out
    assert out == DOCUMENT if words == ["format"] else out.strip() == str(format_document())
