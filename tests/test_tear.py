"""The tear signal's root finder (pendfmu/simulator/tear.py) on maps with known answers, and
the choice of the tear (graph.tear_of). The co-simulations that use them are in
tests/test_loop_events.py."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pendfmu.simulator.graph import Wire, tear_of
from pendfmu.simulator.tear import CONTINUE, CONVERGED, EXHAUSTED, JUMP, JUMP_RESOLUTION, TearSolver


def solve(G, prediction, slope=0.0, tolerance=1e-10, max_evaluations=30):
    """Run the solver on the map G; returns (outcome, the evaluations as (x, G(x)))."""
    solver = TearSolver(prediction, slope, tolerance, max_evaluations)
    evaluated = []
    while True:
        x = solver.guess
        evaluated.append((x, G(x)))
        outcome = solver.update(*evaluated[-1])
        if outcome != CONTINUE:
            return outcome, evaluated


def test_a_smooth_contraction_converges_in_three_or_four_evaluations():
    """Prediction, fixed-point step, secant: exact for a linear map, one more with curvature."""
    assert len(solve(lambda x: 0.7 + 0.03 * x, 0.5)[1]) == 3
    outcome, evaluated = solve(lambda x: 0.7 + 0.03 * x + 1e-4 * math.sin(x), 0.5)
    x, g = evaluated[-1]
    assert outcome == CONVERGED and len(evaluated) == 4 and abs(g - x) <= 1e-10 * (1 + abs(g))


def test_a_slope_from_the_previous_step_saves_an_evaluation():
    G = lambda x: 0.7 + 0.03 * x  # noqa: E731
    assert len(solve(G, 0.5, slope=0.03 - 1.0)[1]) == 2


def test_a_map_that_jumps_across_its_fixed_point_is_accepted_at_the_left_limit():
    """Issue 12's shape: G = 0 (stuck) for guesses below x_c, the braking deceleration
    -2.61 above. No fixed point. The bracket closes on x_c to JUMP_RESOLUTION of the jump,
    and the accepted evaluation is at x = g_pre = -2.61 (the course before the event), which
    lies on the stuck side: the state after the event."""
    x_c = -0.6042
    G = lambda x: 0.0 if x < x_c else -2.61 + 0.02 * x  # noqa: E731
    outcome, evaluated = solve(G, prediction=-2.67)
    bracket = [x for x, _ in evaluated[:-1]]
    below = max(x for x in bracket if x < x_c)
    above = min(x for x in bracket if x >= x_c)
    assert outcome == JUMP and len(evaluated) <= 30
    assert above - below <= JUMP_RESOLUTION * 2.61 * 1.01
    assert evaluated[-1] == (pytest.approx(-2.61 + 0.02 * above), 0.0)


def test_at_a_jump_the_post_event_end_is_the_one_away_from_the_prediction():
    """A breakaway near the step's end: guesses below x_c let the cart slide away (G = 1.25),
    guesses above keep it stuck (G = 0, the smooth course from the prediction 0). The
    accepted state is the slid one, stepped with the stuck course's value 0."""
    x_c = 0.4
    G = lambda x: 1.25 if x < x_c else 0.0  # noqa: E731
    outcome, evaluated = solve(G, prediction=0.0)
    assert outcome == JUMP and evaluated[-1] == (0.0, 1.25)


def test_if_the_left_limit_lands_on_a_third_branch_the_post_event_end_is_taken():
    """Two jumps, no fixed point: the bracket closes at 0.3, but at the left limit x = 1 G is
    neither branch's value; the Filippov point (the bracket's post-event end) is stepped
    again and accepted."""
    G = lambda x: 1.0 if x < 0.3 else (-2.0 if x < 0.9 else 0.5)  # noqa: E731
    outcome, evaluated = solve(G, prediction=0.0)
    assert outcome == JUMP and evaluated[-2] == (1.0, 0.5)
    assert evaluated[-1][1] == -2.0 and 0.0 <= evaluated[-1][0] - 0.3 < 1e-5


