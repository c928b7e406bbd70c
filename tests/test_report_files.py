"""The report's files and the result file behind it: a reused report folder loses the
earlier report's files but keeps the user's (manifest.py); a result file carries its
recordings and provenance and reads back (result.read_result), old files included; and
the page shows the values each recording actually ran with."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest

from pendfmu.errors import BadInput
from pendfmu.fitting.result import ExperimentFit, read_result
from pendfmu.report import write_report
from pendfmu.report.content import signal_errors
from pendfmu.report.manifest import MANIFEST
from test_report import Page, cart_result, current_result, estimate, experiment, pendulum_result, result


def test_a_reused_folder_loses_the_earlier_reports_files_and_keeps_the_users(tmp_path):
    folder = tmp_path / "report"
    write_report(cart_result(), folder)
    assert (folder / "friction-cart.png").exists()
    (folder / "notes.txt").write_text("mine")
    (folder / "sub").mkdir()
    (folder / "sub" / "friction-cart.png").write_text("mine too")
    write_report(current_result(), folder)  # no friction curve
    assert not (folder / "friction-cart.png").exists()
    assert (folder / "notes.txt").read_text() == "mine" and (folder / "sub" / "friction-cart.png").exists()
    assert json.loads((folder / MANIFEST).read_text())["files"] == ["diagnostics-01.png", "index.html"]


def test_a_manifest_never_removes_what_lies_outside_the_folder_or_in_a_sub_folder(tmp_path):
    folder, outside = tmp_path / "report", tmp_path / "outside.txt"
    folder.mkdir()
    (folder / "sub").mkdir()
    for path in (outside, folder / "sub" / "x.png", folder / "listed.png"):
        path.write_text("x")
    (folder / MANIFEST).write_text(json.dumps({"kind": "pendfmu report", "files": [
        "../outside.txt", str(outside), "sub/x.png", "sub", ".", "listed.png", 7]}))
    write_report(current_result(), folder)
    assert outside.exists() and (folder / "sub" / "x.png").exists()
    assert not (folder / "listed.png").exists()  # a plain name it listed: its own


def test_a_foreign_or_broken_manifest_removes_nothing(tmp_path):
    folder = tmp_path / "report"
    folder.mkdir()
    (folder / "a.png").write_text("x")
    figureless = replace(current_result(), experiments=[])  # a figure of its own would be foreign the next time
    for text in ('{"kind": "other tool", "files": ["a.png"]}', "not json", '["a.png"]'):
        (folder / MANIFEST).write_text(text)
        write_report(figureless, folder)
        assert (folder / "a.png").exists()


def test_a_report_written_before_the_manifest_is_recognized_by_its_page(tmp_path):
    folder = tmp_path / "report"
    folder.mkdir()
    shown = ("fit-01-run1.png", "friction-cart.png", "photo.png")
    (folder / "index.html").write_text("<title>pendfmu fit report: stage cart</title>"
                                       + "".join(f'<img src="{name}">' for name in shown))
    for name in (*shown, "fit-02-not-shown.png"):
        (folder / name).write_text("x")
    write_report(current_result(), folder)
    assert not (folder / "fit-01-run1.png").exists() and not (folder / "friction-cart.png").exists()
    assert (folder / "photo.png").exists() and (folder / "fit-02-not-shown.png").exists()


def long_experiment(name: str, samples: int = 30_000) -> ExperimentFit:
    time = np.linspace(0.0, 30.0, samples)
    truth = np.exp(-time / 10) * np.sin(6 * time)
    step = 2 * math.pi / 1024
    recorded = np.round(truth / step) * step
    recorded[777] += 40 * step  # a glitch the stored envelope must keep
    recorded[5000] = np.nan  # a missing reading
    return ExperimentFit(name, time, {"phi": recorded}, {"phi": truth}, {"phi": step}, {"phi": step / math.sqrt(12)},
                         {"m_p": 0.0, "phi0": 3.6}, {"m_p": 0.0})


def round_trip(fitted, path):
    fitted.write_json(path)
    return read_result(path)


def test_the_result_file_reads_back_with_its_recordings_and_provenance(tmp_path):
    original = replace(pendulum_result(), experiments=[long_experiment("decay")],
                       provenance={"seed": 4, "stages": {"pendulum": {"bounds": {"k_fwp": [1e-5, 0.1]}}}},
                       initial={"decay": {"phi0": 3.6}})
    back = round_trip(original, tmp_path / "r.json")
    assert back.stage == original.stage and back.cost == original.cost and back.provenance == original.provenance
    for label, estimate_ in original.estimates.items():
        if "[" in label:
            continue
        other = back.estimates[label]
        assert (other.value, other.stderr, other.ci95, other.flags, other.method) == (
            estimate_.value, estimate_.stderr, estimate_.ci95, estimate_.flags, estimate_.method)
    assert back.estimates["k_fwp"].low == 1e-5  # bounds come back from the provenance
    fit, stored = original.experiments[0], back.experiments[0]
    assert stored.samples == 30_000 and len(stored.time) < 6_100
    # the RMS of every sample (the missing one aside), not of the envelope; the glitch survives
    assert signal_errors(stored)[0].rms == pytest.approx(signal_errors(fit)[0].rms, rel=1e-12)
    assert np.nanmax(stored.recorded["phi"]) == np.nanmax(fit.recorded["phi"])
    assert (stored.values, stored.overrides, stored.scale) == (fit.values, fit.overrides, fit.scale)
    again = round_trip(back, tmp_path / "again.json")  # a re-read result writes the same file again
    assert (tmp_path / "again.json").read_text() == (tmp_path / "r.json").read_text()
    assert again.experiments[0].rms == stored.rms


def test_an_old_result_file_without_recordings_or_provenance_still_reads_and_reports(tmp_path):
    document = cart_result().to_dict()
    for key in ("provenance", "recordings", "predicted"):
        document.pop(key)
    path = tmp_path / "old.json"
    path.write_text(json.dumps(document))
    old = read_result(path)
    assert old.experiments == [] and old.provenance == {}
    assert old.parameters == cart_result().parameters
    text = write_report(old, tmp_path / "report").read_text(encoding="utf-8")
    assert "does not record its provenance" in text and "does not record the values per recording" in text


@pytest.mark.parametrize("content, expected", [
    (None, "cannot read"), ("{", "not valid JSON"), ('{"parameters": {"m_c": 3}}', "not a result file"),
    ('[1, 2]', "not a result file"), ('{"parameters": {}, "fit": {"stage": "cart"}, "recordings": [{}]}',
                                      "malformed")])
def test_a_file_that_is_not_a_result_is_a_clear_error(tmp_path, content, expected):
    path = tmp_path / "x.json"
    if content is not None:
        path.write_text(content)
    with pytest.raises(BadInput, match=expected) as error:
        read_result(path)
    assert str(path) in str(error.value)


def test_values_each_recording_ran_with_are_shown_and_differences_highlighted(tmp_path):
    """The issue's case: the known value m_p = 0.2, every cart recording ran with its
    sidecar's m_p = 0."""
    runs = []
    for name in ("cart-1", "cart-2"):
        run = experiment(name, "x", 1e-5)
        runs.append(replace(run, values={"m_p": 0.0, "m_c": 3.0, "x0": 0.0}, overrides={"m_p": 0.0}))
    fitted = result("cart", [estimate("k_fwc", 30.0, 0.5), estimate("v0[cart-2]", 0.01, 1e-4)], runs,
                    parameters={"m_p": 0.2})
    fitted.initial = {"cart-2": {"v0": 0.01}}
    page = Page(write_report(fitted, tmp_path / "report").read_text(encoding="utf-8"))
    header = next(r for r in page.rows if r[:3] == ["name", "unit", "result's value"])
    m_p = next(r for r in page.rows if r and r[0] == "m_p" and len(r) == len(header))
    assert m_p[2] == "0.2" and m_p[header.index("cart-1")] == "0 (sidecar)" == m_p[header.index("cart-2")]
    v0 = next(r for r in page.rows if r and r[0] == "v0" and len(r) == len(header))
    assert v0[header.index("cart-2")] == "0.01 (fitted)"
    assert not any(r and r[0] == "m_c" and len(r) == len(header) for r in page.rows)  # ran as the result says
    known = next(r for r in page.rows if r and r[0] == "m_p" and len(r) == 6)
    assert known[1] == "0.2" and known[2] == "0 in 2 of 2 recordings (sidecar)"
    text = (tmp_path / "report" / "index.html").read_text(encoding="utf-8")
    assert text.count('<td class="num differs">0 <span class="muted">(sidecar)</span></td>') == 2


