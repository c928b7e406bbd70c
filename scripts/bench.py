"""Speed of co-simulation and fitting, as ratios measured in one run (issue 6).

Co-simulation: the same FMUs and the same 10 s rig experiment (a current step, self-locking
screw) at 0.2 ms communication steps, stepped by
  (a) a plain fmpy FMU2Slave loop in Python (the usual way to drive FMUs),
  (b) pendfmu's master, native and Python engines,
  (c) the plainest C loop over the same binaries (scripts/bench_limit.c): the limit.
End to end (issue 13): `pendfmu simulate` (read the recording, simulate, write the result)
against what a plain fmpy user writes for the same job, on a 20 s recording at 0.2 ms.
Fitting: `fit all` on the standard virtual-rig set, and the current stage against a naive
fit that calls fmpy.simulate_fmu inside scipy's least_squares.
Also the cost's growth with recording length (1x, 2x, 4x).

    python scripts/bench.py [--quick] [--end-to-end-only] [--json PATH]

With --json, the figures are written to PATH too, with the machine, the date and pendfmu's
version: the documentation's Performance page is made from docs/performance.json, written so.
"""

from __future__ import annotations

import argparse
import contextlib
import ctypes
import importlib
import io
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from pendfmu.components import CART
from pendfmu.fmubuild.compiler import FMUS_DIR, LIBRARY_SUFFIX, SOURCE_DIR, compile_library
from pendfmu.simulator.component import ComponentFMU
from pendfmu.simulator.master import ExternalInput, Master
from pendfmu.simulator.native import unit_of
from pendfmu.ssp import rig_system

STEP = 2e-4
COMMAND = 1.5


class Figures:
    """What a run measured, by part, for --json: each part's title and its figures (name,
    value, unit), in the order they were printed."""

    def __init__(self):
        self.parts: dict[str, dict] = {}
        self.load = os.getloadavg()[0]  # how busy the machine was when the run began (1-minute load average)

    def part(self, key: str, title: str) -> None:
        self.parts[key] = {"title": title, "figures": []}

    def add(self, key: str, name: str, value: float, unit: str) -> None:
        self.parts[key]["figures"].append({"name": name, "value": float(f"{value:.4g}"), "unit": unit})

    def document(self, command: list[str]) -> dict:
        """The JSON document: the run's machine, date, versions and command, and the parts."""
        from importlib import metadata
        from datetime import datetime, timezone

        from pendfmu import __version__

        libraries = {name: metadata.version(name) for name in ("numpy", "scipy", "fmpy")}
        machine = {"platform": platform.platform(), "processor": platform.machine(), "cpus": os.cpu_count(),
                   "python": platform.python_version(), **libraries,
                   "load": [round(self.load, 2), round(os.getloadavg()[0], 2)]}  # 1-minute load average, first and last
        return {"pendfmu": __version__, "date": datetime.now(timezone.utc).isoformat(timespec="seconds"),
                "machine": machine, "command": " ".join(["python", "scripts/bench.py", *command]),
                "parts": self.parts}


FIGURES = Figures()


def timed(function, *args, **kwargs):
    start = time.perf_counter()
    value = function(*args, **kwargs)
    return time.perf_counter() - start, value


def plain_fmpy_loop(seconds: float) -> tuple[float, float]:
    """What a user writes with fmpy: set, step, get, copy, record, for every FMU and step.
    It records phi at every step, as the master does in (b), so that both do the same work.
    Timed from the first step, without instantiation (as (b) and (c) are)."""
    fmus = {name: ComponentFMU(name) for name in ("CurrentLoop", "Cart", "Pendulum")}
    loop, cart, pendulum = (fmus[n].slave for n in ("CurrentLoop", "Cart", "Pendulum"))
    vr = {n: fmus[n].vr for n in fmus}
    start = time.perf_counter()
    recorded = [pendulum.getReal([vr["Pendulum"]["phi"]])[0]]
    t = 0.0
    for k in range(int(round(seconds / STEP))):
        t = k * STEP
        loop.setReal([vr["CurrentLoop"]["I_c"]], [COMMAND])
        loop.doStep(t, STEP)
        current = loop.getReal([vr["CurrentLoop"]["I_mean"]])[0]
        cart.setReal([vr["Cart"]["I"]], [current])
        cart.doStep(t, STEP)
        acceleration = cart.getReal([vr["Cart"]["a"]])[0]
        pendulum.setReal([vr["Pendulum"]["a"]], [acceleration])
        pendulum.doStep(t, STEP)
        recorded.append(pendulum.getReal([vr["Pendulum"]["phi"]])[0])
    elapsed = time.perf_counter() - start
    for fmu in fmus.values():
        fmu.free()
    return elapsed, recorded[-1]


