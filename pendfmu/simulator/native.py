"""The native stepping path: a small C library that runs the communication loop.

It is compiled from pendfmu/csrc/runner/runner.c with the FMUs' toolchain into the FMU folder's build/ (not
committed), rebuilt when its source changes, and loaded with ctypes. It calls the fmi2
functions of an instance that the checked binding (fmi.py) created, through the addresses
the binding gives, so everything about the instance (parameters, logging, errors) stays in
the binding and only the loop moves to C; a failure it reports becomes the binding's
FMUError (`CheckedFMU.failure`) with what the FMU logged.
"""

from __future__ import annotations

import ctypes
import hashlib
import os
from enum import IntEnum
from functools import lru_cache
from pathlib import Path

import numpy as np

from pendfmu.errors import UsageError
from pendfmu.fmubuild.compiler import CFLAGS, FMUS_DIR, LIBRARY_SUFFIX, SOURCE_DIR, compile_library

SOURCE = SOURCE_DIR / "runner" / "runner.c"
HEADERS = [SOURCE_DIR / "runner" / "runner.h", SOURCE_DIR / "runner" / "tear.h"]  # included by runner.c
BUILD_DIR = FMUS_DIR / "build"

# MAX_PORTS, Failure and the Structures (Unit, SystemUnit, Link, Drive, System) mirror
# runner.h, where C declares the loop's interface; tests/test_native_interface.py checks
# that both say the same.

MAX_PORTS = 64  # inputs one unit may have


class Failure(IntEnum):
    """Why a run stopped (System.fail_kind; runner.h's enum FailKind)."""

    NONE = 0
    CALL = 1  # an fmi2 call failed (the FMU has logged why)
    NOT_CONVERGED = 2  # a coupled step did not converge
    NO_MEMORY = 3  # out of memory, or more links than the loop's fixed arrays hold
    INCONSISTENT_POINT = 4  # the connected signals could not be made consistent at one instant
    TOO_MANY_PORTS = 5  # a unit has more than MAX_PORTS inputs


class Unit(ctypes.Structure):
    _fields_ = [("component", ctypes.c_void_p), ("set_real", ctypes.c_void_p),
                ("get_real", ctypes.c_void_p), ("do_step", ctypes.c_void_p),
                ("set_input_derivatives", ctypes.c_void_p)]


class SystemUnit(ctypes.Structure):
    _fields_ = [("f", Unit), ("get_state", ctypes.c_void_p), ("set_state", ctypes.c_void_p),
                ("free_state", ctypes.c_void_p)]


class Link(ctypes.Structure):
    _fields_ = [("source", ctypes.c_int), ("target", ctypes.c_int), ("source_vr", ctypes.c_uint),
                ("target_vr", ctypes.c_uint), ("hold", ctypes.c_int)]


class Drive(ctypes.Structure):
    _fields_ = [("unit", ctypes.c_int), ("vr", ctypes.c_uint), ("values", ctypes.POINTER(ctypes.c_double)),
                ("slopes", ctypes.POINTER(ctypes.c_double))]


class System(ctypes.Structure):
    _fields_ = [("n_units", ctypes.c_size_t), ("units", ctypes.POINTER(SystemUnit)),
                ("n_links", ctypes.c_size_t), ("links", ctypes.POINTER(Link)),
                ("n_drives", ctypes.c_size_t), ("drives", ctypes.POINTER(Drive)),
                ("n_groups", ctypes.c_size_t), ("group_start", ctypes.POINTER(ctypes.c_int)),
                ("group_members", ctypes.POINTER(ctypes.c_int)),
                ("tear_unit", ctypes.POINTER(ctypes.c_int)), ("tear_vr", ctypes.POINTER(ctypes.c_uint)),
                ("event_vr", ctypes.POINTER(ctypes.c_long)),
                ("tolerance", ctypes.c_double), ("max_iterations", ctypes.c_int),
                ("n_points", ctypes.c_size_t), ("times", ctypes.POINTER(ctypes.c_double)),
                ("record", ctypes.POINTER(ctypes.c_ubyte)),
                ("n_outputs", ctypes.c_size_t), ("output_unit", ctypes.POINTER(ctypes.c_int)),
                ("output_vr", ctypes.POINTER(ctypes.c_uint)), ("outputs", ctypes.POINTER(ctypes.c_double)),
                ("iterations", ctypes.c_long), ("jumps", ctypes.c_long), ("events", ctypes.c_long),
                ("fail_time", ctypes.c_double),
                ("fail_kind", ctypes.c_int),
                ("fail_unit", ctypes.c_int), ("last_change", ctypes.c_double)]


def _library_path() -> Path:
    text = SOURCE.read_bytes() + b"".join(header.read_bytes() for header in HEADERS)
    digest = hashlib.sha256(text + " ".join(CFLAGS).encode()).hexdigest()[:16]
    return BUILD_DIR / f"runner-{digest}{LIBRARY_SUFFIX}"


