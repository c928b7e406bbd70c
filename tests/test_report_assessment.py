"""The report's account of whether a fit can be trusted (pendfmu/report/assessment.py):
the verdict box, the validation table, the residual diagnostics and the joint region of a
pair determined only together; and a result written before fits were assessed, which
shows none of them (no empty box).

Results are built by hand (test_report's helpers); the combination comes from
validation.separately itself, the limit from validation.moving."""

from __future__ import annotations

import html
import json
import math
from dataclasses import replace

import numpy as np
import pytest

from pendfmu.fitting.identification import fit
from pendfmu.fitting.result import Estimate, kinds, read_result
from pendfmu.fitting.statistics import Z95
from pendfmu.fitting.validation import separately
from pendfmu.report import write_report
from pendfmu.report.content import JOINT_LEVEL, joint_region, log_spread
from pendfmu.report.figures import joint_figure
from pendfmu.virtual_rig import Trial, steps, write_experiments
from test_diagnostics import long_fit
from test_report import PNG_MAGIC, Page, estimate, experiment, pendulum_result, result

RHO = -0.995


def halves_row(value: float, half_width: float) -> list[float]:
    return [value, value - half_width, value + half_width]


def movement(early: list[float], late: list[float]) -> dict:
    """validation._movement's entry, from the rows as the file stores them."""
    combined = math.hypot((early[2] - early[1]) / 2, (late[2] - late[1]) / 2)
    return {"early": early[0], "late": late[0], "ratio": abs(late[0] - early[0]) / combined,
            "direction": "rises" if late[0] > early[0] else "falls"}


def inadequate_result():
    """The issue's 66 s swing: k_fwp and T_Kp correlated -0.995 on residuals 41 times the
    noise; T_Kp falls between the halves by more than their combined interval, k_fwp does not."""
    fitted = result("pendulum", [estimate("k_fwp", 5.67e-4, 5.6e-6), estimate("T_Kp", 3.50e-3, 4.1e-5)],
                    [experiment("swing", "phi", 2 * math.pi / 40000, n=3000)])
    fitted.correlation = {"k_fwp": {"k_fwp": 1.0, "T_Kp": RHO}, "T_Kp": {"k_fwp": RHO, "T_Kp": 1.0}}
    halves = {"early": {"k_fwp": halves_row(5.60e-4, 2e-5), "T_Kp": halves_row(3.9e-3, 1e-4)},
              "late": {"k_fwp": halves_row(5.75e-4, 2e-5), "T_Kp": halves_row(3.2e-3, 1e-4)}}
    fitted.assessment = {
        "verdict": "model-inadequate", "spread": 41.0,
        "evidence": ["the residuals are 41 times the sensor noise (limit 3)",
                     "2 global searches end in the same minimum: the model cannot follow the recordings",
                     "T_Kp falls from 0.0039 (early halves) to 0.0032 (late)"],
        "windows": {"recordings": ["swing@0-33s"], "method": "fits of the halves", "halves": halves,
                    "parameters": {name: movement(halves["early"][name], halves["late"][name])
                                   for name in ("k_fwp", "T_Kp")}, "seconds": 12.5},
        "combinations": separately(fitted.estimates, fitted.correlation)}
    return fitted


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    fitted = inadequate_result()
    index = write_report(fitted, tmp_path_factory.mktemp("inadequate"))
    text = index.read_text(encoding="utf-8")
    return fitted, index, text, Page(text)


def test_the_verdict_stands_in_a_box_before_the_fit_with_its_evidence(written):
    fitted, _, text, page = written
    box = text.index('<div class="verdict verdict-model-inadequate"')
    assert box < text.index("<h2>Fit</h2>")
    end = text.index("</div>", box)
    assert "Model inadequate" in text[box:end] and "model-inadequate" in text[box:end]
    for line in fitted.assessment["evidence"]:
        assert f"<li>{html.escape(line)}</li>" in text[box:end]
    assert not page.errors and not page.open