MASTER = {}


def master_run(seconds: float, engine: str) -> float:
    """One run of the rig by pendfmu's master; the master (and its FMU instances) is kept
    between calls, as a fit keeps it."""
    if engine not in MASTER:
        MASTER[engine] = Master.from_system(rig_system(CART.variable("eta").start, FMUS_DIR, {}))
    times = np.arange(int(round(seconds / STEP)) + 1) * STEP
    frame = MASTER[engine].run(times, ["Pendulum.phi"], {"CurrentLoop.I_c": ExternalInput([0.0], [COMMAND])},
                               engine=engine)
    return float(frame["Pendulum.phi"].iloc[-1])


def c_limit(seconds: float, library: ctypes.CDLL) -> float:
    fmus = {name: ComponentFMU(name) for name in ("CurrentLoop", "Cart", "Pendulum")}
    packed = [unit_of(fmus[n].slave) for n in ("CurrentLoop", "Cart", "Pendulum")]
    array = (type(packed[0]) * 3)(*packed)
    vrs = [fmus["CurrentLoop"].vr["I_c"], fmus["CurrentLoop"].vr["I_mean"], fmus["Cart"].vr["I"], fmus["Cart"].vr["a"],
           fmus["Pendulum"].vr["a"], fmus["Pendulum"].vr["phi"]]
    n_steps = int(round(seconds / STEP))
    recorded = np.zeros(n_steps + 1)
    start = time.perf_counter()
    library.bench_limit(array, (ctypes.c_uint * 6)(*vrs), n_steps, ctypes.c_double(STEP), ctypes.c_double(COMMAND),
                        recorded.ctypes.data_as(ctypes.POINTER(ctypes.c_double)))
    elapsed = time.perf_counter() - start
    for fmu in fmus.values():
        fmu.free()
    return elapsed, recorded[-1]


def build_limit(directory: Path) -> ctypes.CDLL:
    source = Path(__file__).with_name("bench_limit.c")
    library = directory / f"bench_limit{LIBRARY_SUFFIX}"
    compile_library([source], library, [SOURCE_DIR / "runner"])
    from pendfmu.simulator.native import Unit

    lib = ctypes.CDLL(str(library))
    lib.bench_limit.restype = ctypes.c_int
    lib.bench_limit.argtypes = [ctypes.POINTER(Unit), ctypes.POINTER(ctypes.c_uint), ctypes.c_size_t,
                                ctypes.c_double, ctypes.c_double, ctypes.POINTER(ctypes.c_double)]
    return lib


REPEATS = 3


def best_of(run, *args, **kwargs) -> tuple:
    """The fastest of REPEATS runs (the others met a busy machine): run returns (seconds, ...)."""
    return min((run(*args, **kwargs) for _ in range(REPEATS)), key=lambda timing: timing[0])


