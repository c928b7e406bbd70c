"""The package's shape, held by tests (issue 23): no import cycle, no long function, and
the public names of each documented submodule pinned.

The import graph is read from the source (every `import` and `from ... import`, at any
depth: a function-level import ties two modules as much as a top-level one), so a cycle
cannot hide behind a lazy import.
"""

from __future__ import annotations

import ast
import importlib
from pathlib import Path

import pytest

import pendfmu

PACKAGE = Path(pendfmu.__file__).parent
LONGEST_FUNCTION = 80  # lines, decorators and docstring included


def modules() -> dict[str, Path]:
    """Every module of the package by its dotted name."""
    found = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
        name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        found[name] = path
    return found


def imported(name: str, path: Path, known: set[str]) -> set[str]:
    """The package's modules that module `name` imports (a package's __init__ counts for
    `from package import x` unless x is a submodule)."""
    tree = ast.parse(path.read_text())
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    targets = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            targets |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")[:len(package.split(".")) - node.level + 1]
                base = ".".join([*anchor, base] if base else anchor)
            for alias in node.names:
                sub = f"{base}.{alias.name}"
                targets.add(sub if sub in known else base)
    return {t for t in targets if t in known and t != name}


def import_graph() -> dict[str, set[str]]:
    found = modules()
    return {name: imported(name, path, set(found)) for name, path in found.items()}


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The groups of more than one module that import each other (the simulator's own
    Tarjan, which orders co-simulation components the same way)."""
    from pendfmu.simulator.graph import strongly_connected

    return sorted(group for group in strongly_connected(graph, graph) if len(group) > 1)


def test_the_cycle_finder_finds_a_cycle():
    """The check itself: a planted loop through a package is found, a chain is not."""
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert cycles({"a": {"b"}, "b": set()}) == []


def test_the_package_has_no_import_cycle():
    graph = import_graph()
    assert "pendfmu.fitting.result" in graph and graph["pendfmu.report"]  # the graph is read
    assert cycles(graph) == []


def test_no_function_is_longer_than_the_limit():
    long = []
    for name, path in modules().items():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                start = min([node.lineno, *(d.lineno for d in node.decorator_list)])
                if node.end_lineno - start + 1 > LONGEST_FUNCTION:
                    long.append(f"{name}.{node.name}: {node.end_lineno - start + 1} lines")
    assert long == []


# The public names of each submodule that declares them: a change here is a change users see.
SUBMODULE_APIS = {
    "pendfmu.check": ["CheckResult", "compare", "run_battery"],
    "pendfmu.export": ["ExportPlan", "START_FILE", "export_all", "export_result", "plan_export", "write_export"],
    "pendfmu.fmubuild": ["BuildError", "FMI_VERSIONS", "build_all", "build_fmu", "compute_guid", "fmu_path",
                         "ensure_fmu"],
    "pendfmu.recording": ["INITIAL_NAMES", "MAT_TIME_NAMES", "MAX_BYTES", "PARAMETER_NAMES", "QUANTIZERS", "RIG",
                          "SIGNAL_NAMES", "Recording", "RecordingError", "SignalInfo", "Vocabulary",
                          "check_output_path", "format_document", "quantize", "read_recording", "write_recording", "write_signals"],
    "pendfmu.report": ["write_report", "write_comparison", "write_laws_report"],
    "pendfmu.simulator": ["ComponentFMU", "FMUError", "ParameterError", "unpacked_fmu"],
    "pendfmu.ssp": ["Connection", "Connector", "DefaultExperiment", "FmuComponent", "ParameterSet", "ParameterValue",
                    "SHARED_PARAMETERS", "SspError", "System", "Unit", "check_system", "describe_fmu",
                    "fmu_component", "read_ssd", "read_ssp", "read_ssv", "rig_connections", "rig_system", "schema_dir",
                    "write_ssd", "write_ssp", "write_ssv"],
    "pendfmu.testing": ["FMURunner", "Run", "assert_calls_rejected", "assert_converges", "assert_deterministic",
                        "assert_finite_over_inputs", "assert_matches", "assert_reset_restores", "assert_state_rollback",
                        "assert_valid", "fmu_runner", "fmus_and_interfaces"],
}


def test_each_documented_submodule_keeps_its_public_names():
    for name, public in SUBMODULE_APIS.items():
        module = importlib.import_module(name)
        assert list(module.__all__) == public, name
        for item in public:
            assert getattr(module, item) is not None, f"{name}.{item}"


def test_a_missing_compiler_is_exit_5_in_one_line(tmp_path, monkeypatch, capsys):
    """BuildError is in the error tree: a machine without the compiler reads as such, not
    as pendfmu's internal failure (exit 1) with a FileNotFoundError."""
    from pendfmu.cli import main

    monkeypatch.setenv("CC", str(tmp_path / "no-such-cc"))
    assert main(["build", "--out", str(tmp_path / "fmus"), "--fmi", "2", "--force"]) == 5
    err = capsys.readouterr().err
    assert "cannot build the FMUs: no C compiler" in err and "no-such-cc" in err and len(err.splitlines()) == 1


def test_workers_that_failed_the_work_are_exit_6_in_one_line(cart_recording, tmp_path, monkeypatch, capsys):
    """Every Dask worker gone is the machine's failure, not the input's or pendfmu's: exit 6,
    not an internal failure (WorkersLost once was one, outside the tree)."""
    from pendfmu.cli import main
    from pendfmu.fitting import cluster

    def no_worker_answers(self):
        raise cluster.WorkersLost("no worker of the Dask cluster answered (the test's)")

    distributed = pytest.importorskip("distributed")
    monkeypatch.setattr(cluster.ActorGroup, "add_actors", no_worker_answers)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=False,
                                  dashboard_address=":0") as local:
        code = main(["fit", "cart", str(cart_recording), "--scheduler", local.scheduler_address, "--out",
                     str(tmp_path / "r.json")])
    err = capsys.readouterr().err
    assert code == 6 and "the workers failed: no worker of the Dask cluster answered" in err, err


def test_every_error_pendfmu_raises_is_in_the_error_tree():
    """The command line maps PendfmuError's branches to exit codes: an exception class
    outside the tree reads as an internal failure (BuildError once did, for a missing
    compiler). Private helpers (a leading underscore) never leave their module."""
    from pendfmu.errors import PendfmuError

    outside = []
    for name in modules():
        if name.endswith("__main__"):
            continue  # importing it runs the command line
        module = importlib.import_module(name)
        for attribute, value in vars(module).items():
            if (isinstance(value, type) and issubclass(value, BaseException) and value.__module__ == name
                    and not attribute.startswith("_") and not issubclass(value, PendfmuError)):
                outside.append(f"{name}.{attribute}")
    assert outside == []
