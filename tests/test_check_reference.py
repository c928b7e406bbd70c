"""`pendfmu check --reference`: the tolerance tube (pendfmu/check/reference.py) on hand-made
cases, and pendfmu's Cart FMU against a reference made by the independent event-driven
simulator (tests/reference_rig.py)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import reference_rig as rr
from pendfmu.check import run_battery
from pendfmu.check.reference import compare, tube
from pendfmu.cli import main
from pendfmu.export.fmu import write_parameterized_fmu

FIG3 = dict(eta=1.0, k_M=1.0, k_D=1.0, m_c=0.5, m_p=0.0, k_fwc=2.0, F_Kc=0.3, F_Sc=0.8)


# -- the tube on hand-made cases

def step_case():
    """A unit step at t = 0.5 (a repeated time stamp: old value, then new) on a 1 ms grid
    with one extra row 0.5 us after the step, and a result whose step is 1 us late."""
    times = np.sort(np.concatenate([np.linspace(0.0, 1.0, 1001), [0.5, 0.5 + 0.5e-6]]))
    reference = (times >= 0.5).astype(float)
    reference[np.searchsorted(times, 0.5)] = 0.0  # the first of the two rows at 0.5: before the step
    late = (times >= 0.5 + 1e-6).astype(float)
    return times, reference, late


def test_a_step_1us_late_passes_with_a_time_tolerance_and_fails_without():
    times, reference, late = step_case()
    (row,) = compare(times, {"y": reference}, {"y": late}, ttol=2e-6)
    assert row.passed, row
    (row,) = compare(times, {"y": reference}, {"y": late}, ttol=0.0)
    assert not row.passed
    assert row.figure.startswith("y: 0.999 outside at t = 0.5000005 s (tube ±0.001)")
    # the repeated time stamp is a jump: both values belong to the tube there, even at ttol 0
    lo, hi = tube(times, reference, 0.0)
    k = np.searchsorted(times, 0.5)
    assert (lo[k], hi[k], lo[k + 1], hi[k + 1]) == (0.0, 1.0, 0.0, 1.0)


def test_a_zero_crossing_fails_a_relative_only_tolerance_and_passes_with_the_nominal_floor():
    times = np.linspace(0.0, 1.0, 1001)
    reference = np.sin(2 * math.pi * times)
    result = reference + 1e-5  # an offset far below the signal's size
    (relative_only,) = compare(times, {"y": reference}, {"y": result}, atol=0.0, rtol=1e-3, nominal={"y": 0.0})
    assert not relative_only.passed
    assert "at t = 0.5 s" in relative_only.figure or "at t = 1 s" in relative_only.figure  # where it crosses 0
    (floored,) = compare(times, {"y": reference}, {"y": result}, atol=0.0, rtol=1e-3, nominal={"y": 1.0})
    assert floored.passed, floored
    (by_range,) = compare(times, {"y": reference}, {"y": result}, atol=0.0, rtol=1e-3)  # nominal: the range, 2
    assert by_range.passed and "range 2" in by_range.figure


def test_a_one_percent_bias_fails_rtol_1e3_naming_the_variable_time_and_size():
    times = np.linspace(0.0, 1.0, 1001)
    reference = {"y": np.sin(2 * math.pi * times), "z": np.cos(2 * math.pi * times)}
    result = {"y": 1.01 * reference["y"], "z": reference["z"]}
    rows = {r.name: r for r in compare(times, reference, result, rtol=1e-3)}
    assert rows["reference: z"].passed
    y = rows["reference: y"]
    assert not y.passed
    assert y.figure == "y: 0.008 outside at t = 0.25 s (tube ±0.002)"  # 0.01 bias - 0.002 tube at the peak
    assert y.message.startswith("y leaves the tolerance tube at t = 0.25 s by 0.008: result 1.01")
    assert "(= 0 + 0.001 x max(|reference|, range 2))" in y.message


def test_a_nan_result_is_outside_and_missing_reference_samples_are_skipped():
    times = np.linspace(0.0, 1.0, 11)
    reference = np.linspace(0.0, 1.0, 11)
    reference[3] = np.nan
    result = reference.copy()
    result[3] = 123.0  # no reference there: not compared
    assert compare(times, {"y": reference}, {"y": result})[0].passed
    result[5] = np.nan
    (row,) = compare(times, {"y": reference}, {"y": result})
    assert not row.passed and "inf outside at t = 0.5 s" in row.figure


# -- the Cart FMU against the independent simulator

def write_reference(path, params=FIG3, stop=1.25):
    """Cart driven by a current held over 10 ms (1 ms rows), simulated by reference_rig: the
    reference CSV (time, I, x, v, a). Each current step is a repeated time stamp: the row
    before it (old current, the left limit of a) and the row after it."""
    grid = np.linspace(0.0, stop, int(round(stop * 1000)) + 1)
    steps = grid[:-5:10]
    current = rr.Steps(steps, np.sin(2 * math.pi / 0.63 * steps))
    left = steps[1:] - 1e-12
    evaluated = np.sort(np.concatenate([grid, left]))
    df = rr.simulate_cart(params, current, evaluated)
    lines = ["time,I,x,v,a"]
    for t, x, v, a in zip(evaluated, df["x"], df["v"], df["a"]):
        row_time = float(steps[np.argmin(np.abs(steps - t))]) if t in left else float(t)
        lines.append(f"{row_time!r},{current(t)!r},{float(x)!r},{float(v)!r},{float(a)!r}")
    path.write_text("\n".join(lines) + "\n")
    return path


@pytest.fixture(scope="module")
def cart(tmp_path_factory):
    folder = tmp_path_factory.mktemp("reference")
    return {"reference": write_reference(folder / "cart_reference.csv"),
            "fmu": write_parameterized_fmu("Cart", FIG3, folder / "Cart.fmu"),
            "heavier": write_parameterized_fmu("Cart", {**FIG3, "m_c": FIG3["m_c"] * 1.01}, folder / "Heavier.fmu"),
            "folder": folder}


def test_the_cart_matches_the_independent_reference_in_both_interfaces(cart):
    rows = run_battery(cart["fmu"], only=("reference",), reference=cart["reference"])
    assert sorted(r.name for r in rows) == sorted(f"reference: {v} {k}" for v in "xva" for k in ("CS", "ME"))
    assert all(r.passed for r in rows), [r for r in rows if not r.passed]


def test_a_cart_one_percent_heavier_fails_naming_x_and_the_plot_shows_it(cart, capsys):
    plots = cart["folder"] / "plots"
    code = main(["check", str(cart["heavier"]), "--only", "reference", "--reference", str(cart["reference"]),
                 "--plot", str(plots)])
    out = capsys.readouterr().out
    assert code == 1
    assert "FAIL  reference: x CS" in out and "FAIL  reference: x ME" in out
    assert "x leaves the tolerance tube at t = " in out
    assert (plots / "xCS.png").stat().st_size > 10_000 and (plots / "xME.png").is_file()


def test_a_bad_reference_is_bad_input(cart, tmp_path, capsys):
    wrong = tmp_path / "wrong.csv"
    wrong.write_text("time,q\n0,1\n")
    assert main(["check", str(cart["fmu"]), "--reference", str(wrong)]) == 2
    assert "wrong.csv: column 'q' is not a variable of Cart.fmu" in capsys.readouterr().err
    assert main(["check", str(cart["fmu"]), "--reference", str(cart["reference"]), "--rtol", "-1"]) == 2


# -- reference results carried by the FMU (FMI-LS-REF)

def split(reference, folder):
    """The reference CSV as two files: the stimulus (time, I) and the results (time, x, v, a)."""
    lines = [line.split(",") for line in reference.read_text().splitlines()]
    stimulus, results = folder / "stimulus.csv", folder / "results.csv"
    stimulus.write_text("\n".join(",".join(row[:2]) for row in lines) + "\n")
    results.write_text("\n".join(",".join([row[0]] + row[2:]) for row in lines) + "\n")
    return stimulus, results


def export_cart(folder, params, reference, stimulus=None):
    import json

    folder.mkdir(parents=True, exist_ok=True)
    parameters = folder / "params.json"
    parameters.write_text(json.dumps({"parameters": params}))
    args = ["export", "--params", str(parameters), "--out", str(folder), "--component", "Cart",
            "--reference", str(reference)] + (["--input", str(stimulus)] if stimulus else [])
    assert main(args) == 0
    return folder / "Cart.fmu"


def test_export_stores_the_reference_in_the_fmu_and_check_finds_and_passes_it(cart, tmp_path, capsys):
    import zipfile

    from pendfmu.export.lsref import FOLDER, MANIFEST, check_manifest

    fmu = export_cart(tmp_path, FIG3, cart["reference"])
    assert f"Cart.fmu (with the reference results in {FOLDER}/)" in capsys.readouterr().out
    with zipfile.ZipFile(fmu) as archive:
        names = {name for name in archive.namelist() if name.startswith(FOLDER)}
        manifest = archive.read(MANIFEST)
        stored = archive.read(f"{FOLDER}/Cart_out.csv").decode()
    # the layout of the FMI standard's Reference FMUs: the manifest and <Model>_out.csv, nothing else
    assert names == {MANIFEST, f"{FOLDER}/Cart_out.csv"}
    assert stored == cart["reference"].read_text()
    assert check_manifest(manifest) == []
    assert b'source="Cart_out.csv" role="result"' in manifest
    assert main(["check", str(fmu), "--only", "reference"]) == 0
    out = capsys.readouterr().out
    assert "PASS  reference: x CS" in out and "PASS  reference: a ME" in out
    assert f"[reference from the FMU: {FOLDER}/Cart_out.csv]" in out


def test_an_fmu_whose_carried_reference_was_made_at_other_parameters_fails(cart, tmp_path, capsys):
    import zipfile

    stimulus, results = split(cart["reference"], tmp_path)
    fmu = export_cart(tmp_path, {**FIG3, "m_c": FIG3["m_c"] * 1.01}, results, stimulus)  # reference at m_c, FMU not
    capsys.readouterr()
    assert main(["check", str(fmu), "--only", "reference"]) == 1
    out = capsys.readouterr().out
    assert "FAIL  reference: x CS" in out and "x leaves the tolerance tube at t = " in out
    assert "[reference from the FMU: extra/org.fmi-standard.fmi-ls-ref/Cart_out.csv]" in out
    # the stimulus travelled too, as Cart_in.csv beside Cart_out.csv: the same FMU at the
    # reference's parameters passes with it
    good = export_cart(tmp_path / "good", FIG3, results, stimulus)
    with zipfile.ZipFile(good) as archive:
        assert archive.read("extra/org.fmi-standard.fmi-ls-ref/Cart_in.csv").decode() == stimulus.read_text()
    assert main(["check", str(good), "--only", "reference"]) == 0


def test_the_manifest_is_valid_by_the_layered_standard_schema_and_the_ls_ref_rules(cart, tmp_path):
    """fmpy ships FMI 3.0's fmi3LayeredStandardManifest.xsd (the fmi-ls attributes every
    layered standard's manifest root carries); the root and its Related entries are checked
    by check_manifest (root fmiReferences, fixed name and description, source and a role
    from the standard's list)."""
    import zipfile

    import fmpy
    from lxml import etree

    from pendfmu.export.lsref import MANIFEST, check_manifest

    fmu = export_cart(tmp_path, FIG3, cart["reference"])
    with zipfile.ZipFile(fmu) as archive:
        manifest = archive.read(MANIFEST)
    ls_schema = Path(fmpy.__file__).parent / "schema" / "fmi3" / "fmi3LayeredStandardManifest.xsd"
    wrapper = tmp_path / "manifest.xsd"  # the root element with the layered standards' attribute group
    wrapper.write_text(f"""<?xml version="1.0" encoding="UTF-8"?>
<xs:schema xmlns:xs="http://www.w3.org/2001/XMLSchema" xmlns:fmi-ls="http://fmi-standard.org/fmi-ls-manifest">
  <xs:import namespace="http://fmi-standard.org/fmi-ls-manifest" schemaLocation="{ls_schema.as_uri()}"/>
  <xs:element name="fmiReferences"><xs:complexType>
    <xs:sequence><xs:element name="Related" minOccurs="0" maxOccurs="unbounded"><xs:complexType>
      <xs:attribute name="source" type="xs:anyURI" use="required"/>
      <xs:attribute name="role" type="xs:string" use="required"/>
      <xs:attribute name="type" type="xs:string"/><xs:attribute name="description" type="xs:string"/>
    </xs:complexType></xs:element></xs:sequence>
    <xs:attributeGroup ref="fmi-ls:ALayeredStandardManifest"/>
  </xs:complexType></xs:element>
</xs:schema>
""")
    schema = etree.XMLSchema(etree.parse(str(wrapper)))
    assert schema.validate(etree.fromstring(manifest)), schema.error_log
    assert check_manifest(manifest) == []
    broken = manifest.replace(b'role="result"', b'role="expected"').replace(b"org.fmi-standard.fmi-ls-ref", b"x")
    assert check_manifest(broken) == ["fmi-ls:fmi-ls-name is 'x', must be 'org.fmi-standard.fmi-ls-ref'",
                                      "Related 'Cart_out.csv': role 'expected' is not one of the standard's"]


def test_the_stimulus_can_come_from_input_and_export_misuse_is_bad_input(cart, tmp_path, capsys):
    stimulus, results = split(cart["reference"], tmp_path)
    assert main(["check", str(cart["fmu"]), "--only", "reference", "--reference", str(results),
                 "--input", str(stimulus)]) == 0
    assert "PASS  reference: a CS" in capsys.readouterr().out
    parameters = tmp_path / "p.json"
    parameters.write_text('{"parameters": {"m_c": 0.5}}')
    base = ["export", "--params", str(parameters), "--out", str(tmp_path / "out"), "--component", "Cart"]
    assert main(base + ["--input", str(stimulus)]) == 2
    assert "--input needs --reference" in capsys.readouterr().err
    foreign = tmp_path / "foreign.csv"
    foreign.write_text("time,theta\n0,1\n")
    assert main(base + ["--reference", str(foreign)]) == 2
    assert "its columns are not all variables of any exported FMU" in capsys.readouterr().err


def test_a_broken_manifest_in_the_fmu_is_a_failed_row(cart, tmp_path, capsys):
    import zipfile

    from pendfmu.export.lsref import MANIFEST

    fmu = export_cart(tmp_path, FIG3, cart["reference"])
    broken = tmp_path / "Broken.fmu"
    with zipfile.ZipFile(fmu) as src, zipfile.ZipFile(broken, "w") as dst:
        for info in src.infolist():
            data = src.read(info)
            dst.writestr(info, data.replace(b'role="result"', b'role="expected"') if info.filename == MANIFEST else data)
    capsys.readouterr()
    assert main(["check", str(broken), "--only", "reference"]) == 1
    out = capsys.readouterr().out
    assert "FAIL  reference: FMI-LS-REF" in out and "role 'expected' is not one of the standard's" in out


def test_the_layout_pendfmu_wrote_before_is_still_read(cart, tmp_path, capsys):
    """pendfmu 0.x stored reference.csv (role result), stimulus.csv (role other) and an
    experiments.xml pairing them (role experiment/validation): still found and compared,
    the stimulus with it (the Cart at m_c 1 % heavier fails against it, at m_c passes)."""
    from pendfmu.export.lsref import FOLDER, MANIFEST, _replace_folder, manifest_xml

    stimulus, results = split(cart["reference"], tmp_path)
    experiments = (b'<Experiments name="pendfmu export"><Experiment name="reference" startTime="0" stopTime="1.25">'
                   b'<Stimuli source="stimulus.csv" type="text/csv"/><References source="reference.csv" '
                   b'type="text/csv"/></Experiment></Experiments>')
    old = {MANIFEST: manifest_xml([("experiments.xml", "experiment/validation", "application/xml", "the experiment"),
                                   ("reference.csv", "result", "text/csv", "reference results"),
                                   ("stimulus.csv", "other", "text/csv", "stimulus")]),
           f"{FOLDER}/experiments.xml": experiments, f"{FOLDER}/reference.csv": results.read_bytes(),
           f"{FOLDER}/stimulus.csv": stimulus.read_bytes()}
    for params, expected in ((FIG3, 0), ({**FIG3, "m_c": FIG3["m_c"] * 1.01}, 1)):
        fmu = export_cart(tmp_path / str(expected), params, results)
        _replace_folder(fmu, old)
        capsys.readouterr()
        assert main(["check", str(fmu), "--only", "reference"]) == expected
        out = capsys.readouterr().out
        assert f"[reference from the FMU: {FOLDER}/reference.csv]" in out
        assert ("FAIL  reference: x CS" in out) == bool(expected) and "note" not in out


def test_a_carried_reference_is_read_as_far_as_it_fits_and_the_rest_is_a_warning(cart, tmp_path, capsys):
    """A carried reference is the FMU's own: a manifest without the schema's description
    (as the Reference FMUs ship it), a file it names that the FMU lacks, a column that names
    no variable and one that is not a number are notes (a WARN row); the columns that fit
    are compared, a Boolean column of true/false among them."""
    from pendfmu.export.lsref import FOLDER, MANIFEST, _replace_folder

    from pendfmu.check.fmu import Target
    from pendfmu.check.reference import read_reference_csv, run_on_grid

    stimulus, results = split(cart["reference"], tmp_path)
    grid = read_reference_csv(cart["reference"], Target(cart["fmu"]))
    grid.outputs = {"stuck": grid.outputs["x"]}
    stuck = run_on_grid(Target(cart["fmu"]), "CS", grid)["stuck"]  # the FMU's own, written as true/false
    assert 0 < stuck.sum() < len(stuck)
    lines = results.read_text().splitlines()
    extended = [lines[0] + ",q,stuck"] + [f"{line},abc,{'true' if s else 'false'}" for line, s in zip(lines[1:], stuck)]
    manifest = (b'<?xml version="1.0" encoding="UTF-8"?>\n<fmiReferences '
                b'xmlns:fmi-ls="http://fmi-standard.org/fmi-ls-manifest" fmi-ls:fmi-ls-name="org.fmi-standard.fmi-ls-ref" '
                b'fmi-ls:fmi-ls-version="1.0.0-alpha.1">\n'
                b'<Related type="text/csv" source="Cart_out.csv" role="result" description="Output"/>\n'
                b'<Related type="text/csv" source="Gone_out.csv" role="result" description="Output"/>\n'
                b'</fmiReferences>\n')
    fmu = export_cart(tmp_path, FIG3, results)
    _replace_folder(fmu, {MANIFEST: manifest, f"{FOLDER}/Cart_out.csv": "\n".join(extended).encode(),
                          f"{FOLDER}/Cart_in.csv": stimulus.read_bytes()})
    capsys.readouterr()
    assert main(["check", str(fmu), "--only", "reference"]) == 0
    out = capsys.readouterr().out
    assert "WARN  reference: FMI-LS-REF" in out and "3 notes" in out
    assert "no fmi-ls:fmi-ls-description attribute" in out
    assert "names 'Gone_out.csv' (result), which the FMU does not contain" in out
    assert "column q: not variables of Cart.fmu, not compared" in out
    assert "PASS  reference: stuck CS" in out and "PASS  reference: x ME" in out


def test_a_users_fmu_exported_with_fmu_carries_the_reference_and_is_checked_as_described(tmp_path, capsys):
    """`pendfmu export --fmu`: the copy's XML carries the new start values, its binary its
    compiled defaults; check sets the declared start values, so a copy exported at m = 1.02
    against a reference made at m = 1 fails on x, one exported at m = 1 passes."""
    from foreign.build import build

    from pendfmu.check.fmu import Target
    from pendfmu.check.reference import Reference, run_on_grid

    fmu = build("ForeignCart", tmp_path)  # a C FMU that does not use pendfmu's framework; m = 1 by default
    times = np.linspace(0.0, 1.0, 1001)
    force = np.where(times < 0.5, 1.5, -1.5)
    run = run_on_grid(Target(fmu), "CS", Reference(times, {"u": force}, {"x": times, "v": times}, "made here"))
    reference = tmp_path / "reference.csv"
    reference.write_text("time,u,x,v\n" + "".join(f"{float(t)!r},{float(u)!r},{float(x)!r},{float(v)!r}\n"
                                                 for t, u, x, v in zip(times, force, run["x"], run["v"])))
    for mass, expected in ((1.0, 0), (1.02, 1)):
        folder = tmp_path / f"m{mass}"
        folder.mkdir()
        (folder / "p.json").write_text(f'{{"parameters": {{"m": {mass}}}}}')
        assert main(["export", "--fmu", str(fmu), "--params", str(folder / "p.json"), "--out", str(folder),
                     "--reference", str(reference)]) == 0
        capsys.readouterr()
        assert main(["check", str(folder / "ForeignCart.fmu"), "--only", "reference"]) == expected
        out = capsys.readouterr().out
        assert ("FAIL  reference: x CS" in out) == bool(expected), out