def cosimulation(seconds: float) -> None:
    title = (f"co-simulation of the rig, {seconds:g} s at {STEP * 1e3:g} ms (3 FMUs, {seconds / STEP:.0f} steps), "
             f"best of {REPEATS}")
    print(f"{title}:")
    FIGURES.part("cosimulation", title)
    with tempfile.TemporaryDirectory() as tmp:
        library = build_limit(Path(tmp))
        plain, phi_a = best_of(plain_fmpy_loop, seconds)
        python, _ = timed(master_run, seconds, "python")
        cold, _ = timed(master_run, seconds, "native")
        native, phi_b = best_of(timed, master_run, seconds, "native")
        limit, phi_c = best_of(c_limit, seconds, library)
    print(f"  (a) plain fmpy loop      {plain:8.3f} s")
    print(f"  (b) pendfmu master, python {python:6.3f} s   native {native:.3f} s "
          f"(first run, with instantiation: {cold:.3f} s)")
    print(f"  (c) C loop (limit)       {limit:8.3f} s")
    print(f"  native master vs plain fmpy loop: {plain / native:6.1f}x faster")
    print(f"  native master vs C limit:         {native / limit:6.2f}x slower")
    print(f"  (the ceiling: the C limit is {plain / limit:.1f}x faster than the plain fmpy loop)")
    print(f"  (same result: phi {phi_a:.6f} / {phi_b:.6f} / {phi_c:.6f}; (b) interpolates inputs, (a) and (c) hold)")
    for name, value, unit in (("(a) plain fmpy loop", plain, "s"), ("(b) pendfmu master, python engine", python, "s"),
                              ("(b) pendfmu master, native engine", native, "s"),
                              ("(b) native, first run with instantiation", cold, "s"),
                              ("(c) C loop (the limit)", limit, "s"),
                              ("native master against the plain fmpy loop", plain / native, "x faster"),
                              ("native master against the C limit", native / limit, "x slower")):
        FIGURES.add("cosimulation", name, value, unit)


END_TO_END_OUTPUTS = {"I": ("CurrentLoop", "I"), "x": ("Cart", "x"), "v": ("Cart", "v"), "a": ("Cart", "a"),
                      "phi": ("Pendulum", "phi"), "w": ("Pendulum", "w")}


def step_recording(path: Path, seconds: float) -> Path:
    """A recording of a command current alone: +-1.5 A steps every second, sampled at STEP."""
    from pendfmu.recording import Recording, write_recording

    time = np.arange(int(round(seconds / STEP)) + 1) * STEP
    command = np.where(np.floor(time) % 2 == 0, 1.5, -1.5)
    command[time < 0.02] = 0.0
    return write_recording(Recording(None, time, {"I_c": command}), path)


def plain_end_to_end(recording: Path, out: Path, outputs: tuple[str, ...] = ("phi",)) -> tuple[float, float]:
    """What a plain fmpy user writes for `pendfmu simulate`: pandas.read_csv, the plain loop of
    plain_fmpy_loop driven by the recording's I_c (held over each step, as simulate does by
    default), and pandas' to_csv (exact by default). Timed from read_csv to the end of to_csv;
    instantiating the three FMU2Slave objects is not timed, as in plain_fmpy_loop. `outputs`:
    what it records at every step and writes (phi alone, as plain_fmpy_loop, or all six
    columns of simulate's output, read with one getReal per FMU)."""
    import pandas as pd

    fmus = {name: ComponentFMU(name) for name in ("CurrentLoop", "Cart", "Pendulum")}
    loop, cart, pendulum = (fmus[n].slave for n in ("CurrentLoop", "Cart", "Pendulum"))
    vr = {n: fmus[n].vr for n in fmus}
    reads = [(fmus[c].slave, [vr[c][v] for o, (cc, v) in END_TO_END_OUTPUTS.items() if cc == c and o in outputs])
             for c in ("CurrentLoop", "Cart", "Pendulum")]
    reads = [(slave, refs) for slave, refs in reads if refs]

    def sample() -> list[float]:
        return [value for slave, refs in reads for value in slave.getReal(refs)]

    start = time.perf_counter()
    frame = pd.read_csv(recording)
    times, command = frame["time"].to_numpy(), frame["I_c"].to_numpy()
    rows = [sample()]
    for k in range(len(times) - 1):
        t, h = times[k], times[k + 1] - times[k]
        loop.setReal([vr["CurrentLoop"]["I_c"]], [command[k]])
        loop.doStep(t, h)
        current = loop.getReal([vr["CurrentLoop"]["I_mean"]])[0]
        cart.setReal([vr["Cart"]["I"]], [current])
        cart.doStep(t, h)
        acceleration = cart.getReal([vr["Cart"]["a"]])[0]
        pendulum.setReal([vr["Pendulum"]["a"]], [acceleration])
        pendulum.doStep(t, h)
        rows.append(sample())
    result = pd.DataFrame(rows, columns=[o for o in END_TO_END_OUTPUTS if o in outputs])
    result.insert(0, "time", times)
    result.to_csv(out, index=False)
    elapsed = time.perf_counter() - start
    for fmu in fmus.values():
        fmu.free()
    return elapsed, float(result["phi"].iloc[-1])


