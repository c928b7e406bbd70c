"""Issue 12 on real data: every fit ends with a result file, and a parameter reported as
a set reports the same set whatever the seed of the global search.

Each case is the command a user types (``realdata_cases.py``: recordings written as CSV
and sidecar into a temporary folder, ``pendfmu fit STAGE ... --seed S``), run in-process
through ``pendfmu.cli.main``. ``scripts/realdata_fits.py`` runs the same cases for seeds
0-4 and prints the figures; this file keeps the assertions within about a minute and a
half on two cores:

* one seed per data set, with ``--replicates 8`` (the fewest the CLI allows) instead of
  24: the bootstrap's replicate count changes the interval's width, not whether a file is
  written or whether an interval may leave the physical range. (On these recordings the
  fits are marked: a bootstrap asked for becomes the sandwich, and Jacobian intervals are
  widened to at least it, so a second run per data set with ``--uncertainty jacobian``
  doubled the cost to test nearly the same intervals; the Jacobian run is kept where the
  overflow was found, the carriage's line);
* MultiArm on 3 of the script's 8 decay windows (25 s instead of 5 minutes);
* two seeds where a set is reported: the carriage's straight-line fit (its stiction sits
  at the Coulomb bound; the example itself now frees the Stribeck speed) and the Furuta
  pendulum (its stiction is only bounded by a free decay); and the carriage's seed 2 (line
  and Stribeck fit), whose global search ends in another basin.

Skipped when the real data are absent (``realdata.available``).
"""

from __future__ import annotations

import pytest

import realdata_cases as cases
import realdata_rigs as rigs

REPLICATES = ("--replicates", "8")
TESTED = {name: case for name, case in cases.CASES.items() if name != "MultiArm-Pendulum"}
TESTED["MultiArm-Pendulum"] = cases.multiarm_case(3)
# The carriage's straight-line fit (no Stribeck speed, the published start): its stiction ends
# at the Coulomb bound, the set these tests were written for.
LINE = "friction-identification-line"
TESTED[LINE] = cases.FitCase("friction-identification", "cart", rigs.carriage.SOURCES,
                             rigs.carriage.build_line, rigs.carriage.LINE_OPTIONS)


METHODS = {"bootstrap": REPLICATES, "jacobian": ("--uncertainty", "jacobian")}


@pytest.fixture(scope="module")
def fitted(tmp_path_factory):
    """(data set, seed, interval method) -> Run, each fit run once for the module."""
    runs: dict[tuple[str, int, str], cases.Run] = {}

    def get(name: str, seed: int, method: str = "bootstrap") -> cases.Run:
        case = TESTED[name]
        if not case.available:
            pytest.skip(f"real data absent: {', '.join(map(str, case.sources))}")
        if (name, seed, method) not in runs:
            folder = tmp_path_factory.mktemp(name)
            runs[name, seed, method] = cases.run_fit(case.prepare(folder), folder / "result.json", seed, name,
                                                     METHODS[method])
        return runs[name, seed, method]

    return get


# EMPS's bootstrap (eight refits of the closed loop: 100 s on two busy cores), MultiArm's (23 s) and
# the carriage's Stribeck fit's (16 s) are make acceptance's; their data are fitted in make test
# through the examples (test_examples_realdata.py) and, for MultiArm, its decay handling
# (test_real_data_handling.py)
LONG_FITS = {"EMPS", "MultiArm-Pendulum", "friction-identification"}


@pytest.mark.parametrize("name, method", [pytest.param(name, "bootstrap", marks=pytest.mark.acceptance)
                                          if name in LONG_FITS else (name, "bootstrap") for name in TESTED]
                         + [(LINE, "jacobian")])
def test_fit_writes_its_result_with_intervals_in_range(fitted, name, method):
    """Exit code 0 (or 3, warnings under --strict), never 1 (an internal failure) or 2,
    the result file written, and every interval inside its parameter's physical range
    (eta <= 1, frictions >= 0) and containing its own value. With the default intervals,
    and with the fast Jacobian ones on the carriage's line (the default when the issue's
    overflow and eta interval past 1 were found; its F_Sc at its bound got [3.4e-46,
    3.3e48] N there with seed 0)."""
    run = fitted(name, 0, method)
    print(f"\n{name} ({method}): exit {run.exit_code} in {run.seconds:.1f} s")
    assert run.exit_code in (0, 3), run.stderr
    assert run.written, run.stderr
    assert cases.interval_problems(run.document) == []