def test_a_search_that_cannot_finish_says_so():
    outcome, evaluated = solve(lambda x: x + 1.0, 0.0, max_evaluations=5)  # neither a root nor a sign change
    assert outcome == EXHAUSTED and len(evaluated) == 5


@pytest.mark.parametrize("seed", range(3))
def test_random_jumps_and_kinks_finish_within_the_default_budget(seed):
    """Branches with slopes of the rig's loop gain, jumps of 1e-3 to 5, kinks; predictions
    near and far: every search ends converged or at a jump within 30 evaluations (plus the
    one or two that accept a jump)."""
    rng = np.random.default_rng(seed)
    for _ in range(300):
        k, c, J = rng.uniform(0.0, 0.1), rng.uniform(-3, 3), rng.choice([1e-3, 0.1, 1.0, 5.0]) * rng.choice([-1, 1])
        x_c = c + rng.uniform(-1, 1) * abs(J)
        kind = rng.integers(3)
        G = [lambda x: c + k * x + (J if x >= x_c else 0.0),  # a jump
             lambda x: c + k * (x - x_c) * (1.0 if x < x_c else -3.0),  # a kink
             lambda x: 0.0 if x < x_c else c + k * x][kind]  # stuck on one side
        outcome, evaluated = solve(G, c + rng.uniform(-1, 1) * rng.choice([1e-6, 1e-2, 1.0]))
        assert outcome in (CONVERGED, JUMP) and len(evaluated) <= 32


BACK = [Wire("CurrentLoop", "I_mean", "Cart", "I"), Wire("Cart", "a", "Pendulum", "a"),
        *(Wire("Pendulum", v, "Cart", v) for v in ("phi", "w", "alpha"))]


def test_the_rig_is_torn_at_the_carts_acceleration_and_the_pendulum_steps_first():
    assert tear_of(["Cart", "Pendulum"], BACK) == (("Cart", "a"), ["Pendulum", "Cart"])


def test_the_first_output_that_leaves_no_cycle_tears_a_ring():
    ring = [Wire("A", "y", "B", "u"), Wire("B", "y", "C", "u"), Wire("C", "y", "A", "u"),
            Wire("B", "z", "A", "v")]
    assert tear_of(["A", "B", "C"], ring) == (("A", "y"), ["B", "C", "A"])


def test_a_group_that_no_single_signal_tears_has_no_tear():
    crossed = [Wire("A", "y", "B", "u"), Wire("B", "y", "A", "u"), Wire("A", "z", "C", "u"),
               Wire("C", "y", "A", "v"), Wire("B", "z", "C", "v"), Wire("C", "z", "B", "v")]
    assert tear_of(["A", "B", "C"], crossed) is None


CLOSED = [*BACK, Wire("Cart", "x", "RigController", "x"), Wire("Pendulum", "phi", "RigController", "phi"),
          Wire("RigController", "I_c", "CurrentLoop", "I_c")]
LOOP = ["Cart", "CurrentLoop", "Pendulum", "RigController"]


def test_a_held_controller_output_closing_a_second_cycle_orders_nothing():
    """The back-drivable rig in closed loop: no single output cuts both the mechanical loop
    and the controller's, so the group was iterated. The held I_c (read at the step's
    start) is left out, and the rig is torn at Cart.a, the controller stepping last."""
    assert tear_of(LOOP, CLOSED) is None
    assert tear_of(LOOP, CLOSED, {("RigController", "I_c")}) == (
        ("Cart", "a"), ["CurrentLoop", "Pendulum", "Cart", "RigController"])


def test_a_group_torn_with_its_held_connections_keeps_its_tear():
    """The self-locking rig in closed loop (no pendulum-to-cart connections) was torn at the
    current before held outputs were left out; it still is, so its results stay the same."""
    one_way = [c for c in CLOSED if c.target != "Cart" or c.source != "Pendulum"]
    torn = (("CurrentLoop", "I_mean"), ["Cart", "Pendulum", "RigController", "CurrentLoop"])
    assert tear_of(LOOP, one_way) == torn and tear_of(LOOP, one_way, {("RigController", "I_c")}) == torn