def pendfmu_simulate(recording: Path, out: Path) -> tuple[float, float]:
    """`pendfmu simulate --input REC --out OUT` in-process (pendfmu.cli.main), all of it:
    arguments, reading REC and its sidecar, checking and building the FMUs if stale,
    loading and instantiating them, the SSP system and master, the run, writing OUT."""
    from pendfmu.cli import main as cli

    with contextlib.redirect_stdout(io.StringIO()):
        elapsed, code = timed(cli, ["simulate", "--input", str(recording), "--out", str(out)])
    if code != 0:
        raise RuntimeError(f"pendfmu simulate failed with exit code {code}")
    return elapsed, float("nan")


def simulate_stages(recording: Path, out: Path) -> dict[str, float]:
    """The three parts of `pendfmu simulate`, each timed alone (best of REPEATS)."""
    from pendfmu.recording import read_recording
    from pendfmu.recording.writer import write_signals
    from pendfmu.simulator.rig import simulate_recording

    read, rec = best_of(timed, read_recording, recording)
    simulate, result = best_of(timed, simulate_recording, {}, rec)
    columns = {name: result[name].to_numpy() for name in result.columns[1:]}
    write, _ = best_of(timed, write_signals, out, result["time"].to_numpy(), columns)
    write_mat, _ = best_of(timed, write_signals, out.with_suffix(".mat"), result["time"].to_numpy(), columns)
    return {"read": read, "simulate": simulate, "write": write, "write .mat": write_mat}


def command_line(recording: Path, out: Path) -> tuple[float, float]:
    """The command as a user runs it (a new Python process: start-up and imports included),
    and the cost of Python's start-up and pendfmu's imports alone; best of REPEATS each."""
    command = [sys.executable, "-m", "pendfmu", "simulate", "--input", str(recording), "--out", str(out)]
    imports = [sys.executable, "-c", "import pendfmu.cli, pendfmu.simulator.rig"]
    whole = min(timed(subprocess.run, command, check=True, capture_output=True)[0] for _ in range(REPEATS))
    start = min(timed(subprocess.run, imports, check=True)[0] for _ in range(REPEATS))
    return whole, start


def end_to_end(seconds: float = 20.0) -> float:
    """pendfmu simulate against a plain fmpy user's script on the same recording; the ratio."""
    title = (f"end to end: a {seconds:g} s recording of I_c at {STEP * 1e3:g} ms ({seconds / STEP + 1:.0f} samples), "
             f"best of {REPEATS}")
    print(f"{title}:")
    FIGURES.part("end_to_end", title)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        recording = step_recording(folder / "rec.csv", seconds)
        cold, _ = pendfmu_simulate(recording, folder / "ours.csv")  # first in this process: parses the FMUs' XML
        ours, _ = best_of(pendfmu_simulate, recording, folder / "ours.csv")
        ours_mat, _ = best_of(pendfmu_simulate, recording, folder / "ours.mat")
        plain, phi_plain = best_of(plain_end_to_end, recording, folder / "plain.csv")
        plain_all, _ = best_of(plain_end_to_end, recording, folder / "plain_all.csv", tuple(END_TO_END_OUTPUTS))
        stages = simulate_stages(recording, folder / "stages.csv")
        whole, start = command_line(recording, folder / "cli.csv")
        import pandas as pd

        phi_ours = float(pd.read_csv(folder / "ours.csv")["phi"].iloc[-1])
    print(f"  pendfmu simulate, in-process main(), .csv  {ours:7.3f} s   (.mat {ours_mat:.3f} s; "
          f"first run in the process {cold:.3f} s)")
    print("    " + ", ".join(f"{name} {value * 1e3:.0f} ms" for name, value in stages.items())
          + " (each alone; simulate includes loading the FMUs)")
    print(f"  plain fmpy: read_csv + FMU2Slave loop + to_csv of time, phi   {plain:7.3f} s")
    print(f"  plain fmpy, recording and writing simulate's six outputs     {plain_all:7.3f} s")
    print(f"  pendfmu simulate vs plain fmpy: {plain / ours:5.1f}x faster "
          f"({plain_all / ours:.1f}x against the same six outputs written)")
    print(f"  command line (new process): {whole:.3f} s, of which Python start-up and imports {start:.3f} s")
    print(f"  (same result: phi at the end {phi_plain:.6f} / {phi_ours:.6f}; the plain loop holds the coupled "
          f"inputs, simulate interpolates them)")
    figures = [("pendfmu simulate, in-process, .csv", ours, "s"), ("pendfmu simulate, in-process, .mat", ours_mat, "s"),
               ("pendfmu simulate, first run in the process", cold, "s"),
               *((f"{name}, timed alone (simulate: loading the FMUs included)" if name == "simulate" else
                  f"{name}, timed alone", value, "s") for name, value in stages.items()),
               ("plain fmpy: read_csv, FMU2Slave loop, to_csv of time and phi", plain, "s"),
               ("plain fmpy, writing simulate's six outputs", plain_all, "s"),
               ("pendfmu simulate against plain fmpy", plain / ours, "x faster"),
               ("the same, six outputs written by both", plain_all / ours, "x faster"),
               ("command line, a new process", whole, "s"), ("of it: Python start-up and imports", start, "s")]
    for name, value, unit in figures:
        FIGURES.add("end_to_end", name, value, unit)
    return plain / ours


