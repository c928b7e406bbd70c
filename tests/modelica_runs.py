"""Run the Modelica library with rumoca, and the component FMUs, on a common time grid.

rumoca 0.10.2 takes no time-varying inputs, so every Modelica run is a closed model
(an example of the library, or a test bench in tests/modelica/) whose inputs are bound
by equations; the FMU side is driven through ComponentFMU with the same input functions,
their derivatives included where the input is smooth.

rumoca's `dt` is only the output grid: its solver picks its own steps under rtol/atol
and adds a row at each event (twice: before and after), so an event's time is exact in
the result, not rounded to the grid.
"""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np
import rumoca

from modelica_declarations import LIBRARY

TEST_MODELS = Path(__file__).resolve().parent / "modelica"

# Two solver settings: the comparisons use TIGHT; LOOSE shows that a difference is the
# solver's error (it grows about 100x when the tolerance does) and not a model difference.
TIGHT = rumoca.SimConfig(rtol=1e-10, atol=1e-12)
LOOSE = rumoca.SimConfig(rtol=1e-8, atol=1e-10)


@functools.cache
def _session() -> rumoca.Session:
    return rumoca.Session(roots=[str(LIBRARY.parent)])


@functools.cache
def compiled(model: str) -> rumoca.Model:
    """`PendulumID.X` from the library, or a bare name from a file tests/modelica/<name>.mo."""
    if model.startswith("PendulumID."):
        return _session().load(str(LIBRARY / "package.mo"), model=model)
    path = TEST_MODELS / f"{model}.mo"
    if not path.is_file():
        raise FileNotFoundError(f"no test model {path}")
    return _session().load(str(path), model=model)


def simulate(model: str, stop: float, dt: float, params: dict | None = None,
             config: rumoca.SimConfig = TIGHT) -> rumoca.Result:
    return compiled(model).simulate(t=(0.0, stop), dt=dt, config=config, params=params)


def at_times(result: rumoca.Result, names: list[str], times: np.ndarray) -> dict[str, np.ndarray]:
    """`names` at each of `times`, which must be output points of the result; at an event
    on the grid, the value before it (the FMU reports a communication point's value
    before the inputs set there act)."""
    t = np.asarray(result.time)
    rows = np.searchsorted(t, times - 1e-9, side="left")
    rows = np.minimum(rows, len(t) - 1)
    off = np.abs(t[rows] - times)
    if off.max() > 1e-9:
        raise ValueError(f"time {times[off.argmax()]} is not an output point of the rumoca result")
    return {name: np.asarray(result[name])[rows] for name in names}


def modelica_edges(result: rumoca.Result, mode: str) -> list[tuple[float, int, int]]:
    """(time, old mode, new mode) of each change of the Integer `mode` in a rumoca result."""
    t, m = np.asarray(result.time), np.asarray(result[mode])
    changed = np.nonzero(np.diff(m))[0] + 1
    return [(float(t[k]), int(m[k - 1]), int(m[k])) for k in changed]


def fmu_edges(run: dict[str, np.ndarray]) -> list[tuple[float, int, int]]:
    """The same from a ComponentFMU run that recorded `mode` and `t_mode`; t_mode is the
    event time the FMU located (to 1e-12 s). It holds only the last change of a step, so
    the runs use steps much shorter than the time between mode changes."""
    m = run["mode"]
    changed = np.nonzero(np.diff(m))[0] + 1
    return [(float(run["t_mode"][k]), int(m[k - 1]), int(m[k])) for k in changed]


def edge_time_error(modelica: list, fmu: list) -> float:
    """Largest |time difference| of corresponding edges; the mode sequences must agree."""
    assert [e[1:] for e in modelica] == [e[1:] for e in fmu], (modelica, fmu)
    return max(abs(a[0] - b[0]) for a, b in zip(modelica, fmu))


def assert_cart_bench_matches(bench: str, fmu: dict[str, np.ndarray], min_edges: int) -> None:
    """A Modelica cart bench (tests/modelica/<bench>.mo, 2 s) against the Cart FMU's run of
    the same case: the same mode sequence with at least `min_edges` changes, edges within
    1e-6 s (as test_modelica_behaviour), a difference that grows when rumoca's tolerance is
    loosened (the solver's error, not a model difference), and x within 1e-6 of its range
    at the FMU's sample times."""
    tight = simulate(bench, 2.0, 1e-3)
    error = edge_time_error(modelica_edges(tight, "cart.mode"), fmu_edges(fmu))
    loose = edge_time_error(modelica_edges(simulate(bench, 2.0, 1e-3, config=LOOSE), "cart.mode"), fmu_edges(fmu))
    assert len(fmu_edges(fmu)) >= min_edges
    assert error < 1e-6
    assert loose > 10 * error
    grid = np.asarray(tight.time)
    on_grid = np.isin(np.round(grid, 9), np.round(fmu["time"], 9))
    x = np.interp(fmu["time"], grid[on_grid], np.asarray(tight["cart.x"])[on_grid])
    assert np.max(np.abs(x - fmu["x"])) < 1e-6 * np.ptp(fmu["x"])
