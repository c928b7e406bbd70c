"""The FMU files themselves: XML valid, every fmi2 function exported, the GUID checked and the
declared capabilities working (pendfmu.testing's assert_valid), sources compile."""

from __future__ import annotations

import subprocess
import zipfile
from pathlib import Path

import fmpy
import pytest
from fmpy.model_description import read_build_description

from pendfmu.components import ALL_COMPONENTS as COMPONENTS, Component, Variable
from pendfmu.fmubuild import compute_guid
from pendfmu.fmubuild.compiler import compile_sources
from pendfmu.testing import assert_valid

NAMES = list(COMPONENTS)


@pytest.mark.parametrize("name", NAMES)
def test_the_fmu_passes_the_static_checks(built_fmus, name):
    """pendfmu.testing's static checks: the XML valid (validate_fmu), every fmi2 function of
    both interfaces exported, the GUID checked, the declared capabilities working."""
    assert_valid(built_fmus[name])


@pytest.mark.parametrize("name", NAMES)
def test_one_binary_serves_both_interfaces(built_fmus, name):
    md = fmpy.read_model_description(str(built_fmus[name]))
    assert md.modelExchange.modelIdentifier == md.coSimulation.modelIdentifier == name
    assert md.coSimulation.canGetAndSetFMUstate and md.coSimulation.canSerializeFMUstate


@pytest.mark.parametrize("name", NAMES)
def test_variables_follow_the_table(built_fmus, name):
    """The XML is generated from the table: names, references, units and starts agree."""
    md = fmpy.read_model_description(str(built_fmus[name]))
    table = COMPONENTS[name].variables
    assert [v.name for v in md.modelVariables] == [v.name for v in table]
    for vr, (xml, var) in enumerate(zip(md.modelVariables, table)):
        assert xml.valueReference == vr
        assert (xml.causality, xml.type) == (var.causality, var.type)
        assert (xml.unit or "") == (var.unit if var.type == "Real" else "")
        if var.start is not None and var.type == "Real":
            assert float(xml.start) == var.start


@pytest.mark.parametrize("name", NAMES)
def test_source_fmu_compiles_from_its_build_description(built_fmus, name, tmp_path):
    """An importer on another platform gets everything it needs in sources/."""
    (config,) = read_build_description(str(built_fmus[name]))
    assert config.modelIdentifier == name
    with zipfile.ZipFile(built_fmus[name]) as fmu:
        fmu.extractall(tmp_path)
    listed = {f for files in config.sourceFileSets for f in files.sourceFiles}
    assert listed == {p.name for p in (tmp_path / "sources").glob("*.c")}
    library = tmp_path / "rebuilt.so"
    compile_sources(tmp_path / "sources", library)
    # A C host (not Python) loads it: the math library must be linked in.
    probe = subprocess.run(["ldd", str(library)], capture_output=True, text=True)
    assert "libm" in probe.stdout


def test_guid_changes_with_the_table():
    cart = COMPONENTS["Cart"]
    changed = Component(cart.name, cart.description, cart.variables[:-1] + (
        Variable("stuck", "local", "discrete", None, "", "renamed description", type="Boolean"),),
        cart.event_indicators)
    assert compute_guid(changed) != compute_guid(cart)
    assert compute_guid(cart) == compute_guid(COMPONENTS["Cart"])


def test_fmus_are_not_rebuilt_when_up_to_date(built_fmus):
    from pendfmu.fmubuild import build_all

    before = {name: Path(path).stat().st_mtime_ns for name, path in built_fmus.items()}
    build_all()
    assert {name: Path(path).stat().st_mtime_ns for name, path in built_fmus.items()} == before


def test_descriptions_are_parsed_one_thread_at_a_time(built_fmus, tmp_path, monkeypatch):
    """fmpy validates a description against the FMI schema, and libxml2 sets up its schema
    types on a process's first schema parse: two threads at it at once broke every later
    parse of that process, about once in 60 (build_all's stale checks run one thread per
    component; a pytest worker then rebuilt FMUs and failed a dozen tests). So
    compiler.model_description lets one thread parse at a time: here eight threads, each
    with an FMU file of its own (not yet parsed), never overlap inside fmpy's reader."""
    import shutil
    import threading
    import time

    from pendfmu.fmubuild import compiler

    inside, most, lock = [0], [0], threading.Lock()
    real = fmpy.read_model_description

    def watched(path, *args, **kwargs):
        with lock:
            inside[0] += 1
            most[0] = max(most[0], inside[0])
        time.sleep(0.01)  # long enough for the others to arrive
        try:
            return real(path, *args, **kwargs)
        finally:
            with lock:
                inside[0] -= 1

    monkeypatch.setattr(compiler.fmpy, "read_model_description", watched)
    copies = [shutil.copy(built_fmus[NAMES[0]], tmp_path / f"copy{k}.fmu") for k in range(8)]
    barrier = threading.Barrier(len(copies))

    def parse(path):
        barrier.wait()
        compiler.model_description(path)

    threads = [threading.Thread(target=parse, args=(path,)) for path in copies]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert most[0] == 1