def assert_same_sets(runs: list[cases.Run]) -> None:
    agreement = cases.set_agreement(runs)
    for label, (_, sets) in agreement.items():
        print(f"\n{runs[0].case} {label}: " + "; ".join(f"seed {r.seed}: {s}" for r, s in zip(runs, sets)))
    assert all(run.written for run in runs)
    assert agreement, "no parameter reported as a set: the case no longer tests what it should"
    assert {label for label, (same, _) in agreement.items() if not same} == set()


def test_bounded_stiction_is_the_same_set_for_two_seeds(fitted):
    """The Furuta free decay only bounds T_Sp (method "bounded"): the same set for seeds
    0 and 1, by realdata_cases.same_set (method, value and ends within 1 % relative)."""
    runs = [fitted("rotary-inverted-pendulum", seed) for seed in (0, 1)]
    assert runs[0].document["interval_method"]["T_Sp"].startswith("bounded")  # on this marked fit: ", widened to the halves"
    assert_same_sets(runs)


# The Jacobian variant's two fits are make acceptance's: the snap to the bound that both rely on
# is the same code, and the bootstrap variant exercises it through the refits as well.
@pytest.mark.parametrize("method", ["bootstrap", pytest.param("jacobian", marks=pytest.mark.acceptance)])
def test_stiction_at_its_bound_is_the_same_set_for_two_seeds(fitted, method):
    """The carriage's F_Sc ends at its lower bound, equal to F_Kc (flagged: no stiction
    beyond Coulomb friction): what is reported for it must not depend on the seed.

    It did: the search left F_Sc/F_Kc - 1 at 1.4e-8 (seed 0), 1e-10 (seed 1) or 4e-6 from
    the bound, the Jacobian column there was 3.96 or exactly 0 (intervals [3.4e-46, 3.3e48]
    N or none), and the bootstrap's refits from those points ended in different places
    (intervals [15.7, 71.7] or [32.7, 34.5] N). optimizer.snap_to_bounds now puts such a
    coordinate on its bound when the bound fits at least as well."""
    runs = [fitted(LINE, seed, method) for seed in (0, 1)]
    assert any("at its lower bound" in flag for flag in runs[0].document["flags"].get("F_Sc", []))
    assert_same_sets(runs)


# The Stribeck fit's seed 2 (20 s) is make acceptance's; the line's keeps the rule in make test.
@pytest.mark.parametrize("name", [LINE, pytest.param("friction-identification", marks=pytest.mark.acceptance)])
def test_the_seed_does_not_change_the_carriage_optimum(fitted, name):
    """Seeds 0 and 2 end at the same optimum: the same cost within 1e-6 and the same
    values within 1 % (the rule of realdata_cases.same_set). Without this no set or
    point estimate can be the same for every seed.

    With seed 2 the global search (25 generations of 32 candidates) had settled in a basin
    whose optimum costs 57 times the best (F_Sc 102.2 N [100.9, 103.5] unflagged, k_fwc
    109.8 N s/m against F_Sc = F_Kc = 33.59 N, k_fwc 64.18): the issue's "37.6 +- 1.2 with
    no flag". The local refinement now also runs from the user's start and keeps the lower
    optimum (optimizer.optimize), and says so in the notes.

    The same for the example's Stribeck fit (v_Sc free), started from the law fitted to the
    data-implied friction (convert.implied_start): from v_Sc = 0 (the published start
    otherwise), seed 2 ended in a basin 4.8 times costlier (v_Sc 0.012 m/s against 0.137)."""
    first, other = (fitted(name, seed) for seed in (0, 2))
    print(f"\ncarriage: cost {first.document['fit']['cost']:.6g} (seed 0), {other.document['fit']['cost']:.6g} (seed 2)")
    assert other.document["fit"]["cost"] == pytest.approx(first.document["fit"]["cost"], rel=1e-6)
    for label in first.document["interval_method"]:
        assert other.document["parameters"][label] == pytest.approx(first.document["parameters"][label],
                                                                     rel=cases.SET_TOLERANCE), label
