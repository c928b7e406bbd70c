"""The exported rig as SSP 1.0 archives, for the tools that run SSP systems.

- ``rig.ssp``: the rig with the system's own connectors (``I_c`` in; ``I, x, v, a, phi, w``
  out; every other input no connection feeds), as ``pendfmu system`` writes a system: what
  fmpy's simulate_ssp, OMSimulator and ``pendfmu simulate --system`` drive and record;
- ``rig-flat.ssp``: the same rig without them (``pendfmu system --no-system-connectors``),
  for ecos and libcosim, which refuse any connection to a system connector (docs/user-guide/exchange.md,
  Other SSP tools); drive ``CurrentLoop.I_c`` there.

Both are :func:`pendfmu.ssp.rig_system` written by :func:`pendfmu.ssp.write_ssp`, so they hold
what every rig SSP holds: the connections the exported screw efficiency calls for (the
pendulum's state back to the cart on a back-drivable screw), every parameter in an SSV
binding per component, and parameterized copies of the FMUs whose binaries start from the
exported values (an importer that applies no binding runs them too).
"""

from __future__ import annotations

from pathlib import Path

from pendfmu.components import COMPONENTS, parameter_table
from pendfmu.export.plan import ExportPlan
from pendfmu.fmubuild import ensure_fmu
from pendfmu.ssp import rig_system, write_ssp
from pendfmu.ssp.rig import RIG_COMPONENTS

RIG_SSP = "rig.ssp"
FLAT_SSP = "rig-flat.ssp"


def write_rig_ssps(plan: ExportPlan, out_dir: str | Path) -> list[Path]:
    """Write RIG_SSP and FLAT_SSP of the plan's values into `out_dir`; return their paths."""
    out_dir = Path(out_dir)
    folder = {ensure_fmu(name).parent for name in RIG_COMPONENTS}.pop()
    values = {name: value for name, value in plan.given.items() if name in parameter_table()}
    eta = values.get("eta", float(COMPONENTS["Cart"].parameters["eta"].start))
    system = rig_system(eta, folder, values)
    return [write_ssp(system, out_dir / RIG_SSP), write_ssp(system, out_dir / FLAT_SSP, system_connectors=False)]
