"""The fit report: a self-contained HTML page with interactive plots and friction PNGs
(pendfmu.report).

Results are built by hand, so these tests do not fit anything; one integration test
writes the report of a real (quick) current-loop fit. The page in a browser is
tests/test_report_browser.py; the envelope, the manifest and the comparison have tests
of their own (test_report_envelope.py, test_report_files.py, test_report_compare.py).
"""

from __future__ import annotations

import hashlib
import html
import math
import time
from dataclasses import replace
from html.parser import HTMLParser

import numpy as np
import pytest

from pendfmu.fitting.identification import fit
from pendfmu.report import write_report
from pendfmu.report.figures import friction_figure
from pendfmu.fitting.result import Estimate, ExperimentFit, FitResult
from pendfmu.friction import PENDULUM
from pendfmu.virtual_rig import Trial, steps, write_experiments

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
VOID = {"meta", "img", "br", "hr", "link", "input", "col", "source", "wbr"}
STRANGE = "phi0[run <1> & co]"  # a per-recording label from a file name with markup characters
BOUND_FLAG = ("bounded only: every T_Sp in [0.0015, 0.006] N.m gives the same free decay (the swing sticks at "
              "the first turning point where |T_A| <= T_Sp)")


class Page(HTMLParser):
    """What the tests read from the page: image sources, table rows as cell texts, and
    whether every element is closed in order (a cheap well-formedness check)."""

    def __init__(self, text: str):
        super().__init__(convert_charrefs=True)
        self.images: list[str] = []
        self.scripts: list[dict] = []
        self.plots: list[str] = []  # the ids of the interactive plots' elements
        self.links: list[str] = []
        self.rows: list[list[str]] = []
        self.open: list[str] = []
        self.errors: list[str] = []
        self.doctype = ""
        self._cell: list[str] | None = None
        self.feed(text)
        self.close()

    def handle_decl(self, decl):
        self.doctype = decl

    def handle_starttag(self, tag, attrs):
        if tag == "img":
            self.images.append(dict(attrs)["src"])
        if tag == "script":
            self.scripts.append(dict(attrs))
        if tag == "div" and "plotly-graph-div" in (dict(attrs).get("class") or ""):
            self.plots.append(dict(attrs)["id"])
        if tag == "link":
            self.links.append(dict(attrs).get("href", ""))
        if tag == "tr":
            self.rows.append([])
        if tag in ("td", "th"):
            self._cell = []
        if tag not in VOID:
            self.open.append(tag)

    def handle_endtag(self, tag):
        if not self.open or self.open[-1] != tag:
            self.errors.append(f"</{tag}> closes {self.open[-1:] or 'nothing'}")
            return
        self.open.pop()
        if tag in ("td", "th") and self._cell is not None:
            self.rows[-1].append("".join(self._cell).strip())
            self._cell = None

    def handle_data(self, data):
        if self._cell is not None:
            self._cell.append(data)

    def row(self, first: str) -> list[str]:
        return next(r for r in self.rows if r and r[0] == first)


def without_library(text: str) -> str:
    """The page without the inlined plotly.js (the first script): the rest is pendfmu's."""
    start = text.index("<script")
    return text[:start] + text[text.index("</script>", start) + len("</script>"):]


def experiment(name: str, signal: str, resolution: float | None, n: int = 300) -> ExperimentFit:
    time_ = np.linspace(0.0, 1.0, n)
    truth = np.sin(2 * np.pi * time_)
    recorded = np.round(truth / resolution) * resolution if resolution else truth + 0.01
    return ExperimentFit(name, time_, {signal: recorded}, {signal: truth},
                         {signal: resolution} if resolution else {})


def estimate(label: str, value: float, stderr: float | None, flags: list[str] | None = None,
             ci95: tuple[float, float] | None = None) -> Estimate:
    if ci95 is None and stderr is not None and math.isfinite(stderr):
        ci95 = (value - 1.96 * stderr, value + 1.96 * stderr)
    return Estimate(label, value, stderr, ci95, 0.0, 10 * value or 1.0, flags or [])


def result(stage: str, estimates: list[Estimate], experiments: list[ExperimentFit],
           parameters: dict[str, float] | None = None, notes: list[str] | None = None) -> FitResult:
    labels = [e.label for e in estimates]
    correlation = {a: {b: (1.0 if a == b else -0.5) for b in labels} for a in labels}
    values = {"m_c": 3.0, "k_M": 0.06, **{e.label: e.value for e in estimates if "[" not in e.label},
              **(parameters or {})}
    signals = {s for e in experiments for s in e.recorded}
    return FitResult(stage, values, {e.label: e for e in estimates}, correlation, 12.5,
                     {s: 0.01 for s in signals}, 42, 0, 1.25, experiments, {}, notes or [])


def current_result() -> FitResult:
    return result("current", [estimate("T_i", 3e-4, 2e-6), estimate("dIdt_max", 2500.0, 10.0)],
                  [experiment("current-steps", "I", 0.0048828125)],
                  notes=["PWM ripple found in the residual near 2000 Hz and fitted"])


