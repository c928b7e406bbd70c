"""`pendfmu check` on the FMI standard's Reference FMUs (v0.0.41, FMI 2.0 and 3.0, built for
Linux: ../shared/thirdparty-fmus/Reference-FMUs, its SOURCE.txt says how and what each FMU
does; the tests skip when the folder is absent).

With default options no row of any of them FAILs but for a defect of the FMU itself, shown
here with fmpy's plain calls: Stair keeps asking to terminate after fmi2Reset / fmi3Reset in
Co-Simulation (FMI: a reset FMU is as after instantiation). Their shipped reference results
(FMI-LS-REF: extra/org.fmi-standard.fmi-ls-ref/<Model>_out.csv) are read and pass in
Co-Simulation, the interface they were made with; Roberts' (upstream: BouncingBall's file under
another name, not in the manifest) is a WARN, and Clocks (Scheduled Execution only) an
INCONCLUSIVE row, not a crash.
"""

from __future__ import annotations

import os
import zipfile
from pathlib import Path

import numpy as np
import pytest

from pendfmu.check import run_battery
from pendfmu.check.fmu import FAIL, INCONCLUSIVE, PASS, WARN, Driver, Target

FOLDER = Path(os.environ.get("PENDFMU_REFERENCE_FMUS",
                             Path(__file__).resolve().parents[2] / "shared" / "thirdparty-fmus" / "Reference-FMUs"))
FMUS = sorted(f"fmi{v}/{p.name}" for v in (2, 3) for p in (FOLDER / f"fmi{v}").glob("*.fmu")) if FOLDER.is_dir() else []
pytestmark = pytest.mark.skipif(not FMUS, reason=f"the Reference FMUs are not in {FOLDER}")

UPSTREAM_DEFECTS = {"fmi2/Stair.fmu": {"determinism: reset CS"}, "fmi3/Stair.fmu": {"determinism: reset CS"}}
"""The FAIL rows that are the FMUs' own defects (test_stair_asks_to_terminate_after_reset)."""
CONSTANT = {"fmi2/Resource.fmu", "fmi3/Resource.fmu"}
"""No inputs, one output read once from a resource file: nothing moves for a dynamic check to judge."""

_RESULTS: dict[str, list] = {}


def battery(name: str) -> list:
    """The whole battery with default options, once per FMU for all the tests here."""
    if name not in _RESULTS:
        _RESULTS[name] = run_battery(FOLDER / name)
    return _RESULTS[name]


@pytest.mark.slow
@pytest.mark.parametrize("name", FMUS)
def test_every_reference_fmu_goes_through_the_battery_without_a_false_fail(name):
    rows = battery(name)
    failed = {r.name for r in rows if r.verdict == FAIL}
    assert failed == UPSTREAM_DEFECTS.get(name, set()), [r for r in rows if r.verdict == FAIL]
    target = Target(FOLDER / name)
    for kind in target.interfaces:  # every interface it has was driven, and judged only if something moved
        (fresh,) = [r for r in rows if r.name == f"determinism: fresh instances {kind}"]
        assert fresh.verdict == (INCONCLUSIVE if name in CONSTANT else PASS), fresh
    if name in CONSTANT:  # the output is what the resource file says, and no dynamic row passes it
        assert {r.verdict for r in rows if r.name.startswith(("events", "determinism", "rollback",
                                                              "convergence"))} == {INCONCLUSIVE}
        assert all(r.verdict == PASS for r in rows if r.name.startswith("reference: y"))
    for row in rows:  # a WARN or INCONCLUSIVE row says why
        assert row.verdict == PASS or row.message, row


@pytest.mark.slow
@pytest.mark.parametrize("name", [n for n in FMUS if not n.endswith(("Clocks.fmu", "Roberts.fmu"))])
def test_the_shipped_reference_result_is_read_and_passes_in_co_simulation(name):
    """The reference CSV was made in Co-Simulation by the FMU's own fixed-step solver: CS
    reproduces it; ME (integrated by pendfmu's driver) passes, or is a WARN that says the
    interfaces differ by their solvers (Dahlquist's reference is Euler at 0.1 s)."""
    model = Path(name).stem
    rows = [r for r in battery(name) if r.name.startswith("reference: ")]
    cs = [r for r in rows if r.name.endswith(" CS")]
    assert cs and all(r.verdict == PASS for r in cs), cs
    assert all(f"[reference from the FMU: extra/org.fmi-standard.fmi-ls-ref/{model}_out.csv]" in r.figure for r in cs)
    for row in (r for r in rows if r.name.endswith(" ME")):
        assert row.verdict == PASS or (row.verdict == WARN and "the FMU's CS reproduces this carried reference"
                                       in row.message), row
    (notes,) = [r for r in rows if r.name == "reference: FMI-LS-REF"]
    assert notes.verdict == WARN and "no fmi-ls:fmi-ls-description attribute" in notes.message