def scaling() -> None:
    """Times for 1x, 2x, 4x the length, and the straight line through them: a fixed cost per
    run (resetting the FMUs, building the frame) plus a cost per simulated second."""
    print("cost against recording length (native master, rig):")
    FIGURES.part("scaling", "cost against recording length (native master, rig)")
    lengths = np.array([2.5, 5.0, 10.0])
    elapsed = np.array([best_of(timed, master_run, length, "native")[0] for length in lengths])
    for length, seconds in zip(lengths, elapsed):
        print(f"  {length / lengths[0]:.0f}x ({length:g} s): {seconds:.4f} s  ratio {seconds / elapsed[0]:.2f}")
        FIGURES.add("scaling", f"{length / lengths[0]:.0f}x ({length:g} s simulated)", seconds, "s")
    per_second, fixed = np.polyfit(lengths, elapsed, 1)
    worst = np.max(np.abs(fixed + per_second * lengths - elapsed) / elapsed)
    print(f"  line: {fixed * 1e3:.2f} ms per run + {per_second * 1e3:.3f} ms per simulated second; "
          f"largest deviation from it {100 * worst:.1f} %")
    FIGURES.add("scaling", "fixed cost per run", fixed * 1e3, "ms")
    FIGURES.add("scaling", "cost per simulated second", per_second * 1e3, "ms")


def naive_current_fit(path: Path, start: dict[str, float]) -> tuple[float, int, dict[str, float]]:
    """least_squares over fmpy.simulate_fmu, as one would write it without pendfmu."""
    from fmpy import simulate_fmu
    from scipy.optimize import least_squares

    from pendfmu.fmubuild import ensure_fmu
    from pendfmu.recording import read_recording

    recording = read_recording(path)
    fmu = str(ensure_fmu("CurrentLoop"))
    signal = np.array(list(zip(recording.time, recording.signal("I_c"))), dtype=[("time", float), ("I_c", float)])
    step = float(np.diff(recording.time).mean())
    calls = [0]

    def residual(log_values):
        calls[0] += 1
        values = dict(zip(("T_i", "dIdt_max"), np.exp(log_values)))
        result = simulate_fmu(fmu, start_values=values, input=signal, output=["I"], stop_time=recording.time[-1],
                              output_interval=step, fmi_type="CoSimulation")
        simulated = np.interp(recording.time, result["time"], result["I"])
        return simulated - recording.signal("I")

    elapsed, result = timed(least_squares, residual, np.log([start["T_i"], start["dIdt_max"]]), method="trf")
    return elapsed, calls[0], dict(zip(("T_i", "dIdt_max"), np.exp(result.x)))


