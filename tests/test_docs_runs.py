"""The README and the documentation site run as written (issues 17 and 26): each sh and python
block, taken from the README and from the site's pages themselves, runs in order in one
folder that stands for a fresh checkout after the two commands and `. .venv/bin/activate`;
each output block's lines appear in what its command printed. A page whose commands no
longer run, or no longer print what it shows, fails here.

The order is the reader's (tests/readme_blocks.py, walk()): the README's blocks, then each
page's in the site's reading order (Getting started's walkthrough first, then the user
guide's chapters), so that a chapter may use what the walkthrough wrote (rec/, rig.json,
exported/). Every block runs once per run, here only: tests/test_docs_site.py builds the
site and checks the blocks' languages, but runs none.

The folder holds links to the checkout's tracked top-level entries and its built FMUs, so
the pages' relative paths (fmus/Cart.fmu, tests/foreign/...) are the checkout's, while
everything the commands write stays in the test's temporary folder.

Two runs. `make acceptance` runs every block as written (4 to 6 minutes on two busy cores,
the walkthrough's `fit all` most of it: 24 bootstrap refits per stage). `make test` runs them
with one change, named in SHORTENED: the three fits with bootstrap intervals of the pages
(Getting started's `fit all` and its cart from Python, the user guide's foreign FMU) get
Jacobian intervals, a third of their CPU time, so the suite stays within its 15 minutes; the
lines the intervals decide ("12 of 12 intervals hold the truth") are checked only as written.
Every other block, and every other line, is checked in both; the point estimates are the
same either way.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from foreign.recordings import FITTED, TRUTH
from readme_blocks import README, RUNNABLE, blocks, page_blocks, reading_order, runnable, walk
from readme_blocks import run as _run
from readme_blocks import scratch as _scratch

LANGUAGES = {"", "text", "output", *RUNNABLE}
# make test's one change (module docstring): each command, what is added to it; the printed
# lines that then no longer hold are the truth's (the Jacobian intervals hold 5 of 12).
WALKTHROUGH_FIT = "pendfmu fit all rec --out rig.json --report report"
SHORTENED = {WALKTHROUGH_FIT: " --uncertainty jacobian",
             'pendfmu.fit("cart", cart, params={"T_i": 4.5e-4}, seed=1': ', uncertainty="jacobian"',
             "--out out/foreign/fitted.json --report out/foreign/report": " --uncertainty jacobian"}


def _walk(folder: Path, shortened: bool) -> Path:
    """Run every block of walk() in order in `folder`; the first failing block fails."""
    for block in walk():
        code, expected = block.code, block.expected
        if shortened and any(command in code for command in SHORTENED):
            for command, added in SHORTENED.items():
                code = code.replace(command, command + added)
            expected = tuple(line for line in expected if "intervals hold the truth" not in line)
        done = _run(block, folder, code)
        assert done.returncode == 0, f"{block.label} failed:\n{code}\n{done.stdout[-3000:]}{done.stderr[-3000:]}"
        printed = [line.rstrip() for line in (done.stdout + done.stderr).splitlines()]
        for line in expected:
            assert line in printed, f"{block.label}: the page shows {line!r}, the command printed:\n" + \
                "\n".join(printed[-40:])
    return folder


@pytest.fixture(scope="module")
def walked(tmp_path_factory):
    """The folder after every block ran, the bootstrap fits shortened (SHORTENED)."""
    return _walk(_scratch(tmp_path_factory.mktemp("docs-run")), shortened=True)


@pytest.fixture(scope="module")
def walked_as_written(tmp_path_factory):
    """The folder after every block ran exactly as the README and the pages write it."""
    return _walk(_scratch(tmp_path_factory.mktemp("docs-run-as-written")), shortened=False)


def test_every_block_is_runnable_or_marked_as_not(walked):
    """sh and python run (the fixture); text blocks are templates; plain blocks show output.
    (The pages' blocks are checked so in tests/test_docs_site.py, without running them.)"""
    strange = [f"{b.label}: ```{b.language}" for b in blocks(README) if b.language not in LANGUAGES]
    assert not strange, f"code blocks must be sh, python, text or output: {strange}"
    assert len(runnable(README)) >= 2 and len(walk()) >= 20


def test_every_page_with_code_is_in_the_reading_order():
    """A page outside the toctrees the runner follows would keep blocks that never run (the
    site's build already refuses a page outside every toctree; this catches a toctree the
    runner cannot read, such as a glob)."""
    walked_pages = set(reading_order())
    pages = [p for p in Path(README.parent, "docs").rglob("*.md") if not {"_build", "_ext"} & set(p.parts)]
    unwalked = [str(p) for p in pages if p.resolve() not in {w.resolve() for w in walked_pages}
                and any(b.language in RUNNABLE for b in page_blocks(p))]
    assert not unwalked, f"pages with runnable blocks outside the reading order: {unwalked}"


def test_the_shortened_commands_are_on_the_pages():
    """A SHORTENED command no page has any longer would leave make test running the long
    one unnoticed, or testing nothing: each must be there, in a runnable block."""
    code = "\n".join(block.code for block in walk())
    assert all(command in code for command in SHORTENED), [c for c in SHORTENED if c not in code]


def test_the_walkthrough_draws_a_truth_the_fit_does_not_start_from(walked):
    truth = json.loads((walked / "rec" / "truth.json").read_text())
    assert "drawn with seed 4" in truth["described"]
    assert (walked / "report" / "index.html").is_file()


@pytest.mark.acceptance
def test_as_written_the_walkthroughs_intervals_hold_the_drawn_truth(walked_as_written):
    """Every block as written (the module docstring), and the fit's bootstrap intervals hold
    the virtual rig's truth, as Getting started shows."""
    truth = json.loads((walked_as_written / "rec" / "truth.json").read_text())
    intervals = json.loads((walked_as_written / "rig.json").read_text())["ci95"]
    held = {name: low <= truth["parameters"][name] <= high for name, (low, high) in intervals.items()
            if name in truth["parameters"]}
    assert len(held) == 12 and all(held.values()), held


def test_the_your_own_fmu_example_fits_within_one_percent(walked):
    fitted = json.loads((walked / "out/foreign/fitted.json").read_text())["parameters"]
    for name in FITTED:  # the user guide promises each within 1 % of the recordings' truth
        assert abs(fitted[name] / TRUTH[name] - 1) < 0.01, name
    assert (walked / "out/foreign/report/index.html").is_file()
    assert (walked / "out/foreign/predicted.csv").stat().st_size > 0
