"""The co-simulation master against the independent event-driven reference
(tests/reference_rig.py, scipy DOP853 at rtol 1e-10 with every mode change located).

Experiment: a 3 s current step (0 -> 1.5 A at 50 ms, off at 0.4 s) from the pendulum
released at pi + 0.3 rad, for a self-locking screw (eta 0.4: one-way signal flow) and a
back-drivable one (eta 0.7: an algebraic loop between the cart's and the pendulum's
accelerations). The issue's bounds: max |dphi| <= 1e-3 rad and max |dx| <= 2e-5 m.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from reference_rig import Steps, simulate_rig

from pendfmu.simulator.master import CouplingError, ExternalInput, Master
from pendfmu.ssp import rig_system
from pendfmu.fmubuild.compiler import FMUS_DIR

TIMES = np.arange(0, 15001) * 2e-4
COMMAND = ([0.0, 0.05, 0.4], [0.0, 1.5, 0.0])
INITIAL = {"phi0": math.pi + 0.3}


def cosimulate(eta: float, **options):
    system = rig_system(eta, FMUS_DIR, {"eta": eta, **INITIAL})
    master = Master.from_system(system, **options)
    drive = ExternalInput(np.array(COMMAND[0]), np.array(COMMAND[1]), "hold")
    frame = master.run(TIMES, ["Cart.x", "Pendulum.phi", "CurrentLoop.I"], {"CurrentLoop.I_c": drive})
    return master, frame


@pytest.fixture(scope="module", params=[0.4, 0.7], ids=["self-locking", "back-drivable"])
def both(request):
    eta = request.param
    master, frame = cosimulate(eta)
    reference = simulate_rig({"eta": eta}, Steps(*COMMAND), TIMES, INITIAL)
    return eta, master, frame, reference


def test_positions_match_the_independent_reference(both):
    eta, master, frame, reference = both
    assert np.max(np.abs(frame["Cart.x"] - reference["x"])) <= 2e-5
    assert np.max(np.abs(frame["Pendulum.phi"] - reference["phi"])) <= 1e-3


def test_the_experiment_exercises_stick_slip(both):
    """Not a trivial case: the cart breaks away, brakes and sticks; the pendulum swings."""
    eta, master, frame, reference = both
    joints = {event.joint for event in reference.attrs["events"]}
    assert {"cart", "pendulum"} <= joints
    assert reference["x"].iloc[-1] > 0.01 and np.ptp(reference["phi"]) > 0.3


def test_loop_is_detected_and_solved_only_when_back_drivable(both):
    eta, master, frame, reference = both
    if eta <= 0.5:
        assert master.loops == [] and master.iterations == 0
    else:
        assert len(master.loops) == 1 and master.iterations >= len(TIMES) - 1


@pytest.mark.parametrize("iterations, when", [(1, r"at t = 0 s"), (3, r"over \[0\.05, 0\.0502\] s")])
def test_a_loop_that_cannot_converge_names_the_loop_and_the_time(iterations, when):
    """One iteration cannot even make the start consistent. While the cart is stuck its
    acceleration is 0 whatever alpha is, so the loop is trivial until the current step
    breaks it away at 0.05 s; there three iterations are too few: from the stuck cart's
    guess a = 0, a fixed-point step and a secant step leave a relative change of 1e-9, and
    the fourth evaluation converges (tear.py)."""
    loop = r"Cart\.a -> Pendulum\.a -> Pendulum\.alpha -> Cart\.alpha -> Cart\.a"
    with pytest.raises(CouplingError, match=rf"algebraic loop {loop} did not converge {when}"):
        cosimulate(0.7, max_iterations=iterations, loop_tolerance=1e-14)


@pytest.mark.parametrize("eta", [0.4, 0.7], ids=["self-locking", "back-drivable"])
@pytest.mark.parametrize("interpolation", ["hold", "linear"])
def test_native_and_python_masters_agree_to_the_bit(eta, interpolation):
    """The C loop does the Python master's floating-point operations in the same order."""
    times = TIMES[:2501]
    outputs = ["CurrentLoop.I", "Cart.x", "Cart.a", "Pendulum.phi", "Pendulum.alpha"]
    master = Master.from_system(rig_system(eta, FMUS_DIR, {"eta": eta, **INITIAL}))
    drive = {"CurrentLoop.I_c": ExternalInput(np.array([0.0, 0.05, 0.3]), np.array([0.0, 1.5, -0.5]), interpolation)}
    python = master.run(times, outputs, drive, engine="python")
    python_iterations = master.iterations
    native = master.run(times, outputs, drive, engine="native")
    assert np.array_equal(python.to_numpy(), native.to_numpy())
    assert master.iterations == python_iterations


def test_native_runs_keep_their_inputs_apart():
    """The native engine keeps the grid and the drives it built for the last run's sample
    times; a run with other command values, or with the same command object changed in
    place, must give what a new master gives, and an earlier frame must not change."""
    times = TIMES[:1501]
    system = rig_system(0.4, FMUS_DIR, {"eta": 0.4, **INITIAL})
    kept = Master.from_system(system)
    drive = ExternalInput(np.array([0.0, 0.05]), np.array([0.0, 1.5]))
    first = kept.run(times, ["Cart.x"], {"CurrentLoop.I_c": drive})
    first_values = first.to_numpy().copy()
    drive.values[1] = -1.0  # changed in place: the same object, other samples
    changed = kept.run(times, ["Cart.x"], {"CurrentLoop.I_c": drive})
    fresh = Master.from_system(system).run(times, ["Cart.x"], {"CurrentLoop.I_c": drive})
    assert np.array_equal(changed.to_numpy(), fresh.to_numpy())
    assert changed["Cart.x"].iloc[-1] < 0 < first["Cart.x"].iloc[-1]
    assert np.array_equal(first.to_numpy(), first_values)
    user_times = times.copy()
    frame = kept.run(user_times, ["Cart.x"], {"CurrentLoop.I_c": drive})
    user_times[:] = 0.0  # the caller reuses its array: the frame keeps its own time column
    assert np.array_equal(frame["time"].to_numpy(), times)