@lru_cache(maxsize=1)
def library() -> ctypes.CDLL:
    """The runner library, compiled first if missing or stale."""
    path = _library_path()
    if not path.exists():
        BUILD_DIR.mkdir(parents=True, exist_ok=True)
        partial = path.with_name(f".{path.name}.{os.getpid()}")
        compile_library([SOURCE], partial)  # runner.c finds its headers beside it
        os.replace(partial, path)
    lib = ctypes.CDLL(str(path))
    lib.pendfmu_run_single.restype = ctypes.c_long
    lib.pendfmu_run_single.argtypes = [
        ctypes.POINTER(Unit), ctypes.c_size_t, ctypes.POINTER(ctypes.c_double),
        ctypes.c_size_t, ctypes.POINTER(ctypes.c_uint), ctypes.POINTER(ctypes.c_double),
        ctypes.POINTER(ctypes.c_double), ctypes.c_size_t, ctypes.POINTER(ctypes.c_uint),
        ctypes.POINTER(ctypes.c_double)]
    lib.pendfmu_run_system.restype = ctypes.c_int
    lib.pendfmu_run_system.argtypes = [ctypes.POINTER(System)]
    return lib


def system_unit_of(fmu) -> SystemUnit:
    """The C view of an instance in a system: unit_of, and its FMU state functions."""
    return SystemUnit(unit_of(fmu), fmu.address("fmi2GetFMUstate"), fmu.address("fmi2SetFMUstate"),
                      fmu.address("fmi2FreeFMUstate"))


def _array(kind, values):
    return (kind * max(len(values), 1))(*values)


def run_system(fmus: list, links: list[tuple[int, int, int, int, int]], drives: list[tuple[int, int, np.ndarray,
               np.ndarray]], groups: list[list[int]], tears: list[tuple[int, int] | None], clocks: list[int | None],
               times: np.ndarray, record: np.ndarray, outputs: list[tuple[int, int]], tolerance: float,
               max_iterations: int) -> tuple[np.ndarray, System]:
    """Run the master's loop natively; returns (recorded outputs, the System with diagnostics).
    `links` are (source unit, target unit, source vr, target vr, hold: 1 for a discrete output);
    `tears` gives each group's tear as (unit, value reference) of the torn output, or None;
    `clocks` each unit's value reference of t_mode (coupled.py), or None."""
    times = np.ascontiguousarray(times, dtype=float)
    record = np.ascontiguousarray(record, dtype=np.uint8)
    result = np.empty((int(record.sum()), len(outputs)))
    keep = [np.ascontiguousarray(v, dtype=float) for _, _, values, slopes in drives for v in (values, slopes)]
    starts = np.cumsum([0] + [len(g) for g in groups])
    system = System(
        len(fmus), _array(SystemUnit, [system_unit_of(fmu) for fmu in fmus]),
        len(links), _array(Link, [Link(*link) for link in links]),
        len(drives), _array(Drive, [Drive(unit, vr, _doubles(keep[2 * j]), _doubles(keep[2 * j + 1]))
                                    for j, (unit, vr, _, _) in enumerate(drives)]),
        len(groups), _array(ctypes.c_int, [int(x) for x in starts]),
        _array(ctypes.c_int, [m for g in groups for m in g]),
        _array(ctypes.c_int, [tear[0] if tear else -1 for tear in tears]),
        _array(ctypes.c_uint, [tear[1] if tear else 0 for tear in tears]),
        _array(ctypes.c_long, [-1 if vr is None else vr for vr in clocks]), tolerance, max_iterations,
        len(times), _doubles(times), record.ctypes.data_as(ctypes.POINTER(ctypes.c_ubyte)),
        len(outputs), _array(ctypes.c_int, [u for u, _ in outputs]), _array(ctypes.c_uint, [v for _, v in outputs]),
        _doubles(result), 0, 0, 0, 0.0, Failure.NONE, -1, 0.0)
    library().pendfmu_run_system(ctypes.byref(system))
    return result, system


def unit_of(fmu) -> Unit:
    """The C view of an FMI 2.0 Co-Simulation instance of the binding (fmi.FMU2CS): its
    component and the fmi2 functions the loop calls."""
    return Unit(fmu.component, fmu.address("fmi2SetReal"), fmu.address("fmi2GetReal"), fmu.address("fmi2DoStep"),
                fmu.address("fmi2SetRealInputDerivatives"))


def _doubles(array: np.ndarray):
    return array.ctypes.data_as(ctypes.POINTER(ctypes.c_double))


def _refs(values: list[int]):
    return (ctypes.c_uint * len(values))(*values) if values else None


def run_single(unit: Unit, times: np.ndarray, input_vrs: list[int], inputs: np.ndarray, output_vrs: list[int],
               slopes: np.ndarray | None = None) -> tuple[np.ndarray, int]:
    """Step an initialized instance (`unit`: unit_of its FMU2CS) through `times`; each
    input is set to its value at the step's start and, with `slopes`, follows that slope
    over the step (linear interpolation through fmi2SetRealInputDerivatives), else it is
    held.

    Returns (outputs n_points x n_outputs, index of a failing point or -1)."""
    if len(input_vrs) > MAX_PORTS:
        raise UsageError(f"the native loop takes at most {MAX_PORTS} inputs")
    times = np.ascontiguousarray(times, dtype=float)
    inputs = np.ascontiguousarray(inputs, dtype=float).reshape(len(times), len(input_vrs))
    if slopes is not None:
        slopes = np.ascontiguousarray(slopes, dtype=float).reshape(len(times), len(input_vrs))
    outputs = np.empty((len(times), len(output_vrs)))
    failed = library().pendfmu_run_single(
        ctypes.byref(unit), len(times), _doubles(times), len(input_vrs), _refs(input_vrs), _doubles(inputs),
        None if slopes is None else _doubles(slopes), len(output_vrs), _refs(output_vrs), _doubles(outputs))
    return outputs, int(failed)