@pytest.mark.slow
def test_arrays_booleans_and_the_fmi2_feedthroughs_fmi3_columns_are_read_as_far_as_they_fit():
    """StateSpace's y (an array, "1 2 3" in a cell) is compared per element; FMI 3.0
    Feedthrough's Boolean (true/false) and integer outputs pass, its String and Binary are
    left out with a note; the FMI 2.0 Feedthrough ships the FMI 3.0 file: the types it lacks
    are notes, the ones it has pass."""
    space = {r.name: r for r in battery("fmi3/StateSpace.fmu")}
    assert all(space[f"reference: y[{k}] {kind}"].verdict == PASS for k in (1, 2, 3) for kind in ("CS", "ME"))
    three = {r.name: r for r in battery("fmi3/Feedthrough.fmu")}
    assert three["reference: Boolean_output CS"].verdict == PASS and three["reference: UInt64_output ME"].verdict == PASS
    assert "columns String_output, Binary_output: not numbers, not compared" in three["reference: FMI-LS-REF"].message
    two = {r.name: r for r in battery("fmi2/Feedthrough.fmu")}
    assert "Float32_continuous_output" in two["reference: FMI-LS-REF"].message
    assert two["reference: Float64_continuous_output CS"].verdict == PASS
    assert two["reference: Enumeration_output ME"].verdict == PASS


@pytest.mark.slow
def test_what_cannot_be_checked_is_said_not_failed():
    clocks = battery("fmi3/Clocks.fmu")
    assert [(r.name, r.verdict) for r in clocks] == [("static: model description", PASS),
                                                     ("static: interfaces", INCONCLUSIVE)]
    assert "Scheduled Execution" in clocks[1].message
    roberts = {r.name: r for r in battery("fmi3/Roberts.fmu")}
    notes = roberts["reference: FMI-LS-REF"]
    assert notes.verdict == WARN and "names 'BouncingBall_out.csv' (result), which the FMU does not contain" in notes.message
    assert "Roberts_out.csv is not described in the manifest: not read" in notes.message
    assert "runs of 10 s, not the default experiment's 1e+08 s" in roberts["static: model description"].figure
    feedthrough = {r.name: r for r in battery("fmi2/Feedthrough.fmu")}
    nan = feedthrough["sequence: NaN input ME"]  # the output is the input: FMI leaves NaN handling to the FMU
    assert nan.verdict == WARN and "depend on Float64_continuous_input" in nan.message
    fixed = feedthrough["sequence: fixed parameter set while stepping CS"]
    assert fixed.verdict == WARN and "FMI 3.0 section 2.2.3" in fixed.message


@pytest.mark.parametrize("version", (2, 3))
@pytest.mark.parametrize("kind", ("CS", "ME"))
def test_the_driver_ends_stairs_run_where_the_fmu_asks_to_and_matches_its_reference(version, kind):
    """Stair counts the seconds and asks to terminate when it reaches 10 at t = 9 s (CS:
    fmi2DoStep's Discard with fmi2Terminated, fmi3DoStep's terminateSimulation; ME: the
    event iteration's terminateSimulation). The run ends there, as in fmpy and fmusim, the
    counter holding 10, and agrees with Stair_out.csv at every shipped row."""
    target = Target(FOLDER / f"fmi{version}" / "Stair.fmu")
    unit = Driver(target, kind)
    try:
        unit.initialize()
        rows = unit.run(target.step, target.stop, None)
        assert unit.ended == pytest.approx(9.0)
    finally:
        unit.free()
    with zipfile.ZipFile(target.path) as archive:
        shipped = np.loadtxt(archive.open("extra/org.fmi-standard.fmi-ls-ref/Stair_out.csv"), delimiter=",", skiprows=1)
    times = np.arange(len(rows)) * target.step
    assert shipped[-1, 0] == pytest.approx(9.0)
    assert np.array_equal(np.interp(shipped[:, 0], times, rows[:, 0]), shipped[:, 1])
    assert np.all(rows[times >= 9.0 - 1e-9, 0] == 10)


@pytest.mark.parametrize("version", (2, 3))
def test_stair_asks_to_terminate_after_reset(version):
    """The upstream defect behind UPSTREAM_DEFECTS, with fmpy's own classes and no pendfmu:
    after a run to its end and a reset, Stair's first Co-Simulation step already asks to
    terminate (its reset does not clear terminateSimulation), where a fresh instance runs to 9 s."""
    from fmpy import extract, read_model_description
    from fmpy.fmi2 import FMU2Slave
    from fmpy.fmi3 import FMU3Slave

    path = FOLDER / f"fmi{version}" / "Stair.fmu"
    md = read_model_description(str(path))
    fmu = (FMU2Slave if version == 2 else FMU3Slave)(guid=md.guid, unzipDirectory=extract(str(path)),
                                                     modelIdentifier="Stair", instanceName="raw")
    fmu.instantiate()

    def end_of_run() -> float:
        if version == 2:
            fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        fmu.exitInitializationMode()
        for k in range(50):
            if version == 3:
                if fmu.doStep(k * 0.2, 0.2)[1]:
                    return (k + 1) * 0.2
            elif _fmi2_discarded(fmu, k * 0.2):
                return (k + 1) * 0.2
        return 10.0

    try:
        assert end_of_run() == pytest.approx(9.0)
        fmu.reset()
        assert end_of_run() == pytest.approx(0.2)
    finally:
        fmu.freeInstance()