def cart_result() -> FitResult:
    return result("cart", [
        estimate("eta", 0.4, 0.01),
        estimate("k_fwc", 30.0, 0.5),
        estimate("F_Kc", 8.0, float("nan"), ["the recordings do not depend on it (zero sensitivity): "
                                              "not identifiable here"]),
        estimate("F_Sc", 12.0, 0.2, ["correlated +0.980 with F_Kc: only a combination of the two is determined"]),
    ], [experiment("cart-startup", "x", 9.765913e-6), experiment("cart-ramp", "x", None)])


def pendulum_result() -> FitResult:
    return result("pendulum", [
        estimate("k_fwp", 1e-3, 1e-5),
        estimate("T_Kp", 2e-3, 2e-5, ["at its lower bound 1e-07: the optimum may lie beyond; widen the bounds "
                                      "(--bounds) or check the model"]),
        estimate("T_Sp", 2e-3, None, [BOUND_FLAG], ci95=(0.0015, 0.006)),
        estimate(STRANGE, 3.74, 1e-4, ["a flag with <markup> & \"quotes\""]),
    ], [experiment("run <1> & co $\\frac{$", "phi", 2 * math.pi / 1024, n=5000)],
        notes=["T_Sp is set-identified by the free decay: [0.0015, 0.006] N.m", "<script>alert(1)</script>"])


def all_result() -> FitResult:
    parts = [current_result(), cart_result(), pendulum_result()]
    combined = FitResult(
        "all", {k: v for r in parts for k, v in r.parameters.items()},
        {k: e for r in parts for k, e in r.estimates.items()},
        {k: c for r in parts for k, c in r.correlation.items()}, sum(r.cost for r in parts),
        {f"{r.stage}.{s}": v for r in parts for s, v in r.nrmse.items()}, 126, 1, 3.75,
        [e for r in parts for e in r.experiments], {}, [f"{r.stage}: {n}" for r in parts for n in r.notes])
    return combined


RESULTS = {"current": current_result, "cart": cart_result, "pendulum": pendulum_result, "all": all_result}


@pytest.fixture(scope="module")
def reports(tmp_path_factory):
    """Each hand-built result's report, written once for the module: stage -> (result,
    index.html path, its text, the parsed page)."""
    written = {}
    for stage, make in RESULTS.items():
        fitted = make()
        index = write_report(fitted, tmp_path_factory.mktemp(f"report-{stage}"))
        text = index.read_text(encoding="utf-8")
        written[stage] = fitted, index, text, Page(text)
    return written


@pytest.fixture(params=list(RESULTS))
def report(request, reports):
    return reports[request.param]


def test_report_is_index_html_with_a_plot_per_recording_and_the_pngs_it_shows(report):
    fitted, index, _, page = report
    assert index.name == "index.html"
    assert page.plots == [f"fit-{k:02d}" for k in range(1, len(fitted.experiments) + 1)]
    for source in page.images:
        path = index.parent / source
        assert path.parent == index.parent, "figures lie beside the page"
        assert path.read_bytes()[:8] == PNG_MAGIC


def test_page_is_well_formed_html5_and_needs_no_network(report):
    """plotly.js is inlined: no script, style sheet or image is loaded from anywhere."""
    _, _, text, page = report
    assert page.doctype.lower() == "doctype html"
    assert not page.errors and not page.open
    assert '<meta charset="utf-8">' in text and "<title>" in text and '<html lang="en">' in text
    assert page.scripts and not any("src" in attributes for attributes in page.scripts)
    assert not page.links and "@import" not in text.split("<script", 1)[0]
    assert all(not source.startswith(("http:", "https:", "//")) for source in page.images)
    assert "<noscript>" in text  # what a reader without JavaScript is told


def test_every_estimate_label_and_flag_appears_escaped(report):
    fitted, _, text, _ = report
    for label, found in fitted.estimates.items():
        assert html.escape(label) in text
        for flag in found.flags:
            assert html.escape(flag) in text
    for note in fitted.notes:
        assert html.escape(note) in text


def test_flagged_rows_are_highlighted(report):
    fitted, _, text, _ = report
    assert text.count('<tr class="flagged">') == sum(1 for e in fitted.estimates.values() if e.flags)


def test_missing_and_nan_stderr_render_as_a_dash(reports):
    page = reports["all"][3]
    header = next(r for r in page.rows if "stderr" in r)
    stderr, relative = header.index("stderr"), header.index("stderr %")
    for label in ("F_Kc", "T_Sp"):  # NaN, None
        row = page.row(label)
        assert row[stderr] == "—" and row[relative] == "—"
    assert page.row("T_Sp")[header.index("interval")].startswith("[0.0015, 0.006]")
    assert page.row("k_fwc")[stderr] == "0.5" and page.row("k_fwc")[relative] == "1.67"