def test_the_validation_table_shows_each_parameter_and_whether_it_moved_beyond_the_limit(written):
    fitted, _, text, page = written
    header = next(r for r in page.rows if r and r[0] == "parameter" and "direction" in r)
    moved = fitted.assessment["windows"]["parameters"]
    for name, beyond in (("T_Kp", "yes"), ("k_fwp", "no")):
        row = next(r for r in page.rows if r and r[0] == name and len(r) == len(header))
        assert float(row[header.index("moved [combined intervals]")]) == pytest.approx(moved[name]["ratio"], rel=1e-3)
        assert row[header.index("direction")] == moved[name]["direction"]
        assert row[header.index("beyond the limit")] == beyond
        assert row[header.index("early halves")].startswith(f"{moved[name]['early']:.6g} [")
    assert moved["T_Kp"]["ratio"] > 1 > moved["k_fwp"]["ratio"]  # the case is what the test says
    section = text[text.index("<h2>Validation: early against late halves</h2>"):]
    section = section[:section.index("</section>")]
    assert section.count('<tr class="flagged">') == 1 and '<tr class="flagged"><td class="name"><code>T_Kp<' in section


def test_the_residual_diagnostics_figure_and_numbers_are_in_the_report(written):
    _, index, text, page = written
    assert "<h2>Residual diagnostics</h2>" in text
    assert "diagnostics-01.png" in page.images
    assert (index.parent / "diagnostics-01.png").read_bytes()[:8] == PNG_MAGIC
    header = next(r for r in page.rows if r and r[0] == "recording" and "lag-1 autocorrelation" in r)
    row = next(r for r in page.rows if r[:2] == ["swing", "phi"] and len(r) == len(header))
    assert row[header.index("samples")] == "3000"
    assert float(row[header.index("white-noise band ±")]) == pytest.approx(Z95 / math.sqrt(3000), rel=0.01)


def test_a_pair_determined_only_together_gets_its_joint_region(written):
    fitted, index, text, page = written
    combination, = fitted.assessment["combinations"]
    assert combination["pair"] == ["k_fwp", "T_Kp"]
    assert "<h2>Determined only together</h2>" in text and "joint-01.png" in page.images
    assert (index.parent / "joint-01.png").read_bytes()[:8] == PNG_MAGIC
    assert html.escape(combination["text"]) in text


def test_the_joint_figure_draws_the_region_the_line_through_the_estimate_and_the_halves():
    fitted = inadequate_result()
    combination, = fitted.assessment["combinations"]
    figure = joint_figure(fitted, combination, fitted.assessment["windows"]["halves"])
    axis = figure.axes[0]
    assert axis.get_xscale() == axis.get_yscale() == "log"
    p, q = combination["powers"]
    assert max(p, q) == 1.0 >= min(abs(p), abs(q))  # the larger power is +1, never k_fwp^-1 * ...
    line = next(l for l in axis.get_lines() if l.get_label() == combination["text"])
    x, y = (np.asarray(v) for v in line.get_data())
    assert np.allclose(p * np.log(x) + q * np.log(y), math.log(combination["value"]))
    a, b = fitted.estimates["k_fwp"].value, fitted.estimates["T_Kp"].value
    assert p * math.log(a) + q * math.log(b) == pytest.approx(math.log(combination["value"]))
    labels = [t.get_text() for t in figure.legends[0].get_texts()]
    assert {"95 % joint region", "early halves", "late halves"} <= set(labels)
    (x0, x1), (y0, y1) = axis.get_xlim(), axis.get_ylim()
    for which in ("early", "late"):  # the halves lie inside the drawn area
        row = fitted.assessment["windows"]["halves"][which]
        assert x0 < row["k_fwp"][0] < x1 and y0 < row["T_Kp"][0] < y1


@pytest.mark.parametrize("rho", [-0.995, 0.0, 0.6])
def test_the_joint_region_projects_onto_each_axis_as_the_joint_level_times_its_spread(rho):
    """A 2-D normal's region x' C^-1 x <= r^2 reaches r sqrt(C_ii) along axis i, whatever
    the correlation; the log-scale spread comes from the 95 % interval."""
    a = estimate("k_fwp", 2e-4, None, ci95=(1e-4, 4e-4))
    b = Estimate("T_Kp", 3e-3, 3e-5, None, 0.0, 1.0)  # no interval: its standard error
    region = joint_region(a, b, rho, points=20_000)
    assert log_spread(a) == pytest.approx(math.log(4) / (2 * Z95))
    assert log_spread(b) == pytest.approx(0.01)
    for k, e in enumerate((a, b)):
        reach = region[k] - math.log(e.value)
        assert reach.max() == pytest.approx(JOINT_LEVEL * log_spread(e), rel=1e-6)
        assert reach.min() == pytest.approx(-JOINT_LEVEL * log_spread(e), rel=1e-6)
    assert JOINT_LEVEL == pytest.approx(2.4477, abs=1e-4)  # sqrt of chi-square(2)'s 95 % quantile