def test_predicted_recordings_get_their_own_plots_and_errors(tmp_path):
    """fit all's recordings with both x and phi, predicted but not fitted: a plot each, and
    their RMS errors from the traces (not only the validation numbers)."""
    coupled = replace(long_experiment("coupled-step", 20_000), name="coupled-step")
    fitted = replace(cart_result(), predicted=[coupled, experiment("bangbang-0", "phi", 2 * math.pi / 1024)])
    page = Page(write_report(fitted, tmp_path / "report").read_text(encoding="utf-8"))
    assert page.plots == ["fit-01", "fit-02", "predicted-01", "predicted-02"]
    header = next(r for r in page.rows if r and r[0] == "recording" and "RMS error [σ]" in r)
    row = next(r for r in page.rows if r[:2] == ["coupled-step", "phi"])
    expected = signal_errors(coupled)[0]
    assert float(row[header.index("RMS error [steps]")]) == pytest.approx(expected.steps, rel=5e-3)
    assert float(row[header.index("RMS error [σ]")]) == pytest.approx(math.sqrt(12) * expected.steps, rel=5e-3)


def test_a_users_own_page_is_never_overwritten(tmp_path, capsys):
    """A folder whose index.html is the user's (not a pendfmu page, not in a manifest)
    stops the report: exit 2 from the command line, the page untouched."""
    folder = tmp_path / "site"
    folder.mkdir()
    (folder / "index.html").write_text("<html><title>my homepage</title></html>")
    with pytest.raises(BadInput, match="index.html: exists and was not written by a pendfmu report"):
        write_report(current_result(), folder)
    assert (folder / "index.html").read_text() == "<html><title>my homepage</title></html>"


def test_a_report_that_fails_to_render_leaves_the_earlier_one(tmp_path, monkeypatch):
    folder = tmp_path / "report"
    index = write_report(current_result(), folder)
    before = {p.name: p.read_bytes() for p in folder.iterdir()}

    def broken(*args, **kwargs):
        raise ValueError("arrays of different lengths")

    monkeypatch.setattr("pendfmu.report.html.page", broken)
    with pytest.raises(ValueError):
        write_report(current_result(), folder)
    assert {p.name: p.read_bytes() for p in folder.iterdir()} == before and index.is_file()