def test_markup_in_names_notes_and_flags_is_escaped(reports):
    _, index, text, _ = reports["pendulum"]
    text = without_library(text)  # plotly.js's own code has markup in its strings
    assert STRANGE not in text and html.escape(STRANGE) in text
    assert "run <1>" not in text and "<markup>" not in text and "<script>alert" not in text
    assert "<h3>run &lt;1&gt; &amp; co $\\frac{$</h3>" in text  # the plot's heading shows it as typed


def test_friction_curve_figures_follow_the_fitted_joints(report):
    expected = {"current": set(), "cart": {"friction-cart.png"}, "pendulum": {"friction-pendulum.png"},
                "all": {"friction-cart.png", "friction-pendulum.png"}}
    fitted, _, _, page = report
    assert {s for s in page.images if s.startswith("friction-")} == expected[fitted.stage]


def test_friction_curve_shades_a_bounded_stiction_and_draws_the_spike():
    figure = friction_figure(pendulum_result(), PENDULUM)
    axis = figure.axes[0]
    labels = [text.get_text() for text in figure.legends[0].get_texts()]
    assert any(label.startswith("T_Sp bounded only: [0.0015, 0.006]") for label in labels)
    spike = next(line for line in axis.get_lines() if line.get_label().startswith("stuck"))
    assert list(spike.get_xdata()) == [0, 0] and list(spike.get_ydata()) == pytest.approx([-2e-3, 2e-3])
    assert len(axis.collections) == 2  # the band above and below zero


def test_known_parameters_table_and_rms_in_sensor_steps(reports):
    page = reports["cart"][3]
    known = page.row("m_c")
    header = next(r for r in page.rows if r and r[0] == "name" and "FMU" in r)
    assert [known[header.index(c)] for c in ("value", "unit")] == ["3", "kg"]
    assert "Cart" in known[header.index("FMU")]
    header = next(r for r in page.rows if r and r[0] == "recording")
    startup = next(r for r in page.rows if r[:2] == ["cart-startup", "x"])
    assert 0.1 < float(startup[header.index("RMS error [steps]")]) < 0.5  # rounding: ~0.29 steps
    ramp = next(r for r in page.rows if r[:2] == ["cart-ramp", "x"])
    assert ramp[header.index("RMS error [steps]")] == "—"  # resolution not stated


def test_a_stage_without_recordings_or_estimates_still_reports(tmp_path):
    empty = replace(current_result(), estimates={}, correlation={}, experiments=[], nrmse={})
    page = Page(write_report(empty, tmp_path / "empty").read_text(encoding="utf-8"))
    assert not page.errors and page.images == []


SHORT_CURRENT = [Trial("current", "current", 0.004, 20e-6, ("I_c", "I"), steps((0, 0.0), (1e-3, 2.0)))]


def test_report_of_a_real_current_fit(tmp_path):
    started = time.perf_counter()
    write_experiments(tmp_path / "rig", seed=3, experiments=SHORT_CURRENT)
    fitted = fit("current", [tmp_path / "rig" / "current.csv"], seed=1, progress=False)
    index = write_report(fitted, tmp_path / "report")
    assert time.perf_counter() - started < 20
    text = index.read_text(encoding="utf-8")
    page = Page(text)
    assert page.images == ["diagnostics-01.png"] and page.plots == ["fit-01"]  # no friction curve
    assert fitted.experiments[0].resolution == {"I": pytest.approx(20 / 4096)}
    header = next(r for r in page.rows if r and r[0] == "recording")
    row = next(r for r in page.rows if r[:2] == ["current", "I"])
    steps_rms = float(row[header.index("RMS error [steps]")])
    assert 0.2 < steps_rms < 10  # noise, ripple and quantization, a few ADC steps at most
    for label in ("T_i", "dIdt_max"):
        assert page.row(label)[2] in ("s", "A/s")
    # the cost explained: one signal, so the RMS of the scaled residuals from the cost
    # (sqrt(2 cost / N)) is that signal's RMS error over its error scale, from the arrays
    summary = next(r for r in page.rows if r and r[0] == "current" and len(r) == 6)
    from_cost = float(summary[2])
    from_arrays = float(row[header.index("RMS error [σ]")])
    assert from_cost == pytest.approx(from_arrays, rel=2e-3)
    # provenance: the recording's sha256 as hashlib computes it, the seed, the free set
    csv = tmp_path / "rig" / "current.csv"
    assert hashlib.sha256(csv.read_bytes()).hexdigest() in text
    assert "Provenance" in text and page.row("seed")[1] == "1"
    bounds = fitted.provenance["stages"]["current"]["bounds"]["T_i"]
    free = next(r for r in page.rows if r and r[0] == "T_i" and len(r) == 4)  # free parameter, start, bounds, unit
    assert free[2] == f"[{bounds[0]:.4g}, {bounds[1]:.4g}]" and free[3] == "s"
