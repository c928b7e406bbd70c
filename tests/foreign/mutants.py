"""ForeignCart as a supplier would ship it, and its broken variants, built by mutation:
`build_variant(variant, out_dir) -> Path` of `<out_dir>/ForeignCart_<variant>.fmu`.

The acceptance corpus of issue 24 (`pendfmu check` on an FMU it did not make). "Shipped"
means the start values are the identified cart of the recordings (`recordings.TRUTH`: 2 kg,
4 N/V, breakaway at 5 N), so that the voltage a cautious stimulus uses, about 1 V, does not
move it. The source is rewritten here: the start values in copies of `src/ForeignCart.c` and
`src/ForeignCart.xml`; each broken variant is then the same copy compiled with one planted
bug switched on (-D<MACRO>, described in ForeignCart.c and foreign_fmi2.c):

    ok                correct
    events_at_points  stick/slip decided only at communication points (no event location)
    forget_mode       an FMU state that forgets the friction mode, a discrete variable
    reset_keeps       fmi2Reset keeps the parameters set before it
    nan_above_11V     outputs NaN above 11 V of input, every call OK
    step_jump         the position output jumps with the communication step (x + h v)
"""

from __future__ import annotations

import re
import shutil
import tempfile
from pathlib import Path

from foreign.build import SOURCES, build
from foreign.recordings import TRUTH

VARIANTS = {
    "ok": None,
    "events_at_points": "MUTANT_EVENTS_AT_POINTS",
    "forget_mode": "MUTANT_FORGET_MODE",
    "reset_keeps": "MUTANT_RESET_KEEPS_PARAMETERS",
    "nan_above_11V": "MUTANT_NAN_ABOVE_11V",
    "step_jump": "MUTANT_STEP_JUMP",
}


def build_variant(variant: str, out_dir: str | Path, starts: dict[str, float] | None = None,
                  hide_mode: bool = False, name: str | None = None) -> Path:
    """The shipped ForeignCart (start values `starts`, default TRUTH) with the bug `variant`
    planted (VARIANTS), as `<out_dir>/<name>.fmu` (default `ForeignCart_<variant>`); with
    `hide_mode` its model description does not declare the friction mode (default name
    `ForeignCart_<variant>_hidden`): a checker then sees its events from outside only."""
    if variant not in VARIANTS:
        raise ValueError(f"unknown variant {variant!r}; known: {', '.join(VARIANTS)}")
    with tempfile.TemporaryDirectory(prefix="ForeignCart-mutant-") as work:
        sources = Path(work)
        for path in SOURCES.iterdir():
            shutil.copy(path, sources / path.name)
        rewrite_starts(sources, TRUTH if starts is None else starts)
        if hide_mode:
            hide_the_mode(sources / "ForeignCart.xml")
        defines = () if VARIANTS[variant] is None else (VARIANTS[variant],)
        name = name or f"ForeignCart_{variant}{'_hidden' if hide_mode else ''}"
        return build("ForeignCart", out_dir, defines, sources, name)


def rewrite_starts(sources: Path, starts: dict[str, float]) -> None:
    """Sets each parameter's start value in both the C variable table and the model
    description (they must agree: the binary starts from the first, a host reads the second)."""
    c_file, xml_file = sources / "ForeignCart.c", sources / "ForeignCart.xml"
    c_text, xml_text = c_file.read_text(), xml_file.read_text()
    for name, value in starts.items():
        c_row = re.compile(r'(\{VR_\w+, "' + re.escape(name) + r'", PARAMETER, )([^,]+)')
        xml_row = re.compile(r'(name="' + re.escape(name) + r'"[^>]*>\s*<Real[^>]*? start=")([^"]+)')
        c_text, n_c = c_row.subn(lambda m: m.group(1) + repr(float(value)), c_text)
        xml_text, n_xml = xml_row.subn(lambda m: m.group(1) + repr(float(value)), xml_text)
        if n_c != 1 or n_xml != 1:
            raise ValueError(f"parameter {name!r}: found {n_c} rows in ForeignCart.c, {n_xml} in ForeignCart.xml")
    c_file.write_text(c_text)
    xml_file.write_text(xml_text)


def hide_the_mode(xml_file: Path) -> None:
    """Removes the Integer `mode` (the last variable: no index in ModelStructure moves)."""
    text = xml_file.read_text()
    text, count = re.subn(r'\s*<!-- \d+ --> <ScalarVariable name="mode".*?</ScalarVariable>', "", text, flags=re.S)
    if count != 1:
        raise ValueError(f"{xml_file}: the mode variable was not found once ({count})")
    xml_file.write_text(text)


def build_all_variants(out_dir: str | Path) -> dict[str, Path]:
    """Every variant, built into `out_dir`: {variant: path}."""
    return {variant: build_variant(variant, out_dir) for variant in VARIANTS}
