"""`pendfmu report A.json [B.json]`: one result re-rendered, or two compared
(pendfmu/report/compare.py, pendfmu/cli/report.py)."""

from __future__ import annotations

import math
from dataclasses import replace

import pytest

from pendfmu.cli import main
from pendfmu.report.compare import SIGNIFICANT, difference
from test_report import Page, cart_result, estimate, without_library


def test_difference_in_units_of_the_combined_standard_error():
    assert difference(1.0, 0.3, 2.0, 0.4) == pytest.approx((1.0, 0.5, 2.0))  # 3-4-5
    assert difference(2.0, 0.4, 1.0, 0.3) == pytest.approx((-1.0, 0.5, -2.0))
    assert difference(1.0, None, 4.0, 1.5) == pytest.approx((3.0, 1.5, 2.0))  # one error known
    assert difference(1.0, None, 4.0, None) == (3.0, None, None)
    assert difference(1.0, 0.0, 1.0, 0.0) == (0.0, 0.0, 0.0)
    assert difference(1.0, 0.0, 2.0, 0.0)[2] == math.inf
    assert difference(None, 0.1, 2.0, 0.1) == (None, None, None)
    assert difference(float("nan"), 0.1, 2.0, 0.1) == (None, None, None)


def writable():
    """cart_result as a fit writes it: an undefined standard error is None (JSON has no NaN)."""
    first = cart_result()
    first.estimates["F_Kc"].stderr = None
    return first


def refit():
    """cart_result with k_fwc moved by 1.5 (combined error 0.5 * sqrt 2: 2.12 of them) and
    eta unchanged, and a known value changed."""
    first = writable()
    estimates = dict(first.estimates)
    estimates["k_fwc"] = estimate("k_fwc", 31.5, 0.5)
    return replace(first, estimates=estimates, parameters={**first.parameters, "k_fwc": 31.5, "m_c": 3.2})


@pytest.fixture
def files(tmp_path):
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    writable().write_json(a)
    refit().write_json(b)
    return a, b


def test_two_results_compared_side_by_side(files, tmp_path):
    a, b = files
    assert main(["report", str(a), str(b), "--out", str(tmp_path / "cmp")]) == 0
    text = (tmp_path / "cmp" / "index.html").read_text(encoding="utf-8")
    page = Page(text)
    header = next(r for r in page.rows if r and r[0] == "name" and "combined stderr" in r)
    k_fwc = next(r for r in page.rows if r and r[0] == "k_fwc" and len(r) == len(header))
    assert k_fwc[header.index("a")] == "30" and k_fwc[header.index("b")] == "31.5"
    assert float(k_fwc[header.index("difference [stderr]")]) == pytest.approx(1.5 / math.sqrt(0.5), abs=5e-3)  # printed to 3 digits
    assert 1.5 / math.sqrt(0.5) > SIGNIFICANT and '<td class="num differs">2.12</td>' in text
    eta = next(r for r in page.rows if r and r[0] == "eta" and len(r) == len(header))
    assert float(eta[header.index("difference [stderr]")]) == 0.0
    assert next(r for r in page.rows if r and r[0] == "m_c" and len(r) == 4)[2:] == ["3", "3.2"]
    # both files hold the same two recordings: one overlaid plot each, the second result in its own trace
    assert page.plots == ["compare-01", "compare-02"]
    assert '"name":"b x"' in without_library(text)


def test_one_result_is_re_rendered(files, tmp_path):
    assert main(["report", str(files[0]), "--out", str(tmp_path / "again")]) == 0
    page = Page((tmp_path / "again" / "index.html").read_text(encoding="utf-8"))
    assert page.plots == ["fit-01", "fit-02"] and page.row("k_fwc")[1] == "30"


@pytest.mark.parametrize("make, message", [
    (lambda d: d / "missing.json", "missing.json: cannot read"),
    (lambda d: (d / "p.json").write_text('{"parameters": {"m_c": 3}}') and d / "p.json", "p.json: not a result"),
    (lambda d: (d / "t.txt").write_text("m_c = 3") and d / "t.txt", "t.txt: not a result file (not valid JSON"),
])
def test_bad_input_is_a_clear_error_before_any_work(files, tmp_path, capsys, make, message):
    out = tmp_path / "never"
    assert main(["report", str(files[0]), str(make(tmp_path)), "--out", str(out)]) == 2
    error = capsys.readouterr().err
    assert error.startswith("pendfmu report: error: ") and message in error and error.count("\n") == 1
    assert not out.exists()


def test_more_than_two_results_is_a_usage_error(files, tmp_path, capsys):
    assert main(["report", *map(str, files), str(files[0]), "--out", str(tmp_path / "x")]) == 2
    assert "one result file or two" in capsys.readouterr().err
