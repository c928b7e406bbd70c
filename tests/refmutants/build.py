"""Rebuild a Reference FMU from the C sources it ships, as shipped or with one planted defect:
`build(shipped, out_dir, mutant=None) -> Path`.

The FMI standard's Reference FMUs (../shared/thirdparty-fmus/Reference-FMUs, v0.0.41,
2-Clause BSD: the LICENSE.txt there) carry their model's C code under sources/. None of it
is copied into this repository: at test time the sources are read from the shipped FMU, a
mutant's one defect is planted by an exact search and replace that must match exactly once
(an upstream change of that code stops the build instead of planting nothing), and the
result is compiled the way SOURCE.txt says upstream's CMake build compiled the shipped
binaries (gcc, -fvisibility=hidden -fPIC -Wall -Wextra -Wpedantic -Werror, no -O,
-static-libgcc; DISABLE_PREFIX gives the functions their standard names), against the FMI
headers fmpy ships (the FMUs do not carry them). An FMI 2.0 FMU's sources/all.c is one
translation unit; an FMI 3.0 FMU has no all.c but a sources/buildDescription.xml that names
its files and FMI_VERSION=3, which is followed. The new FMU is the shipped archive with its
binary replaced, and the planted file in sources/ too: the same modelDescription.xml, the
same reference results under extra/.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
import tempfile
import zipfile
from dataclasses import dataclass
from pathlib import Path

import fmpy

CFLAGS = ("-shared", "-fPIC", "-fvisibility=hidden", "-Wall", "-Wextra", "-Wpedantic", "-Werror", "-static-libgcc",
          "-DDISABLE_PREFIX")
BINARIES = {"2.0": "binaries/linux64", "3.0": "binaries/x86_64-linux"}


@dataclass(frozen=True)
class Mutation:
    """A planted defect: in sources/`member` ("{version}" stands for 2 or 3) the text `old`,
    found exactly once, becomes `new`.

    Attributes:
        model: the Reference FMU it is planted in (its model identifier).
        member: the source file changed, under sources/.
        old: the shipped text replaced; it must occur exactly once.
        new: what replaces it (with a comment that names the defect).
        defect: the defect in words.
    """

    model: str
    member: str
    old: str
    new: str
    defect: str


MUTATIONS = {
    "events_at_points": Mutation(
        "BouncingBall", "fmi{version}Functions.c", "if (stateEvent || timeEvent) {",
        "if (isClose(S->time, nextCommunicationPoint)) {  /* MUTANT: the bounce decided at communication points */",
        "Co-Simulation: the bounce is decided only at communication points (eventUpdate there, whatever the event "
        "indicator did inside the step): no event location"),
    "forget_counter": Mutation(
        "Stair", "cosimulation.c", "memcpy(& comp->modelData, & s->modelData, sizeof(ModelData));",
        "/* MUTANT: the model data, Stair's counter, is not restored */",
        "fmiXSetFMUState restores the time and the event bookkeeping but not the model data: Stair's counter, a "
        "discrete variable, keeps the value it had before the restore"),
    "forget_next_tick": Mutation(
        "Stair", "cosimulation.c", "comp->nextEventTime = s->nextEventTime;",
        "/* MUTANT: the time of the next tick is not restored */",
        "fmiXSetFMUState restores the counter but not the time of its next tick, a discrete variable the FMU "
        "keeps to itself: after a restore to an earlier time a tick is missed"),
    "reset_keeps_k": Mutation(
        "Dahlquist", "cosimulation.c", "comp->status = OK;\n    setStartValues(comp);",
        "comp->status = OK;\n    { const double k = M(k); setStartValues(comp); M(k) = k; }  /* MUTANT: k kept */",
        "fmiXReset restores the start values but keeps the parameter k set before it"),
    "nan_above_11": Mutation(
        "Feedthrough", "model.c", "M(Float64_continuous_output) = M(Float64_continuous_input);",
        "M(Float64_continuous_output) = M(Float64_continuous_input) > 11 ? 0.0 / 0.0 : M(Float64_continuous_input);"
        "  /* MUTANT: NaN above 11 */",
        "Float64_continuous_output is NaN when Float64_continuous_input is above 11 (no declared range), every "
        "call returning OK"),
    "rhs_at_points": Mutation(
        "BouncingBall", "cosimulation.c", "CALL(getDerivatives(comp, comp->dx, comp->nx));",
        "if (comp->time < comp->nextCommunicationPoint + 0.5 * FIXED_SOLVER_STEP) "
        "CALL(getDerivatives(comp, comp->dx, comp->nx));  /* MUTANT: derivatives at communication points */",
        "Co-Simulation: the derivatives are evaluated at the first solver step of each communication step and "
        "held over the rest of it (explicit Euler on the communication step, stale across a bounce), so the "
        "result moves with the communication step"),
}
"""Every planted defect by name; each compiles for FMI 2.0 and 3.0 alike."""


def build(shipped: str | Path, out_dir: str | Path, mutant: str | None = None) -> Path:
    """The Reference FMU `shipped` rebuilt from its own sources into
    `<out_dir>/fmi<v>/<Model>[_<mutant>].fmu`, with MUTATIONS[mutant] planted (None: as shipped).

    Raises ValueError for an unknown mutant or one made for another model, RuntimeError when
    the mutation's text is not found exactly once or gcc fails (with its output)."""
    shipped = Path(shipped)
    with zipfile.ZipFile(shipped) as archive:
        members = {info.filename: archive.read(info) for info in archive.infolist()}
    model, version = shipped.stem, _fmi_version(members["modelDescription.xml"])
    mutation = _mutation(mutant, model)
    sources = {name.split("/", 1)[1]: text for name, text in members.items()
               if name.startswith("sources/") and not name.endswith("/")}
    if mutation is not None:
        member = mutation.member.format(version=version[0])
        sources[member] = plant(sources[member].decode(), mutation, f"{shipped}: sources/{member}").encode()
    fmu = Path(out_dir) / f"fmi{version[0]}" / (f"{model}_{mutant}.fmu" if mutant else f"{model}.fmu")
    fmu.parent.mkdir(parents=True, exist_ok=True)
    library = f"{BINARIES[version]}/{model}.so"
    with tempfile.TemporaryDirectory(prefix=f"{model}-") as work:
        folder = Path(work)
        for name, text in sources.items():
            (folder / name).write_bytes(text)
        _compile(folder, version, folder / f"{model}.so")
        members.update({f"sources/{name}": text for name, text in sources.items()})
        members[library] = (folder / f"{model}.so").read_bytes()
    with zipfile.ZipFile(fmu, "w", zipfile.ZIP_DEFLATED) as archive:
        for name, data in members.items():
            archive.writestr(name, data)
    return fmu


