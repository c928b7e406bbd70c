"""The documentation site (docs/, issue 26): it builds with no warning and every reference
resolved, as `make docs` builds it (docs/build.py, the one home of the command), into a
temporary folder; it loads nothing from outside; a browser opens its pages without console
errors; and every code block of every page is runnable or marked as not.

The code blocks follow the README's rule (tests/readme_blocks.py): sh and python blocks run,
text blocks are not run, an output block lists lines the block before it prints; a fence
with a MyST directive ({toctree}, {include}, ...) is no code, but what a page includes is
read as part of it. They run in tests/test_docs_runs.py, with the README's, in the site's
reading order in one folder (later chapters use what Getting started's walkthrough wrote),
and only there: the walkthrough's fit is minutes of CPU time, which make test pays once.
"""

from __future__ import annotations

import re
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path

import pytest

from readme_blocks import RUNNABLE, page_blocks
from test_report_browser import BROWSER, chromium, console_errors

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
PAGES = sorted(p for p in DOCS.rglob("*.md") if not {"_build", "_ext"} & set(p.relative_to(DOCS).parts))
LANGUAGES = {"", "text", "output", *RUNNABLE}


def _name(page: Path) -> str:
    return str(page.relative_to(ROOT))


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> tuple[Path, subprocess.CompletedProcess]:
    """The site built as make docs builds it, into a temporary folder (about 15 s)."""
    output = tmp_path_factory.mktemp("docs") / "html"
    built = subprocess.run([sys.executable, str(DOCS / "build.py"), str(output)], capture_output=True, text=True,
                           cwd=ROOT, timeout=600)
    return output, built


def test_the_site_builds_without_a_warning(site):
    output, built = site
    assert built.returncode == 0, \
        f"docs/build.py failed ({built.returncode}):\n{built.stdout[-4000:]}{built.stderr[-8000:]}"
    assert "WARNING" not in built.stderr and "ERROR" not in built.stderr, built.stderr[-8000:]
    for page in PAGES:  # every page is part of the site (a page outside every toctree warns)
        assert (output / page.relative_to(DOCS)).with_suffix(".html").is_file(), page


class Loads(HTMLParser):
    """Every address a page loads by itself: scripts, style sheets, images, frames."""

    def __init__(self, text: str):
        super().__init__()
        self.addresses: list[str] = []
        self.feed(text)

    def handle_starttag(self, tag, attrs):
        attributes = dict(attrs)
        if tag in ("script", "img", "iframe", "source") and attributes.get("src"):
            self.addresses.append(attributes["src"])
        if tag == "link" and attributes.get("href") and set((attributes.get("rel") or "").split()) & {
                "stylesheet", "preload", "icon", "modulepreload"}:
            self.addresses.append(attributes["href"])


def test_the_pages_load_nothing_from_outside(site):
    """Offline at view time: every script, style sheet and image is a file of the site."""
    output, built = site
    assert built.returncode == 0
    pages = sorted(output.rglob("*.html"))
    assert len(pages) >= len(PAGES)
    for page in pages:
        for address in Loads(page.read_text(encoding="utf-8")).addresses:
            assert not re.match(r"^(\w+:)?//", address), f"{page.relative_to(output)} loads {address}"
            assert (page.parent / address.split("?")[0].split("#")[0]).is_file(), f"{page}: {address} missing"


@pytest.mark.skipif(BROWSER is None, reason="no Chromium (apt-get install chromium; make tools)")
@pytest.mark.parametrize("page, shown", [("index.html", "Getting started"),
                                         ("reference/cli.html", "pendfmu fit"),
                                         ("reference/variables.html", "CurrentLoop"),
                                         ("user-guide/friction.html", "Stribeck")])
def test_a_browser_opens_the_page_without_console_errors(site, tmp_path, page, shown):
    output, built = site
    assert built.returncode == 0
    result = chromium(tmp_path / "profile", "--dump-dom", (output / page).as_uri())
    assert console_errors(result.stderr) == []
    assert shown in result.stdout and "furo" in result.stdout  # the theme's scripts ran and drew the page


@pytest.mark.parametrize("page", PAGES, ids=_name)
def test_every_code_block_is_runnable_or_marked_as_not(page):
    strange = [f"{b.label}: ```{b.language}" for b in page_blocks(page)
               if b.language not in LANGUAGES and not b.language.startswith("{")]
    assert not strange, f"code blocks must be sh, python, text, output or a MyST directive: {strange}"
