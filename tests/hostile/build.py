"""Build the hostile FMUs of tests/test_check_hostile.py: `build_all(out_dir) -> {variant: Path}`.

Hostile.c (an FMI 2.0 Co-Simulation FMU, y' = k (u - y)) compiled as is or with one of its
HOSTILE_* macros (a DoStep that segfaults, never returns, or allocates without end), zipped
with a model description written here, itself made hostile for other variants: a default
experiment of 1e-300 s steps or 1e12 s, no interface element, a parameter whose min exceeds
its max, a modelIdentifier that is a path to evil.c's library (inside the archive, or
anywhere on the machine); FMI-LS-REF members that are not UTF-8, not XML, or an entity bomb.
Each variant is one gcc call at most; nothing built is kept in git.
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

import fmpy

HERE = Path(__file__).resolve().parent
CFLAGS = ("-std=c99", "-O2", "-fPIC", "-shared", "-Wall", "-Wextra", "-Werror", "-Wno-unused-parameter")
GUID = "{6f1d2c3b-0a4e-4b5f-8c7d-hostile00001}"
LIBRARIES = {"ok": [], "segv": ["-DHOSTILE_SEGV"], "hang": ["-DHOSTILE_HANG"], "hog": ["-DHOSTILE_HOG"]}
"""The binaries: Hostile.c with these macros."""
EXPERIMENT = '<DefaultExperiment startTime="0" stopTime="1" stepSize="0.01"/>'
EXPERIMENTS = {"tiny_step": '<DefaultExperiment startTime="0" stopTime="1" stepSize="1e-300"/>',
               "long_stop": '<DefaultExperiment startTime="0" stopTime="1e12" stepSize="1e-3"/>'}
K_RANGE = {"min_over_max": ' min="10" max="0"', "start_outside": ' min="2" max="10"'}
REF = "extra/org.fmi-standard.fmi-ls-ref"
BOMB = ('<?xml version="1.0"?>\n<!DOCTYPE b [<!ENTITY a "aaaaaaaaaa">'
        + "".join(f'<!ENTITY {chr(98 + i)} "{("&" + chr(97 + i) + ";") * 10}">' for i in range(9))
        + ']>\n<fmiReferences>&j;</fmiReferences>\n')
MANIFEST = ('<?xml version="1.0" encoding="UTF-8"?>\n'
            '<fmiReferences xmlns:fmi-ls="http://fmi-standard.org/fmi-ls-manifest"'
            ' fmi-ls:fmi-ls-name="org.fmi-standard.fmi-ls-ref" fmi-ls:fmi-ls-version="1.0.0-alpha.1"'
            ' fmi-ls:fmi-ls-description="Layered Standard providing information on related files included in an'
            ' FMU.">\n  <Related source="Hostile_out.csv" role="result" type="text/csv" description="y"/>\n'
            '</fmiReferences>\n')
REFERENCES = {"ref_not_utf8": {f"{REF}/fmi-ls-manifest.xml": MANIFEST.encode(),
                               f"{REF}/Hostile_out.csv": b"time,y\n0,0\n1,0.63\xff\xfe\n"},
              "ref_not_xml": {f"{REF}/fmi-ls-manifest.xml": b"<fmiReferences><Related source="},
              "ref_bomb": {f"{REF}/fmi-ls-manifest.xml": BOMB.encode()},
              "ref_experiments_bomb": {f"{REF}/fmi-ls-manifest.xml": MANIFEST.replace(
                  'Hostile_out.csv" role="result" type="text/csv"', 'experiments.xml" role="experiment" type="text/xml"'
              ).encode(), f"{REF}/experiments.xml": BOMB.replace("fmiReferences", "Experiments").encode()}}
"""FMI-LS-REF members beside an ordinary FMU."""


def model_description(variant: str, identifier: str = "Hostile", version: str = "2.0") -> str:
    interface = "" if variant == "no_interface" else f'<CoSimulation modelIdentifier="{identifier}"/>'
    k_range = K_RANGE.get(variant, ' min="0" max="10"')
    start = "20" if variant == "start_outside" else "1"
    token = "instantiationToken" if version == "3.0" else "guid"
    return f"""<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="{version}" modelName="Hostile" {token}="{GUID}"
  generationTool="hand-written (pendfmu tests/hostile)" variableNamingConvention="flat" numberOfEventIndicators="0">
  {interface}
  {EXPERIMENTS.get(variant, EXPERIMENT)}
  <ModelVariables>
    <ScalarVariable name="k" valueReference="0" causality="parameter" variability="fixed" initial="exact">
      <Real start="{start}"{k_range}/></ScalarVariable>
    <ScalarVariable name="u" valueReference="1" causality="input" variability="continuous">
      <Real start="0" min="-1" max="1"/></ScalarVariable>
    <ScalarVariable name="y" valueReference="2" causality="output" variability="continuous" initial="calculated">
      <Real/></ScalarVariable>
  </ModelVariables>
  <ModelStructure><Outputs><Unknown index="3"/></Outputs><InitialUnknowns><Unknown index="3"/></InitialUnknowns>
  </ModelStructure>