def fitting(quick: bool) -> None:
    from pendfmu.fitting.identification import fit
    from pendfmu.fitting.optimizer import GlobalOptions
    from pendfmu.virtual_rig import write_experiments

    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        write_experiments(folder, seed=1)
        start = {"T_i": 0.6e-3, "dIdt_max": 1800.0}
        naive, calls, values = best_of(naive_current_fit, folder / "current-steps.csv", start)
        ours, result = best_of(timed, fit, "current", [folder / "current-steps.csv"], start, harmonic="off",
                               global_search=GlobalOptions(enabled=False), progress=False, uncertainty="jacobian")
        print(f"current stage, local fit from the same start, best of {REPEATS}:")
        FIGURES.part("fitting", f"current stage, local fit from the same start, best of {REPEATS}")
        for name, value, unit in (("naive: fmpy.simulate_fmu inside least_squares", naive, "s"),
                                  ("naive: simulations", calls, ""), ("pendfmu", ours, "s"),
                                  ("pendfmu: simulations", result.nfev, ""),
                                  ("pendfmu against naive", naive / ours, "x faster")):
            FIGURES.add("fitting", name, value, unit)
        print(f"  naive (simulate_fmu in least_squares): {naive:6.3f} s, {calls} simulations")
        print(f"  pendfmu:                               {ours:6.3f} s, {result.nfev} simulations "
              f"-> {naive / ours:.1f}x faster ({naive / calls / (ours / result.nfev):.1f}x per simulation)")
        if not quick:
            wall, result = timed(fit, "all", folder, seed=1, progress=False)
            intervals = sum(u.get("seconds", 0.0) for u in result.uncertainty.values())
            print(f"fit all on the standard set: {wall:.1f} s wall, {result.nfev} simulations, "
                  f"{result.failures} failed; of it the bootstrap intervals {intervals:.1f} s")
            FIGURES.part("fit_all", "fit all on the standard virtual-rig set (seed 1), bootstrap intervals")
            for name, value, unit in (("wall time", wall, "s"), ("simulations", result.nfev, ""),
                                      ("of it: the bootstrap intervals", intervals, "s")):
                FIGURES.add("fit_all", name, value, unit)