def test_a_sequence_shows_its_worst_verdict_and_each_stage(tmp_path):
    stage = inadequate_result()
    stage.assessment["verdict"] = "fit-failed"
    fitted = replace(pendulum_result(), stage="all",
                     assessment={"verdict": "fit-failed", "stages": {"pendulum": stage.assessment,
                                                                     "cart": {"verdict": "adequate", "spread": 1.1,
                                                                              "evidence": ["fine"]}}})
    text = write_report(fitted, tmp_path / "report").read_text(encoding="utf-8")
    box = text[text.index('<div class="verdict verdict-fit-failed"'):]
    box = box[:box.index("</div>")]
    assert "Stage pendulum: fit-failed" in box and "Stage cart: adequate" in box and "<li>fine</li>" in box
    assert "<h3>Stage pendulum</h3>" in text  # its validation table, under its stage


def test_an_old_result_without_an_assessment_renders_without_a_box(tmp_path):
    """A file written before fits were assessed, and before diagnostics were stored: no
    verdict box, no validation, no joint region; a short recording's diagnostics come from
    its arrays, a long one's envelope has none, and the page says so."""
    fitted = result("pendulum", [estimate("k_fwp", 1e-3, 1e-5)],
                    [experiment("short", "phi", 2 * math.pi / 1024), long_fit()])
    document = fitted.to_dict()
    del document["fit"]["assessment"]
    for recording in document["recordings"]:
        del recording["diagnostics"]
    path = tmp_path / "old.json"
    path.write_text(json.dumps(document))
    old = read_result(path)
    assert old.assessment == {}
    index = write_report(old, tmp_path / "report")
    text = index.read_text(encoding="utf-8")
    page = Page(text)
    assert 'class="verdict' not in text and "Validation: early" not in text and "Determined only" not in text
    assert "diagnostics-01.png" in page.images and "diagnostics-02.png" not in page.images
    assert "No diagnostics for long: the result file holds only the display envelope" in text
    assert not page.errors and not page.open


def test_the_report_of_a_real_model_inadequate_fit_and_of_its_file(tmp_path):
    """A current step whose converter leaves a 3 kHz ripple, fitted without the ripple term
    (as test_adequacy does, long enough to be split in halves): the fit marks itself
    model-inadequate, and its report, written from the fit and again from its file, shows
    the verdict, the halves of both parameters and a residual that stays correlated."""
    trial = Trial("rippled", "current", 0.024, 20e-6, ("I_c", "I"), steps((0, 0.0), (1e-3, 2.0)))
    write_experiments(tmp_path, {"a_h": 0.05, "f_h": 3000.0}, seed=4, experiments=[trial])
    fitted = fit("current", [tmp_path / "rippled.csv"], harmonic="off", seed=1, progress=False,
                 uncertainty="jacobian")
    assert fitted.assessment["verdict"] == "model-inadequate" and fitted.assessment["windows"]["halves"]
    again = read_result(fitted.write_json(tmp_path / "result.json"))
    pages = [Page(write_report(r, tmp_path / name).read_text(encoding="utf-8"))
             for r, name in ((fitted, "report"), (again, "again"))]
    for page in pages:
        assert "diagnostics-01.png" in page.images
        header = next(r for r in page.rows if r and r[0] == "parameter" and "direction" in r)
        for name in ("T_i", "dIdt_max"):  # beyond the limit as the report sees it: as the fit flagged it
            row = next(r for r in page.rows if r and r[0] == name and len(r) == len(header))
            marked = "model-inadequate" in kinds(fitted.estimates[name].flags)
            assert row[header.index("beyond the limit")] == ("yes" if marked else "no")
    rows = [next(r for r in page.rows if r[:2] == ["rippled", "I"] and len(r) == 8) for page in pages]
    assert rows[0] == rows[1]  # the file's stored diagnostics are the fit's
    length = int(rows[0][4].lstrip("≥ "))
    assert length > 100  # the ripple keeps the residual correlated (white noise: 1)


def test_predicted_recordings_are_diagnosed_after_the_fitted_ones(tmp_path):
    fitted = replace(pendulum_result(), predicted=[experiment("coupled", "phi", 2 * math.pi / 1024)])
    index = write_report(fitted, tmp_path / "report")
    page = Page(index.read_text(encoding="utf-8"))
    assert [s for s in page.images if s.startswith("diagnostics-")] == ["diagnostics-01.png", "diagnostics-02.png"]
    assert any(r[:2] == ["coupled (predicted, not fitted)", "phi"] for r in page.rows)