</fmiModelDescription>
"""


def model_description3(identifier: str) -> str:
    """An FMI 3.0 description whose only interface names `identifier`."""
    return f"""<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="3.0" modelName="Hostile" instantiationToken="{GUID}">
  <CoSimulation modelIdentifier="{identifier}"/>
  <ModelVariables>
    <Float64 name="time" valueReference="0" causality="independent" variability="continuous"/>
    <Float64 name="y" valueReference="1" causality="output" variability="continuous"/>
  </ModelVariables>
  <ModelStructure><Output valueReference="1"/><InitialUnknown valueReference="1"/></ModelStructure>
</fmiModelDescription>
"""


def _compile(source: str, macros: list[str], library: Path) -> Path:
    compiler = shutil.which("gcc")
    if compiler is None or not sys.platform.startswith("linux"):
        raise RuntimeError("the hostile FMUs are built with gcc for Linux")
    headers = Path(fmpy.__file__).resolve().parent / "c-code"
    command = [compiler, *CFLAGS, *macros, f"-I{headers}", str(HERE / source), "-o", str(library), "-lm"]
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"building {library.name} failed:\n{' '.join(command)}\n{done.stderr}")
    return library


def _zip(path: Path, members: dict[str, bytes | Path]) -> Path:
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as archive:
        for name, content in members.items():
            if isinstance(content, Path):
                archive.write(content, name)
            else:
                archive.writestr(name, content)
    return path


def build_all(out_dir: str | Path) -> dict[str, Path]:
    """Every variant as `<out_dir>/Hostile_<variant>.fmu`; the evil library as out_dir/evil/evil.so
    (what "evil_outside" points at)."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="Hostile-") as work:
        binaries = {name: _compile("Hostile.c", macros, Path(work) / f"{name}.so")
                    for name, macros in LIBRARIES.items()}
        (out_dir / "evil").mkdir(exist_ok=True)
        evil = _compile("evil.c", [], out_dir / "evil" / "evil.so")
        built = {}
        for variant in (*LIBRARIES, *EXPERIMENTS, *K_RANGE, "no_interface", *REFERENCES):
            members = {"modelDescription.xml": model_description(variant).encode(),
                       "binaries/linux64/Hostile.so": binaries.get(variant, binaries["ok"]),
                       **REFERENCES.get(variant, {})}
            built[variant] = _zip(out_dir / f"Hostile_{variant}.fmu", members)
        outside = "../" * 40 + str(evil.with_suffix("")).lstrip("/")  # from binaries/linux64/ to / and on
        for variant, description, platform in (("evil", model_description("evil", "../../x/evil"), "linux64"),
                                               ("evil_outside", model_description("evil", outside), "linux64"),
                                               ("evil3", model_description3("../../x/evil"), "x86_64-linux")):
            members = {"modelDescription.xml": description.encode(), "x/evil.so": evil,
                       f"binaries/{platform}/Hostile.so": binaries["ok"]}  # the folder the path starts from
            built[variant] = _zip(out_dir / f"Hostile_{variant}.fmu", members)
    return built


if __name__ == "__main__":
    for name, path in build_all(Path(sys.argv[1]) if len(sys.argv) > 1 else Path("hostile-fmus")).items():
        print(name, path)
