"""Shared fixtures: the FMUs are built (or found up to date) once per test session."""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest

from pendfmu.fmubuild import build_all

# `make test` runs two modules at once on two pytest-xdist workers: a fit that started a worker
# process per core would put four busy processes on two cores, and the small fits most tests
# make spent a third of their CPU time starting pools. Fits left to choose their worker count
# (--workers 0) use one (pendfmu.fitting.pool.default_workers); the tests of the worker pools,
# of Dask and of results that do not depend on the workers ask for theirs explicitly.
os.environ.setdefault("PENDFMU_WORKERS", "1")


FIRST = ("test_docs_runs.py", "test_fit_options.py", "test_reference_fmus.py", "test_reference_mutants.py",
         "test_identification.py", "test_wheel.py", "test_coverage_benchmark.py", "test_faults_workers.py",
         "test_examples_realdata.py", "test_realdata_fits.py", "test_laws.py", "test_validation.py",
         "test_control.py", "test_report_browser.py", "test_check.py", "test_real_data_handling.py",
         "test_distributed.py", "test_docs_site.py", "test_win64.py", "test_check_corpus.py",
         "test_friction_extras.py", "test_data_handling.py", "test_loop_events.py", "test_reference_rig.py",
         "test_check_exercise.py", "test_check_hostile.py", "test_fmi3.py", "test_search_box.py",
         "test_foreign_fit.py", "test_realdata.py", "test_bootstrap.py")
"""The modules of 15 s or more, longest first (the sums of --durations=0 over a whole run), started
first: `make test` runs the modules on two pytest-xdist workers (--dist loadfile: a module
whole on one, so that its module-scoped fits run once; --no-loadscope-reorder: in this
order), and a long module started last would run alone at the end."""


def pytest_collection_modifyitems(config, items):
    """The longest modules first (FIRST), the rest in their order."""
    rank = {name: k for k, name in enumerate(FIRST)}
    items.sort(key=lambda item: rank.get(Path(str(item.fspath)).name, len(FIRST)))


@pytest.fixture(scope="session", autouse=True)
def built_fmus():
    return build_all()


@pytest.fixture(scope="session")
def cart_recording(tmp_path_factory):
    """A short cart start-up (pendulum removed) on the virtual rig, with a truth away from
    the defaults: the small fit that the determinism, failure, interrupt and Dask tests share."""
    from pendfmu.virtual_rig import Trial, steps, write_experiments

    out = tmp_path_factory.mktemp("cart-recording")
    experiment = Trial("cart", "cart", 0.4, 2e-4, ("I_c", "I", "x"), steps((0, 0.0), (0.02, 2.0), (0.25, 0.0)),
                            sidecar_parameters={"m_p": 0.0}, known_initial=("x", "v"))
    write_experiments(out, CART_TRUTH, seed=9, experiments=[experiment])
    return out / "cart.csv"


CART_TRUTH = {"k_fwc": 26.0, "F_Kc": 7.0, "F_Sc": 10.5, "eta": 0.42}


def result_without_time(path):
    """A result file's content without its timings (fit.seconds, fit.uncertainty.seconds and
    the validation's fit.assessment.windows.seconds) and the date, command line and workers of its provenance, the only fields that differ
    between runs (the command line names the run's own output file; the workers and the Dask
    scheduler say where the work ran, which changes no number)."""
    import json

    document = json.loads(path.read_text())
    document["fit"].pop("seconds")
    if isinstance(document["fit"].get("uncertainty"), dict):
        document["fit"]["uncertainty"].pop("seconds", None)
    assessment = document["fit"].get("assessment") or {}
    for verdict in [assessment, *(assessment.get("stages") or {}).values()]:  # fit all's: one per stage
        if isinstance(verdict.get("windows"), dict):
            verdict["windows"].pop("seconds", None)
    provenance = document.get("provenance", {})
    for key in ("date", "command"):
        provenance.pop(key, None)
    where = ("workers", "scheduler")
    for search in [provenance.get("request", {}).get("global_search", {}),
                   *(stage.get("search", {}) for stage in provenance.get("stages", {}).values())]:
        for key in where:
            search.pop(key, None)
    return document


@pytest.fixture
def interrupt_costs(monkeypatch):
    """Counts the fit's cost evaluations (Residuals.sum_of_squares, in this process) in
    ``calls["n"]`` and raises KeyboardInterrupt, as Ctrl-C would, at ``calls["stop_at"]``."""
    from pendfmu.fitting.residuals import Residuals

    calls = {"n": 0, "stop_at": None}
    original = Residuals.sum_of_squares

    def counted(self, u):
        calls["n"] += 1
        if calls["n"] == calls["stop_at"]:
            raise KeyboardInterrupt
        return original(self, u)

    monkeypatch.setattr(Residuals, "sum_of_squares", counted)
    return calls


WINE = shutil.which("wine") or shutil.which("wine64")


@pytest.fixture(scope="session")
def wine(request, tmp_path_factory):
    """Run a Windows program under wine (tests/test_win64*.py): a prefix kept in pytest's
    cache, no debug output, and one wineserver for the whole session, stopped at its end (a
    server stopped and started again between test modules raced with the next module's
    first program).

    Output goes through files, not pipes: wine's background processes (wineserver, the
    services wineboot starts) inherit the first caller's handles and would keep a pipe open
    long after the program has exited."""
    cache = getattr(request.config, "cache", None)  # None with -p no:cacheprovider: a fresh prefix then
    worker = os.environ.get("PYTEST_XDIST_WORKER", "")  # a prefix, and so a wineserver, per xdist worker
    prefix = cache.mkdir(f"wine-prefix{worker}") if cache else tmp_path_factory.mktemp("wine-prefix")
    env = {**os.environ, "WINEPREFIX": str(prefix), "WINEDEBUG": "-all", "WINEDLLOVERRIDES": "mscoree,mshtml="}
    server = shutil.which("wineserver")  # without it on PATH, wine starts one per run (slower, same results)
    quiet = dict(env=env, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    if server:
        subprocess.run([server, "-p", "30"], timeout=60, **quiet)
    subprocess.run([WINE, "wineboot", "--init"], timeout=300, **quiet)  # creates the prefix the first time
    folder = tmp_path_factory.mktemp("wine-output")

    def run(program: Path, *args: str, stdin: str | None = None) -> subprocess.CompletedProcess:
        (folder / "stdin").write_text(stdin or "")
        with open(folder / "stdin") as given, open(folder / "stdout", "w") as out, open(folder / "stderr", "w") as err:
            done = subprocess.run([WINE, str(program), *args], stdin=given, stdout=out, stderr=err, env=env,
                                  timeout=300)
        done.stdout = (folder / "stdout").read_text().replace("\r\n", "\n")
        done.stderr = (folder / "stderr").read_text()
        return done

    yield run
    if server:
        subprocess.run([server, "-k"], timeout=60, **quiet)
