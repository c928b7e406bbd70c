"""The Performance page's tables, from docs/performance.json as `scripts/bench.py --json`
writes it: the run's machine, date, pendfmu version and command, then each part it measured
with its figures. Whatever parts the file holds are shown; none are copied by hand."""

from __future__ import annotations

import json
from pathlib import Path

from sphinx.util import logging

from pendfmu_docs.markdown import plain, table

logger = logging.getLogger(__name__)
FIGURES = Path(__file__).resolve().parents[2] / "performance.json"


def value(number: float, unit: str) -> str:
    """A figure as the benchmark printed it: times to three significant digits, ratios to
    one decimal, counts whole."""
    if unit == "":
        return f"{number:.0f}"
    if unit.startswith("x"):
        return f"{number:.1f}"
    return f"{number:.3g}"


def markdown(app=None) -> str:
    try:
        document = json.loads(FIGURES.read_text(encoding="utf-8"))
    except (OSError, ValueError) as error:
        logger.warning("cannot read %s: %s", FIGURES, error)
        return ""
    machine = document["machine"]
    libraries = ", ".join(f"{name} {machine[name]}" for name in ("numpy", "scipy", "fmpy") if name in machine)
    load = machine.get("load")
    busy = ""
    if load:
        busy = f" The machine's load average was {load[0]:g} when the run began and {load[1]:g} when it ended, on " \
               f"{machine['cpus']} cores"
        busy += ": a busy machine, whose timings are slower and noisier." if max(load) > 1 else "."
    parts = [
        f"Measured on {document['date'][:10]} ({document['date']}) with pendfmu {document['pendfmu']}, by "
        f"`{document['command']}`, on {plain(machine['platform'])} ({machine['processor']}, {machine['cpus']} "
        f"cores), Python {machine['python']}, {libraries}.{busy}\n"
    ]
    for part in document["parts"].values():
        rows = [[plain(figure["name"]), value(figure["value"], figure["unit"]), plain(figure["unit"])]
                for figure in part["figures"]]
        title = part["title"]
        parts.append(f"## {plain(title[0].upper() + title[1:])}\n\n" + table(["", "value", "unit"], rows, right=(1,)))
    return "\n".join(parts)
