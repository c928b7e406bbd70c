"""`pendfmu check` on the FMI standard's Reference FMUs with one planted defect each: a
stranger's code, broken on purpose (issue 24, item 8).

The Reference FMUs (v0.0.41, FMI 2.0 and 3.0: the FOLDER of tests/test_reference_fmus.py,
skipped when absent) ship their C sources under sources/. Their code is 2-Clause BSD (the
folder's LICENSE.txt) and none of it is copied into this repository: tests/refmutants/build.py
reads the sources from the shipped FMU at test time, plants one defect by an exact search and
replace that must match exactly once, compiles them with gcc as upstream does and repacks the
FMU around the same modelDescription.xml. With default options of `run_battery`:

- rebuilt without a defect, each FMU gives the shipped binary's rows word for word, so a
  difference a mutant makes is its defect's, not the build's;
- each mutant, FMI 2.0 and 3.0 alike, FAILs the row made for its defect class, and no other
  row turns to FAIL but the ones listed with their reason (COLLATERAL).
"""

from __future__ import annotations

import zipfile

import pytest

from pendfmu.check import run_battery
from pendfmu.check.fmu import FAIL
from refmutants.build import BINARIES, MUTATIONS, Mutation, build, plant
from test_reference_fmus import FMUS, FOLDER, battery

pytestmark = pytest.mark.skipif(not FMUS, reason=f"the Reference FMUs are not in {FOLDER}")

MADE_FOR = {
    "events_at_points": ({"convergence: h, h/2, h/4 CS"}, "the result moves with the communication step: v changes"),
    "forget_counter": ({"rollback: FMU state CS", "rollback: serialized state CS", "rollback: FMU state ME",
                        "rollback: serialized state ME"},
                       'Variable "counter" cannot be incremented for values >= 10.'),
    "forget_next_tick": ({"rollback: FMU state CS", "rollback: serialized state CS", "rollback: FMU state ME",
                          "rollback: serialized state ME"}, "does not reproduce the run: counter at t ="),
    "reset_keeps_k": ({"determinism: reset CS", "determinism: reset ME"},
                      "fmi{version}Reset must bring k back to its start value 1"),
    "nan_above_11": ({"inputs: finite outputs CS", "inputs: finite outputs ME"},
                     "input Float64_continuous_input held at 100 (probed by decades, no declared range) output "
                     "Float64_continuous_output turned nan"),
    "rhs_at_points": ({"convergence: h, h/2, h/4 CS"}, "the result moves with the communication step: h changes"),
}
"""Each mutant's rows made for its defect class, which must FAIL, and words every one of them says
("{version}": 2 or 3)."""

MISSED_REFERENCE = {f"reference: {o} {kind}" for o in ("h", "v") for kind in ("CS", "ME")}
COLLATERAL = {"events_at_points": MISSED_REFERENCE, "rhs_at_points": MISSED_REFERENCE}
"""Other rows a mutant turns to FAIL. A Co-Simulation defect of BouncingBall leaves its shipped
reference result (made in Co-Simulation) in CS; its Model Exchange run is unchanged and was a
WARN only because CS reproduced the reference (test_reference_fmus), so it is a FAIL now."""


def failed(rows) -> set[str]:
    return {r.name for r in rows if r.verdict == FAIL}


@pytest.fixture(scope="module")
def rebuilt(tmp_path_factory):
    """(version, model, mutant or None) -> (FMU, battery rows): each built and checked once."""
    folder, done = tmp_path_factory.mktemp("refmutants"), {}

    def get(version: int, model: str, mutant: str | None):
        if (version, model, mutant) not in done:
            fmu = build(FOLDER / f"fmi{version}" / f"{model}.fmu", folder, mutant)
            done[version, model, mutant] = fmu, run_battery(fmu)
        return done[version, model, mutant]
    return get


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted({f"fmi{v}/{m.model}.fmu" for m in MUTATIONS.values() for v in (2, 3)}))
def test_the_rebuild_from_the_shipped_sources_gives_the_shipped_rows(name, rebuilt):
    version, model = int(name[3]), name.split("/")[1][:-4]
    _, rows = rebuilt(version, model, None)
    assert rows == battery(name)


@pytest.mark.slow
@pytest.mark.parametrize("version", (2, 3))
@pytest.mark.parametrize("mutant", MUTATIONS)
def test_each_planted_defect_fails_the_check_made_for_it(mutant, version, rebuilt):
    mutation = MUTATIONS[mutant]
    _, clean = rebuilt(version, mutation.model, None)
    fmu, rows = rebuilt(version, mutation.model, mutant)
    made_for, words = MADE_FOR[mutant]
    assert failed(rows) - failed(clean) == made_for | COLLATERAL.get(mutant, set()), [
        r for r in rows if r.verdict == FAIL]
    for row in (r for r in rows if r.name in made_for):
        assert words.format(version=version) in row.message, row
    shipped, planted = _members(FOLDER / f"fmi{version}" / f"{mutation.model}.fmu"), _members(fmu)
    changed = {n for n in shipped if shipped[n] != planted[n]}
    assert planted.keys() == shipped.keys() and planted["modelDescription.xml"] == shipped["modelDescription.xml"]
    assert changed == {f"{BINARIES[f'{version}.0']}/{mutation.model}.so",
                       "sources/" + mutation.member.format(version=version)}


@pytest.mark.parametrize("version", (2, 3))
def test_every_mutation_matches_the_shipped_sources_once_and_anything_else_is_refused(version):
    for mutation in MUTATIONS.values():
        source = _members(FOLDER / f"fmi{version}" / f"{mutation.model}.fmu")
        member = "sources/" + mutation.member.format(version=version)
        assert plant(source[member].decode(), mutation, member).count(mutation.new) == 1
    cosimulation = _members(FOLDER / f"fmi{version}" / "Stair.fmu")["sources/cosimulation.c"].decode()
    for old, found in (("setStartValues(comp);", 2), ("no such text", 0)):  # instantiation and reset: twice
        with pytest.raises(RuntimeError, match=f"occurs {found} times, not once"):
            plant(cosimulation, Mutation("Stair", "cosimulation.c", old, "", "ambiguous"), "cosimulation.c")
    with pytest.raises(ValueError, match="'reset_keeps_k' is planted in Dahlquist, not in Stair"):
        build(FOLDER / f"fmi{version}" / "Stair.fmu", "unused", "reset_keeps_k")


def _members(path) -> dict[str, bytes]:
    with zipfile.ZipFile(path) as archive:
        return {info.filename: archive.read(info) for info in archive.infolist()}