def foreign_fit() -> None:
    """Issue 13: a foreign cart FMU (tests/foreign, not made with pendfmu's framework)
    fitted with 6 free parameters to three recordings, by pendfmu and by the hand-written
    scipy least_squares over fmpy's FMU2Slave (scripts/foreign_baseline.py), from the same
    start, both local fits without intervals. Neither side's time includes loading the
    FMU (pendfmu's first fit, which unpacks it, is run once before timing)."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    import foreign_baseline as baseline
    from foreign.build import build
    from foreign.recordings import FIT_NAMES, FITTED, TRUTH, write_recordings

    from pendfmu.fitting.identification import fit
    from pendfmu.fitting.optimizer import GlobalOptions

    with tempfile.TemporaryDirectory() as tmp:
        fmu = build("ForeignCart", tmp)
        csvs = write_recordings(fmu, Path(tmp) / "recordings")
        start = {p: TRUTH[p] * baseline.START_FACTORS[p] for p in FITTED}
        known = {"m": TRUTH["m"]}
        files = [csvs[name] for name in FIT_NAMES]

        def ours():
            return fit(fmu, files, {**known, **start}, free=list(FITTED), progress=False,
                       global_search=GlobalOptions(enabled=False), uncertainty="jacobian")

        ours()
        mine, result = best_of(timed, ours)
        theirs = min((baseline.fit(fmu, files, start, known) for _ in range(REPEATS)), key=lambda r: r["seconds"])
    worst = max(abs(result.parameters[p] / TRUTH[p] - 1) for p in FITTED)
    worst_theirs = max(abs(theirs["estimate"][p] / TRUTH[p] - 1) for p in FITTED)
    title = (f"foreign cart fit (6 parameters, 3 recordings of 8 s at 1 ms), local fits from the same start, "
             f"best of {REPEATS}")
    print(f"{title}:")
    FIGURES.part("foreign", title)
    for name, value, unit in (("scipy least_squares over FMU2Slave", theirs["seconds"], "s"), ("pendfmu", mine, "s"),
                              ("pendfmu against least_squares", theirs["seconds"] / mine, "x faster")):
        FIGURES.add("foreign", name, value, unit)
    print(f"  scipy least_squares over FMU2Slave: {theirs['seconds']:6.3f} s, {theirs['simulations']} simulations, "
          f"largest error {100 * worst_theirs:.4f} %")
    print(f"  pendfmu:                            {mine:6.3f} s, {3 * result.nfev} simulations, "
          f"largest error {100 * worst:.4f} % -> {theirs['seconds'] / mine:.1f}x faster")


def dask_scaling(stage: str = "pendulum") -> None:
    """The global search of a stage's fit (the parallel part of a fit; the local refinement
    after it is serial) on a Dask LocalCluster with 1 and with 2 workers. The pendulum stage
    by default: its 30 s decay makes it the stage whose global search costs most."""
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        print("dask: not installed (pip install 'pendfmu[distributed]')")
        return
    from pendfmu.components import rig_defaults
    from pendfmu.fitting.stages import STAGES, make_experiment, stage_free_parameters
    from pendfmu.fitting.optimizer import GlobalOptions, global_search
    from pendfmu.recording import read_recording
    from pendfmu.fitting.residuals import Residuals
    from pendfmu.virtual_rig import standard_experiments, write_experiments

    chosen = [e for e in standard_experiments() if e.name.startswith(f"{stage}-")][:1]
    with tempfile.TemporaryDirectory() as tmp:
        write_experiments(tmp, seed=2, experiments=chosen)
        values = rig_defaults()
        experiments = [make_experiment(read_recording(p), stage, values) for p in sorted(Path(tmp).glob("*.csv"))]
        free = stage_free_parameters(stage, experiments, None, [], {}, values)
        spec = STAGES[stage]
        coarse = {**values, **({"solver_step": spec.coarse_solver_step} if spec.coarse_solver_step else {})}
        residuals = Residuals(experiments, free, coarse, decimate=spec.coarse_decimate)  # as fit() builds it
        times = {}
        for workers in (1, 2):  # default workers: the fit pauses their profiler itself
            with LocalCluster(n_workers=workers, threads_per_worker=1, host="127.0.0.1",
                              dashboard_address=":0") as cluster, Client(cluster.scheduler_address) as client:
                # Workers that have imported pendfmu, as on a cluster that served a fit before: the
                # imports happen once per worker process and, done in parallel, would flatter 2 workers.
                client.run(importlib.import_module, "pendfmu.fitting.residuals")
                options = GlobalOptions(scheduler=cluster.scheduler_address)
                times[workers], (_, _, nfev, _) = best_of(timed, global_search, residuals, len(free), 3, options)
    print(f"dask, global search of a {stage} fit on {chosen[0].name} ({nfev} simulations), best of {REPEATS}: "
          f"1 worker {times[1]:.1f} s, 2 workers {times[2]:.1f} s -> {times[1] / times[2]:.2f}x")
    FIGURES.part("dask", f"dask, global search of a {stage} fit on {chosen[0].name} ({nfev} simulations), "
                         f"best of {REPEATS}")
    for name, value, unit in (("1 worker", times[1], "s"), ("2 workers", times[2], "s"),
                              ("2 workers against 1", times[1] / times[2], "x faster")):
        FIGURES.add("dask", name, value, unit)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="skip the full fit-all timing")
    parser.add_argument("--end-to-end-only", action="store_true", help="only the pendfmu simulate comparison")
    parser.add_argument("--foreign-only", action="store_true", help="only the foreign FMU fit against plain scipy")
    parser.add_argument("--json", metavar="PATH", help="also write the figures, the machine, the date and pendfmu's "
                                                       "version to PATH (docs/performance.json: the docs' tables)")
    args = parser.parse_args()
    print(f"python {sys.version.split()[0]}; one run, on this machine now")
    if args.end_to_end_only:
        end_to_end()
    elif args.foreign_only:
        foreign_fit()
    else:
        cosimulation(10.0)
        end_to_end()
        scaling()
        fitting(args.quick)
        foreign_fit()
        dask_scaling()
    if args.json:
        document = FIGURES.document(sys.argv[1:])
        Path(args.json).write_text(json.dumps(document, indent=1) + "\n", encoding="utf-8")
        print(f"figures written to {args.json}")


if __name__ == "__main__":
    main()
