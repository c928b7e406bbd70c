"""Export fitted values for a user's FMU or SSP system (not one of pendfmu's components).

Writes into one folder:

- for each FMU of the model, ``<Instance>.fmu``: a copy of it whose modelDescription.xml
  carries the fitted values as the parameters' start values (and says so in its
  description); every other member, the binaries included, byte for byte. The GUID is
  kept: a binary pendfmu did not build checks it at fmi2Instantiate. A copy of a
  parameterized copy pendfmu wrote (one of pendfmu's components packed in a pendfmu SSP)
  gets its start file written anew too: its binary computes with the values it declares;
- ``parameters.ssv``: SSP 1.0 parameter values of every parameter, named
  ``Instance.parameter`` (validated against the SSV schema);
- ``set_parameters.m`` and ``parameters.mat``: the same values for Simulink's FMU Import
  blocks of the copies (:mod:`pendfmu.export.simulink`).

What the copy can and cannot do: an importer that sets every parameter to the start value
its model description declares (pendfmu does; SSP tools apply the SSV) runs it with the
fitted values. The binary itself still starts from the defaults it was compiled with,
which only its exporter can change, and an importer that leaves parameters alone gets
those: fmpy's simulate_fmu leaves a co-simulation FMU's parameters alone (its
apply_default_start_values is deprecated and, measured with fmpy 0.3.x, not applied to
co-simulation); give such a tool the values (start_values=...), or the SSV.
"""

from __future__ import annotations

import zipfile
from collections.abc import Mapping
from pathlib import Path

from pendfmu.atomic import write_atomically
from pendfmu.escaping import xml_text
from pendfmu.export.fmu import MODEL_DESCRIPTION, START_FILE, _copy_info, _now, _parse, start_file_text
from pendfmu.simulator.model import Model
from pendfmu.ssp import ParameterSet, ParameterValue, write_ssv

SSV_FILE = "parameters.ssv"


def export_model(model: Model, values: Mapping[str, float], out_dir: str | Path,
                 source: str = "a pendfmu fit") -> list[Path]:
    """Write the parameterized FMU copies, the SSV file and the Simulink files of `model`
    with `values` (the model's names); return their paths. Values are checked by the model first."""
    from pendfmu.export.simulink import block_values, write_simulink_files
    from pendfmu.fitting.models import checked_values

    checked = checked_values(model, values)
    per, given = model.split({**model.defaults(), **checked}), model.split(checked)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    paths, blocks = [], []
    for name, instance in model.instances.items():
        if instance.fmu is None:
            continue  # pendfmu's own components: pendfmu export writes those
        paths.append(_parameterized_copy(Path(instance.fmu), per[name], out_dir / f"{name}.fmu", source))
        blocks.append(block_values(name, paths[-1], per[name], given[name], source))
    entries = {f"{name}.{parameter}": ParameterValue(float(value), None, "Real")
               for name, parameters in per.items() for parameter, value in sorted(parameters.items())}
    paths.append(write_ssv(ParameterSet("fitted", entries), out_dir / SSV_FILE))
    return paths + write_simulink_files(blocks, out_dir, source)


def _parameterized_copy(original: Path, values: Mapping[str, float], target: Path, source: str) -> Path:
    """`original` with `values` as start values in its model description. A parameterized copy
    pendfmu wrote (the FMUs packed in a pendfmu SSP) carries a start file its binary computes
    with: it is written anew from the new description, so the binary computes with the values
    the copy declares, not the ones it was packed with."""
    def write(out) -> None:
        with zipfile.ZipFile(original) as src, zipfile.ZipFile(out, "w", zipfile.ZIP_DEFLATED) as dst:
            description = _with_start_values(src.read(MODEL_DESCRIPTION), values, source)
            for info in src.infolist():
                data = src.read(info)
                if info.filename == MODEL_DESCRIPTION:
                    data = description
                elif info.filename == START_FILE:
                    data = start_file_text(description).encode()
                dst.writestr(_copy_info(info), data)

    return write_atomically(target, writer=write)


def _with_start_values(description: bytes, values: Mapping[str, float], source: str) -> bytes:
    """The model description with new start values of Real parameters (repr: exact)."""
    from lxml import etree

    root = _parse(description)
    root.set("description", f"{root.get('description', '')} [start values from {xml_text(source)}: "
                            f"{', '.join(values)}]")
    root.set("generationDateAndTime", _now())
    for variable in root.iterfind("ModelVariables/ScalarVariable"):
        real = variable.find("Real")
        if variable.get("name") in values and variable.get("causality") == "parameter" and real is not None:
            real.set("start", repr(float(values[variable.get("name")])))
    data = etree.tostring(root.getroottree(), xml_declaration=True, encoding="UTF-8")
    return data if data.endswith(b"\n") else data + b"\n"
