"""Build BrokenCart (tests/broken/BrokenCart.c) correct or with one planted bug:
`build(variant, out_dir) -> Path` of `<out_dir>/BrokenCart_<variant>.fmu`.

The variants ("ok", "state", "reset", "step", "nan") are one C file compiled with
-DBREAK_<VARIANT> (none for "ok") by one gcc call against the FMI 2.0 headers fmpy ships,
zipped with the model description written here. Nothing built is kept in git.
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
VARIANTS = ("ok", "state", "reset", "step", "nan")
CFLAGS = ("-std=c99", "-O2", "-fPIC", "-shared", "-Wall", "-Wextra", "-Werror")

_REAL = '<ScalarVariable name="{0}" valueReference="{1}" causality="{2}" variability="{3}"{4}><Real{5}/></ScalarVariable>'
VARIABLES = [  # name, vr, causality, variability, initial, attributes
    ("m", 0, "parameter", "fixed", "exact", ' start="1" min="0"'),
    ("k", 1, "parameter", "fixed", "exact", ' start="2"'),
    ("c", 2, "parameter", "fixed", "exact", ' start="1" min="0"'),
    ("F_c", 3, "parameter", "fixed", "exact", ' start="3" min="0"'),
    ("F_s", 4, "parameter", "fixed", "exact", ' start="4" min="0"'),
    ("u_rated", 5, "parameter", "fixed", "exact", ' start="3"'),
    ("u", 6, "input", "continuous", None, ' start="0" min="-5" max="5"'),
    ("x", 7, "output", "continuous", "calculated", ""),
    ("v", 8, "output", "continuous", "calculated", ""),
    ("a", 9, "output", "continuous", "calculated", ""),
    ("margin", 10, "output", "continuous", "calculated", ""),
]


def model_description() -> str:
    rows = [_REAL.format(name, vr, causality, variability, f' initial="{initial}"' if initial else "", attributes)
            for name, vr, causality, variability, initial, attributes in VARIABLES]
    rows.append('<ScalarVariable name="mode" valueReference="0" causality="local" variability="discrete" '
                'initial="calculated"><Integer/></ScalarVariable>')
    outputs = "".join(f'<Unknown index="{i}"/>' for i in (8, 9, 10, 11))
    return f"""<?xml version="1.0" encoding="UTF-8"?>
<fmiModelDescription fmiVersion="2.0" modelName="BrokenCart" guid="{{5d0c1a2e-7b4f-4c1e-9a3d-b20ce4a7f001}}"
  generationTool="hand-written (pendfmu tests/broken)" variableNamingConvention="flat" numberOfEventIndicators="0">
  <CoSimulation modelIdentifier="BrokenCart" canHandleVariableCommunicationStepSize="true"
    canGetAndSetFMUstate="true" canSerializeFMUstate="true"/>
  <DefaultExperiment startTime="0" stopTime="2" stepSize="4e-3"/>
  <ModelVariables>
    {chr(10).join(rows)}
  </ModelVariables>
  <ModelStructure>
    <Outputs>{outputs}</Outputs>
    <InitialUnknowns>{outputs}</InitialUnknowns>
  </ModelStructure>
</fmiModelDescription>
"""


def build(variant: str, out_dir: str | Path) -> Path:
    if variant not in VARIANTS:
        raise ValueError(f"unknown variant {variant!r}; known: {', '.join(VARIANTS)}")
    compiler = shutil.which("gcc")
    if compiler is None or not sys.platform.startswith("linux"):
        raise RuntimeError("BrokenCart is built with gcc for linux64")
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    headers = Path(fmpy.__file__).resolve().parent / "c-code"
    define = [] if variant == "ok" else [f"-DBREAK_{variant.upper()}"]
    with tempfile.TemporaryDirectory(prefix="BrokenCart-") as work:
        library = Path(work) / "BrokenCart.so"
        command = [compiler, *CFLAGS, *define, f"-I{headers}", str(HERE / "BrokenCart.c"), "-o", str(library), "-lm"]
        done = subprocess.run(command, capture_output=True, text=True)
        if done.returncode != 0:
            raise RuntimeError(f"building BrokenCart ({variant}) failed:\n{' '.join(command)}\n{done.stderr}")
        fmu = out_dir / f"BrokenCart_{variant}.fmu"
        with zipfile.ZipFile(fmu, "w", zipfile.ZIP_DEFLATED) as archive:
            archive.writestr("modelDescription.xml", model_description())
            archive.write(library, "binaries/linux64/BrokenCart.so")
    return fmu


if __name__ == "__main__":
    target = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("broken-fmus")
    for name in VARIANTS:
        print(build(name, target))
