"""The README's "Your own FMU" example runs as written: its shell block, taken from the
README itself, in a fresh folder, with the project's interpreter first on PATH (as after
`make test`). A README whose example no longer runs fails here."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

from foreign.recordings import FITTED, TRUTH

ROOT = Path(__file__).resolve().parents[1]


def _example_block() -> str:
    text = (ROOT / "README.md").read_text()
    section = text[text.index("## Your own FMU"):]
    return re.search(r"```sh\n(.*?)```", section, re.S).group(1)


def test_the_your_own_fmu_example_runs_as_written(tmp_path):
    (tmp_path / "tests").symlink_to(ROOT / "tests")  # the example's paths are the repository's
    bin_dir = Path(sys.executable).parent
    env = {**os.environ, "PATH": f"{bin_dir}{os.pathsep}{os.environ.get('PATH', '')}"}
    done = subprocess.run(["bash", "-e", "-c", _example_block()], cwd=tmp_path, env=env, capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    fitted = json.loads((tmp_path / "out/foreign/fitted.json").read_text())["parameters"]
    for name in FITTED:  # the README promises each within 1 % of the recordings' truth
        assert abs(fitted[name] / TRUTH[name] - 1) < 0.01, name
    assert (tmp_path / "out/foreign/report/index.html").is_file()
    assert (tmp_path / "out/foreign/predicted.csv").stat().st_size > 0
