"""The user guide's "Testing your FMUs" example (docs/user-guide/pytest-plugin.md) runs as
written: its python block, taken from the page itself, is a test file run by pytest (with the plugin loaded as a user without the
install would, -p pendfmu.testing) in a fresh folder on pendfmu's Cart.fmu, and passes. (That
each assertion fails on its bug is tests/test_testing_plugin.py's job.)"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

from pendfmu.fmubuild import ensure_fmu

ROOT = Path(__file__).resolve().parents[1]


def _example_block() -> str:
    text = (ROOT / "docs" / "user-guide" / "pytest-plugin.md").read_text()
    section = text[text.index("# Testing your FMUs"):]
    return re.search(r"```python\n(.*?)```", section, re.S).group(1)


def _pytest(folder: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "pendfmu.testing", "-p", "no:cacheprovider",
                           "test_cart_fmu.py"], cwd=folder, capture_output=True, text=True, timeout=300)


def test_the_testing_your_fmus_example_runs_as_written(tmp_path):
    (tmp_path / "fmus").mkdir()
    (tmp_path / "fmus" / "Cart.fmu").symlink_to(ensure_fmu("Cart"))
    (tmp_path / "test_cart_fmu.py").write_text(_example_block())
    done = _pytest(tmp_path)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]
    assert "3 passed" in done.stdout  # Cart-CS, Cart-ME and the runner's test