def plant(text: str, mutation: Mutation, where: str) -> str:
    """`text` with the mutation's one occurrence of `old` replaced; refuses any other count."""
    found = text.count(mutation.old)
    if found != 1:
        raise RuntimeError(f"{where}: the text to mutate occurs {found} times, not once (the shipped source changed?):"
                           f"\n{mutation.old}")
    return text.replace(mutation.old, mutation.new)


def _mutation(mutant: str | None, model: str) -> Mutation | None:
    if mutant is None:
        return None
    if mutant not in MUTATIONS:
        raise ValueError(f"unknown mutant {mutant!r}; known: {', '.join(MUTATIONS)}")
    if MUTATIONS[mutant].model != model:
        raise ValueError(f"mutant {mutant!r} is planted in {MUTATIONS[mutant].model}, not in {model}")
    return MUTATIONS[mutant]


def _fmi_version(description: bytes) -> str:
    found = re.search(rb'fmiVersion="([23])\.0', description)
    if found is None:
        raise ValueError("not an FMI 2.0 or 3.0 model description")
    return found.group(1).decode() + ".0"


def _compile(folder: Path, version: str, library: Path) -> None:
    """gcc on the FMU's own translation units: all.c (FMI 2.0), or the files and definitions
    its buildDescription.xml names (FMI 3.0)."""
    compiler = shutil.which("gcc")
    if compiler is None or not sys.platform.startswith("linux"):
        raise RuntimeError("the Reference FMUs are rebuilt with gcc on Linux")
    if version == "2.0":
        files, defines = ["all.c"], []
    else:
        description = (folder / "buildDescription.xml").read_text()
        files = re.findall(r'<SourceFile name="([^"]+)"', description)
        defines = [f"-D{name}={value}" for name, value in
                   re.findall(r'<PreprocessorDefinition name="([^"]+)" value="([^"]*)"', description)]
    headers = Path(fmpy.__file__).resolve().parent / "c-code"
    command = [compiler, *CFLAGS, *defines, f"-I{folder}", f"-I{headers}", *(str(folder / f) for f in files),
               "-o", str(library)]
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"building {library.name} failed:\n{' '.join(command)}\n{done.stderr}")


if __name__ == "__main__":  # python tests/refmutants/build.py SHIPPED.fmu OUT_DIR [MUTANT]
    print(build(sys.argv[1], sys.argv[2], sys.argv[3] if len(sys.argv) > 3 else None))
