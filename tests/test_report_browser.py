"""The report in a real browser: headless Chromium opens index.html from disk (no
network), runs plotly.js and draws every recording's plot.

Three looks, each a plain chromium command line (no driver, no DevTools client): the
console (--enable-logging=stderr prints every console message, errors included, as a
CONSOLE line), the DOM after the scripts ran (--dump-dom: plotly draws each plot as SVG
elements of class main-svg, and each curve as a path of class js-line), and a
screenshot (--screenshot: not blank). Skipped where no Chromium is installed (the
Makefile's `tools` target installs the Debian package).
"""

from __future__ import annotations

import re
import shutil
import subprocess
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

from pendfmu.fitting.identification import fit
from pendfmu.fitting.optimizer import GlobalOptions
from pendfmu.report import write_report
from pendfmu.virtual_rig import standard_experiments, write_experiments

BROWSER = next((found for name in ("chromium", "chromium-browser", "google-chrome")
                if (found := shutil.which(name))), None)
pytestmark = pytest.mark.skipif(BROWSER is None, reason="no Chromium (apt-get install chromium; make tools)")
SECONDS = 60  # per browser run; a run takes 1-6 s on a loaded two-core machine
CONSOLE = re.compile(r":CONSOLE[^\]]*\] \"(?P<message>.*)\", source: (?P<source>.*)$")


def chromium(profile: Path, *arguments: str) -> subprocess.CompletedProcess:
    command = [BROWSER, "--headless", "--disable-gpu", "--no-sandbox", "--no-first-run", "--hide-scrollbars",
               f"--user-data-dir={profile}", "--enable-logging=stderr", "--v=0", *arguments]
    return subprocess.run(command, capture_output=True, text=True, timeout=SECONDS, check=True)


def console_errors(stderr: str) -> list[str]:
    """The page's console messages that report an error (uncaught exceptions, console.error
    and failed loads all say so in their text; Chromium logs every level as INFO here)."""
    messages = [m.group("message") for line in stderr.splitlines() if (m := CONSOLE.search(line))]
    return [m for m in messages if re.search(r"error|uncaught|failed", m, re.IGNORECASE)]


class Plots(HTMLParser):
    """Per plotly plot element (id), how many main-svg layers and drawn curves it holds."""

    def __init__(self, text: str):
        super().__init__()
        self.svgs: dict[str, int] = {}
        self.curves: dict[str, int] = {}
        self._stack: list[str | None] = []
        self.feed(text)

    def handle_starttag(self, tag, attrs):
        attributes = dict(attrs)
        classes = (attributes.get("class") or "").split()
        current = next((p for p in reversed(self._stack) if p), None)
        if "plotly-graph-div" in classes:
            current = attributes["id"]
            self.svgs[current], self.curves[current] = 0, 0
        if current and "main-svg" in classes:
            self.svgs[current] += 1
        if current and tag == "path" and "js-line" in classes and len(attributes.get("d") or "") > 20:
            self.curves[current] += 1
        if tag not in ("path", "rect", "line", "circle", "image", "use", "stop", "br", "img", "meta", "input"):
            self._stack.append(current if "plotly-graph-div" in classes else None)

    def handle_endtag(self, tag):
        if tag not in ("path", "rect", "line", "circle", "image", "use", "stop", "br", "img", "meta", "input") \
                and self._stack:
            self._stack.pop()


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    """The report of a small real fit: the cart stage on two recordings whose sidecars
    say m_p = 0 (the pendulum removed), one long enough to be plotted as its envelope."""
    folder = tmp_path_factory.mktemp("browser")
    chosen = [e for e in standard_experiments() if e.name in ("cart-startup-2A", "cart-ramp")]
    write_experiments(folder / "rig", seed=5, experiments=chosen)
    fitted = fit("cart", sorted((folder / "rig").glob("cart*.csv")), progress=False,
                 global_search=GlobalOptions(enabled=False), uncertainty="jacobian")
    return fitted, write_report(fitted, folder / "report"), folder


def test_the_console_check_sees_an_error(tmp_path):
    """The check below can fail: a page with an error is caught."""
    page = tmp_path / "broken.html"
    page.write_text("<!DOCTYPE html><html><body><script>notAFunction();</script></body></html>")
    result = chromium(tmp_path / "profile", "--dump-dom", page.as_uri())
    assert any("notAFunction" in m for m in console_errors(result.stderr))


def test_every_recording_is_plotted_without_console_errors(report):
    fitted, index, folder = report
    result = chromium(folder / "profile", "--dump-dom", index.as_uri())
    assert console_errors(result.stderr) == []
    plots = Plots(result.stdout)
    expected = [f"fit-{k:02d}" for k in range(1, len(fitted.experiments) + 1)]
    assert sorted(plots.svgs) == expected
    for plot in expected:
        assert plots.svgs[plot] >= 1, f"{plot}: plotly drew nothing"
        # one signal (x): recorded, simulated and the residual
        assert plots.curves[plot] == 3, f"{plot}: {plots.curves[plot]} curves"
    text = result.stdout
    assert "Provenance" in text and "Parameter values per recording" in text
    assert re.search(r"<td class=\"num differs\">0 <span class=\"muted\">\(sidecar\)</span></td>", text)


def test_the_page_is_not_blank(report):
    from PIL import Image

    _, index, folder = report
    shot = folder / "shot.png"
    chromium(folder / "profile", "--window-size=1300,2400", f"--screenshot={shot}", index.as_uri())
    pixels = np.asarray(Image.open(shot).convert("RGB")).reshape(-1, 3)
    drawn = np.any(pixels < 245, axis=1).mean()
    colours = len(np.unique(pixels, axis=0))
    assert drawn > 0.05 and colours > 200, f"{drawn:.1%} drawn, {colours} colours"
