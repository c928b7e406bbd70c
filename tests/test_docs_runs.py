"""The README runs as written (issue 17): each of its sh and python blocks, taken from the
README itself, runs in order in one folder that stands for a fresh checkout after the two
commands and `. .venv/bin/activate`; each output block's lines appear in what its command
printed. A README whose commands no longer run, or no longer print what it shows, fails here.

The folder holds links to the checkout's tracked top-level entries and its built FMUs, so
the README's relative paths (fmus/Cart.fmu, tests/foreign/...) are the checkout's, while
everything the commands write stays in the test's temporary folder.

Two runs. `make acceptance` runs every block as written (4 to 6 minutes on two busy cores,
the walkthrough's `fit all` most of it: 24 bootstrap refits per stage). `make test` runs them
with one change, named in SHORTENED: the README's three fits with bootstrap intervals (the
walkthrough's `fit all`, the cart from Python, the foreign FMU) get Jacobian intervals, a
third of their CPU time, so the suite stays within its 15 minutes; the lines the intervals
decide ("12 of 12 intervals hold the truth") are checked only as written. Every other block,
and every other line, is checked in both; the point estimates are the same either way.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from foreign.recordings import FITTED, TRUTH
from readme_blocks import RUNNABLE, blocks, runnable
from readme_blocks import run as _run
from readme_blocks import scratch as _scratch

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
LANGUAGES = {"", "text", "output", *RUNNABLE}
# make test's one change (module docstring): each command, what is added to it; the printed
# lines that then no longer hold are the truth's (the Jacobian intervals hold 5 of 12).
WALKTHROUGH_FIT = "pendfmu fit all rec --out rig.json --report report"
SHORTENED = {WALKTHROUGH_FIT: " --uncertainty jacobian",
             'pendfmu.fit("cart", cart, params={"T_i": 4.5e-4}, seed=1': ', uncertainty="jacobian"',
             "--out out/foreign/fitted.json --report out/foreign/report": " --uncertainty jacobian"}


def _walk(folder: Path, shortened: bool) -> Path:
    """Run every runnable block in order in `folder`; the first failing block fails."""
    for block in runnable(README):
        code, expected = block.code, block.expected
        if shortened and any(command in code for command in SHORTENED):
            for command, added in SHORTENED.items():
                code = code.replace(command, command + added)
            expected = tuple(line for line in expected if "intervals hold the truth" not in line)
        done = _run(block, folder, code)
        assert done.returncode == 0, f"{block.label} failed:\n{code}\n{done.stdout[-3000:]}{done.stderr[-3000:]}"
        printed = [line.rstrip() for line in (done.stdout + done.stderr).splitlines()]
        for line in expected:
            assert line in printed, f"{block.label}: the README shows {line!r}, the command printed:\n" + \
                "\n".join(printed[-40:])
    return folder


@pytest.fixture(scope="module")
def walked(tmp_path_factory):
    """The folder after every block ran, the walkthrough's fit shortened (SHORTENED)."""
    return _walk(_scratch(tmp_path_factory.mktemp("readme")), shortened=True)


@pytest.fixture(scope="module")
def walked_as_written(tmp_path_factory):
    """The folder after every block ran exactly as the README writes it."""
    return _walk(_scratch(tmp_path_factory.mktemp("readme-as-written")), shortened=False)


def test_every_block_is_runnable_or_marked_as_not(walked):
    """sh and python run (the fixture); text blocks are templates; plain blocks show output."""
    strange = [f"{b.label}: ```{b.language}" for b in blocks(README) if b.language not in LANGUAGES]
    assert not strange, f"code blocks must be sh, python, text or output: {strange}"
    assert len(runnable(README)) >= 8


def test_the_shortened_command_is_in_the_readme():
    """A SHORTENED command the README no longer has would leave make test running the long
    one unnoticed, or testing nothing: each must be there, in a runnable block."""
    code = "\n".join(block.code for block in runnable(README))
    assert all(command in code for command in SHORTENED), [c for c in SHORTENED if c not in code]


def test_the_walkthrough_draws_a_truth_the_fit_does_not_start_from(walked):
    truth = json.loads((walked / "rec" / "truth.json").read_text())
    assert "drawn with seed 4" in truth["described"]
    assert (walked / "report" / "index.html").is_file()


@pytest.mark.acceptance
def test_as_written_the_walkthroughs_intervals_hold_the_drawn_truth(walked_as_written):
    """Every block as written (the module docstring), and the fit's bootstrap intervals hold
    the virtual rig's truth, as the README shows."""
    truth = json.loads((walked_as_written / "rec" / "truth.json").read_text())
    intervals = json.loads((walked_as_written / "rig.json").read_text())["ci95"]
    held = {name: low <= truth["parameters"][name] <= high for name, (low, high) in intervals.items()
            if name in truth["parameters"]}
    assert len(held) == 12 and all(held.values()), held


def test_the_your_own_fmu_example_fits_within_one_percent(walked):
    fitted = json.loads((walked / "out/foreign/fitted.json").read_text())["parameters"]
    for name in FITTED:  # the README promises each within 1 % of the recordings' truth
        assert abs(fitted[name] / TRUTH[name] - 1) < 0.01, name
    assert (walked / "out/foreign/report/index.html").is_file()
    assert (walked / "out/foreign/predicted.csv").stat().st_size > 0
