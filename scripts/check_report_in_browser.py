"""Open a written report in headless Chromium and say what a reader would see: console
errors, one zoomable plot per recording (fitted and predicted), provenance and the
per-recording values. For reports the tests do not write themselves, such as make demo's:

    python scripts/check_report_in_browser.py out/demo/report/index.html

Exit 0 when every recording of the result is plotted with no console error and both
tables are there; 1 otherwise. Uses the browser test's helpers (tests/test_report_browser.py).
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from test_report_browser import BROWSER, Plots, chromium, console_errors  # noqa: E402


def main(index: Path) -> int:
    if BROWSER is None:
        print("no Chromium installed (apt-get install chromium; make tools)")
        return 1
    with tempfile.TemporaryDirectory() as profile:
        result = chromium(Path(profile), "--dump-dom", index.resolve().as_uri())
    errors = console_errors(result.stderr)
    plots = Plots(result.stdout)
    drawn = [plot for plot, layers in plots.svgs.items() if layers and plots.curves[plot] >= 2]
    text = result.stdout
    checks = {
        "no console errors": not errors,
        f"{len(drawn)} of {len(plots.svgs)} plots drawn (recorded and simulated curves)": drawn and
        len(drawn) == len(plots.svgs),
        "provenance shown": "Provenance" in text,
        "per-recording values shown": "Parameter values per recording" in text,
    }
    for what, passed in checks.items():
        print(f"{'PASS' if passed else 'FAIL'}  {what}")
    for error in errors:
        print(f"      console: {error}")
    print("plots: " + ", ".join(f"{p} ({plots.curves[p]} curves)" for p in plots.svgs))
    return 0 if all(checks.values()) else 1


if __name__ == "__main__":
    if len(sys.argv) != 2 or not Path(sys.argv[1]).is_file():
        print(__doc__.strip().splitlines()[-1] if len(sys.argv) != 2 else f"{sys.argv[1]}: no such file",
              file=sys.stderr)
        sys.exit(2)
    sys.exit(main(Path(sys.argv[1])))