def _fmi2_discarded(fmu, t: float) -> bool:
    """fmi2DoStep from t; whether it returned fmi2Discard with fmi2Terminated true."""
    from fmpy.fmi1 import FMICallException

    try:
        fmu.doStep(t, 0.2)
    except FMICallException as error:
        return error.status == 2 and fmu.getBooleanStatus(3)
    return False


def test_a_stiff_model_is_integrated_in_model_exchange_as_its_own_co_simulation_does():
    """Roberts (stiff: h|lambda| up to about 2000 1/s times the step) over 10 s at h = 0.02 s:
    pendfmu's Model Exchange driver halves its Runge-Kutta steps where they would go unstable
    (a single step per communication step gave NaN) and agrees with the FMU's own fixed-step
    Co-Simulation (1 ms Euler) to 1e-5; a step it cannot split small enough is a limit of the
    check (StiffModel: an INCONCLUSIVE row), not a failure of the FMU."""
    from pendfmu.check import static

    target = Target(FOLDER / "fmi3" / "Roberts.fmu")
    ends = {}
    for kind in ("CS", "ME"):
        unit = Driver(target, kind)
        try:
            unit.initialize()
            ends[kind] = unit.run(target.step, target.stop, None)[-1]
        finally:
            unit.free()
    assert np.all(np.isfinite(ends["ME"]))
    np.testing.assert_allclose(ends["ME"], ends["CS"], rtol=1e-5, atol=1e-9)
    row = static.check_capabilities(Target(target.path, stop=1e5, step=1e4), "ME")
    assert row.verdict == INCONCLUSIVE and "too stiff for pendfmu check's explicit integrator" in row.message


def test_pendfmus_export_writes_the_layout_the_reference_fmus_ship_and_reads_it_back(tmp_path):
    """The same files and manifest entries as every Reference FMU (the manifest, <Model>_out.csv
    of role result, text/csv), the manifest valid where theirs lacks the description, and
    `pendfmu check` finds and passes it (the Cart's own Co-Simulation run as the reference)."""
    import shutil

    from lxml import etree

    from pendfmu.check.reference import Reference, run_on_grid
    from pendfmu.cli import main
    from pendfmu.export.lsref import FOLDER as LS, MANIFEST, add_references, carried, check_manifest
    from pendfmu.fmubuild import ensure_fmu

    def layout(path: Path, model: str):
        with zipfile.ZipFile(path) as archive:
            names = {n.replace(model, "<Model>") for n in archive.namelist() if n.startswith(LS + "/") and n[-1] != "/"}
            manifest = archive.read(MANIFEST)
        entries = [(e.get("source").replace(model, "<Model>"), e.get("role"), e.get("type"))
                   for e in etree.fromstring(manifest).iterfind("Related")]
        return names, entries, manifest

    fmu = Path(shutil.copy(ensure_fmu("Cart"), tmp_path / "Cart.fmu"))
    times = np.linspace(0.0, 0.2, 201)
    own = run_on_grid(Target(fmu), "CS", Reference(times, {}, {"x": times, "v": times}, "the Cart's own run"))
    reference = tmp_path / "cart.csv"
    reference.write_text("time,x,v\n" + "".join(f"{float(t)!r},{float(x)!r},{float(v)!r}\n"
                                                 for t, x, v in zip(times, own["x"], own["v"])))
    add_references(fmu, reference)
    names, entries, manifest = layout(fmu, "Cart")
    for name in [n for n in FMUS if not n.endswith(("Clocks.fmu", "Roberts.fmu"))]:
        theirs = layout(FOLDER / name, Path(name).stem)
        assert (names, entries) == theirs[:2] == ({f"{LS}/fmi-ls-manifest.xml", f"{LS}/<Model>_out.csv"},
                                                  [("<Model>_out.csv", "result", "text/csv")])
        assert check_manifest(theirs[2]) == ["no fmi-ls:fmi-ls-description attribute (the FMI-LS-REF schema "
                                             "requires it)"]
    assert check_manifest(manifest) == []
    (found,) = carried(fmu).results
    assert found.member == f"{LS}/Cart_out.csv" and found.text == reference.read_text()
    assert main(["check", str(fmu), "--only", "reference"]) == 0
