"""SSP 1.0 (System Structure and Parameterization) files for the pendulum rig.

The rig's component FMUs, their connections and parameter values are described in
plain, standard SSP 1.0 so that other tools can load the same rig:

- :func:`rig_system` builds the :class:`System` for a screw efficiency and parameters;
- :func:`write_ssd` / :func:`read_ssd`: the SystemStructureDescription (plus its SSV files);
- :func:`write_ssv` / :func:`read_ssv`: one SystemStructureParameterValues file;
- :func:`write_ssp` / :func:`read_ssp`: the zip with SystemStructure.ssd and resources/.

Every file is validated against the normative schemas shipped with fmpy when written and
when read; problems raise :class:`SspError` naming file, line and element.
fmpy's own SSP simulation is deliberately not used (see TOOL-NOTES.md).
"""

from pendfmu.ssp._xml import SspError, schema_dir
from pendfmu.ssp.archive import read_ssp, write_ssp
from pendfmu.ssp.check import check_system
from pendfmu.ssp.fmu import describe_fmu, fmu_component
from pendfmu.ssp.model import (
    Connection, Connector, DefaultExperiment, FmuComponent, ParameterSet, ParameterValue, System, Unit,
)
from pendfmu.ssp.rig import SHARED_PARAMETERS, rig_connections, rig_system
from pendfmu.ssp.ssd import read_ssd, write_ssd
from pendfmu.ssp.ssv import read_ssv, write_ssv

__all__ = [
    "Connection", "Connector", "DefaultExperiment", "FmuComponent", "ParameterSet", "ParameterValue",
    "SHARED_PARAMETERS", "SspError", "System", "Unit", "check_system", "describe_fmu", "fmu_component",
    "read_ssd", "read_ssp", "read_ssv", "rig_connections", "rig_system", "schema_dir", "write_ssd",
    "write_ssp", "write_ssv",
]
