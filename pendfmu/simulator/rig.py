"""The whole rig driven by a recording's command current: what `pendfmu simulate` runs.

The system is built as an SSP system (pendfmu.ssp.rig_system) and stepped by the
fmpy master, so the same description can be written out for other tools.
"""

from __future__ import annotations

from collections.abc import Mapping

import pandas as pd

from pendfmu.components import CART
from pendfmu.fmubuild import build_all
from pendfmu.fmubuild.compiler import FMUS_DIR
from pendfmu.parameters import recording_values
from pendfmu.recording import Recording, RecordingError
from pendfmu.simulator.master import ExternalInput, Master, check_plan
from pendfmu.ssp import rig_system
from pendfmu.ssp.rig import RIG_OUTPUTS

# The columns of `pendfmu simulate`'s output, in order (a command-line contract): the rig
# system's output connectors.
OUTPUT_COLUMNS = dict(RIG_OUTPUTS)


def experiment_parameters(parameters: Mapping[str, float], recording: Recording) -> dict[str, float]:
    """Rig parameters for one recording: the given values, then the values its sidecar
    fixes for this experiment, then its known initial states, checked together
    (parameters.recording_values)."""
    return recording_values(parameters, recording)


def simulate_recording(parameters: Mapping[str, float], recording: Recording, step: float = 2e-4,
                       interpolation: str = "hold") -> pd.DataFrame:
    """Simulate the rig driven by the recording's `I_c` and return time, I, x, v, a, phi, w
    at the recording's time stamps."""
    if "I_c" not in recording.signals:
        raise RecordingError(f"{recording.path}: no column 'I_c' (the command current that drives the rig); "
                             f"columns: {', '.join(('time', *recording.signals))}")
    check_plan(recording.time, step, str(recording.path))
    values = experiment_parameters(parameters, recording)
    build_all()
    system = rig_system(values.get("eta", CART.variable("eta").start), FMUS_DIR, values, step_size=step)
    master = Master.from_system(system)
    drive = ExternalInput(recording.time, recording.signal("I_c"), interpolation)
    (fed,) = system.boundary("input")["I_c"]  # the system input I_c feeds CurrentLoop.I_c
    result = master.run(recording.time, list(OUTPUT_COLUMNS.values()), {".".join(fed): drive})
    return result.rename(columns={full: short for short, full in OUTPUT_COLUMNS.items()})
