"""What a design needs from a fit result: the rig's values and the encoders' resolutions.

The result is read by the project's reader (fitting.result.read_result); its "parameters"
hold every value the fit ran with, fitted and known. A value the result lacks (a stage fit
of the current loop alone has no cart) is the reference rig's value (docs/user-guide/model.md), and the design says so.
The resolutions come from the sidecars of the recordings the fit read (provenance inputs),
where they still lie beside them; else the paper's 1024-count encoders.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

from pendfmu.components import parameter_table, rig_defaults
from pendfmu.errors import BadInput

# The values the controller's design reads (RigModel.from_parameters), which a fit must have.
DESIGN_PARAMETERS = ("m_c", "m_p", "l", "J_p", "g", "eta", "eta_back", "k_M", "k_D", "k_fwc", "F_Kc", "F_Sc",
                     "k_fwp", "T_i", "dIdt_max")


def rig_values(result) -> tuple[dict[str, float], list[str]]:
    """(every rig parameter's value, the names taken from the reference rig) of a FitResult."""
    table = parameter_table()
    values = rig_defaults()
    fitted = {k: v for k, v in result.parameters.items() if k in table}
    for name, value in fitted.items():
        if not isinstance(value, (int, float)) or not math.isfinite(value):
            raise BadInput(f"the result's parameter {name} = {value!r} is not a finite number")
        values[name] = float(value)
    return values, [name for name in DESIGN_PARAMETERS if name not in fitted]


def sidecar_resolutions(result) -> dict[str, float]:
    """The x and phi resolutions the recordings' sidecars give (the first found of each)."""
    found: dict[str, float] = {}
    for entry in result.provenance.get("inputs", []):
        sidecar = Path(str(entry.get("path", ""))).with_suffix(".json")
        try:
            signals = json.loads(sidecar.read_text()).get("signals", {})
        except (OSError, ValueError, AttributeError):
            continue
        for name in ("x", "phi"):
            resolution = signals.get(name, {}).get("resolution") if isinstance(signals.get(name), dict) else None
            if isinstance(resolution, (int, float)) and resolution > 0:
                found.setdefault(name, float(resolution))
    return found
