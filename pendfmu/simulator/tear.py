"""Solving a coupled group's algebraic loop over a step, on one tear signal.

The problem. Over a step [a, b] (a communication step, or a piece of one: coupled.py) a
coupled group (cart and pendulum on a back-drivable screw) needs the end values of the
signals its members exchange. Tearing the loop at one signal (the cart's acceleration a,
which the pendulum takes as input) makes it one equation in one unknown: guess the tear's
end value x, step the pendulum with its input interpolated from its value at a to x,
step the cart with the pendulum's outputs, and read the cart's acceleration at b, G(x).
The step is consistent where r(x) = G(x) - x = 0.

Why plain fixed-point iteration (x <- G(x)) is not enough. While both joints slide, G is
smooth with a small slope (the loop gain A m^2 l^2 cos^2(phi) / (M J), below
m_p / (m_c + m_p) for any rod or bob, 0.027 for the reference rig at eta 0.7), and fixed-point
iteration contracts. But a joint that sticks, breaks away or reverses near the step's end
makes G jump: a guess on one side lets the cart reach v = 0 just before b (G = 0, stuck),
a guess on the other just after (G = the braking deceleration). Then r changes sign
without a zero, no fixed point exists, and fixed-point iteration jumps between the two
branches forever (issue 12: the cart's stop at t = 0.0588 s, 1.7 us before a
communication point).

The method: safeguarded scalar root finding on r.
  1. The first guess is the tear's value predicted from the previous steps; the second
     a Newton step with the slope of r measured in an earlier step (r' changes slowly
     while the joints slide), or without one a fixed-point step, x1 = G(x0), which for
     the usual small loop gain is already close.
  2. Until r changes sign, secant steps (superlinear on smooth branches).
  3. Once a sign change brackets the solution, Illinois steps (regula falsi with the
     stale end's residual halved), which converge superlinearly on a smooth r; an
     Illinois step that fails to halve the smallest residual so far switches to bisection,
     which stays on while bisection points do not halve it either. Near a jump no
     interpolation can help, and bisection gains one bit per evaluation there, the most
     any method can (the jump's location is invisible in the residuals).
  4. Converged: |r| <= tolerance * (1 + |G|), the criterion of the fixed-point iteration.
  5. A jump: the bracket is narrower than JUMP_RESOLUTION times the jump of r across it
     (an apparent slope of 1e5, against slopes of order 1 for smooth branches, where
     r' = G' - 1), or narrower than the tolerance itself.

What a solution at a jump means. There is none of x = G(x); its Filippov (set-valued)
solution is the x_c where the bracket closes, between G's one-sided limits: the guess at
which the event falls exactly on b. The bracket's two ends differ by less than 1e-5 of the
jump, so the members' continuous states at b agree to that precision at both; only the side
of b on which the event falls differs. An event at b means: over [a, b) the torn signal
followed its course from before the event, ending at its left limit g_pre (G at the
pre-event end), and at b it jumps to g_post (G at the post-event end). The linear coupling
represents exactly this: the consumers' inputs ramp to g_pre, and the next step starts
from g_post (inputs are set anew at every step, so a jump can sit on a step's end). So
the step is accepted with the consumers driven to x = g_pre and the FMU states after the
event: for a cart that comes to rest, stuck with a = 0 exactly. Those states come from one
more evaluation at x = g_pre, which lies on the post-event side of the jump (without a
fixed point each branch's output lies on the other branch's side, which is why fixed-point
iteration cycles), so the event happens inside that step, displaced from b only by the
event time's weak dependence on the guess. That evaluation is checked: its G must lie
nearer g_post than g_pre (one jump, not two); else the post-event end itself is stepped
again and accepted (the Filippov point; the consumers then ramp to x_c, an error of order
jump * h). On issue 12's case the Filippov point leaves the pendulum 9e-5 rad from the
reference, the left limit 2e-8 rad.

Which end is post-event: the event is what breaks the torn signal from its smooth course,
so it is the end whose G lies farther from the smooth prediction x0 (the linear
extrapolation of the previous steps). For a joint that comes to rest that is the stuck
end, for a reversal the reversed one; where a stop falls on the stiction threshold (stick
or reverse), the stuck one, since holding changes a more than reversing does. If the
prediction were off by more than half the jump (tiny jumps), the other end is taken:
still a consistent state, with the error of order jump * h of the Filippov point.

Where the master can locate events (coupled.py), an event accepted this way lies inside
the step and the step is then cut there, so that the event's stick-or-slip decision is
taken with consistent partners; this jump treatment is what makes every solve terminate
on a state the FMUs' own mode logic produced, and the fallback where events cannot be
located. After a step accepted at a jump the master makes the coupled signals agree at b
through the FMUs' own mode logic (coupled._settle).

The native engine (pendfmu/csrc/runner/tear.h) implements this class operation for operation,
so that both engines stay bit-identical; change both together.
"""

from __future__ import annotations

import math

# Outcomes of TearSolver.update
CONTINUE, CONVERGED, JUMP, EXHAUSTED = 0, 1, 2, 3
# Phases of a TearSolver: searching, then at a jump stepping to the left limit, then (if
# that did not land on the post-event branch) stepping the post-event end again.
SEARCH, LEFT_LIMIT, POST_EVENT = 0, 1, 2

#: A bracket narrower than this fraction of the residual's jump across it is a discontinuity.
#: Why 1e-5: locating a jump costs one bisection per bit (17 bits here), and interpolation
#: attempts that fail near a jump cost more; over the 240 rigs of the tests a search took at
#: most 24 of the default 30 evaluations (27 at 1e-6). What is accepted at a jump hardly
#: depends on it: the consumers ramp to g_pre, which moves with the guess only by the loop
#: gain.
JUMP_RESOLUTION = 1e-5


class TearSolver:
    """Root finding on r(x) = G(x) - x, one evaluation of G at a time.

    Use: evaluate g = G(x) at x = solver.guess and call update(x, g), as long as it returns
    CONTINUE. CONVERGED and JUMP accept the step as last evaluated (at a jump, with x =
    g_pre, see the module's docstring); EXHAUSTED means max_evaluations searching did not
    reach either."""

    def __init__(self, prediction: float, slope: float, tolerance: float, max_evaluations: int):
        """prediction: the first guess; slope: r' measured in an earlier step (0 if none)."""
        self.prediction = prediction
        self.guess = prediction
        self.slope = slope  # the latest secant slope of r, handed on to the next step
        self.tolerance = tolerance
        self.max_evaluations = max_evaluations
        self.phase = SEARCH
        self.evaluations = 0
        self.change = math.inf  # relative change |r| / (1 + |G|) of the last evaluation
        self.best = math.inf  # smallest |r| so far
        self.x_last = self.r_last = self.g_last = 0.0
        self.bracketed = False
        self.bisecting = False
        # bracket ends: guess, residual, Illinois-weighted residual, output
        self.a = self.ra = self.fa = self.ga = 0.0
        self.b = self.rb = self.fb = self.gb = 0.0
        self.kept = 0  # +1: the last bracketed update replaced end a, -1: end b, 0: none yet
        self.x_post = self.g_post = self.g_pre = 0.0  # at a jump

    def update(self, x: float, g: float) -> int:
        """Take the output g = G(x) of an evaluation at x; returns CONTINUE (evaluate at
        self.guess next), CONVERGED, JUMP or EXHAUSTED."""
        self.evaluations += 1
        if self.phase == LEFT_LIMIT:
            if abs(g - self.g_post) <= abs(g - self.g_pre):
                return JUMP
            self.phase = POST_EVENT
            self.guess = self.x_post
            return CONTINUE
        if self.phase == POST_EVENT:
            return JUMP
        r = g - x
        self.change = abs(r) / (1.0 + abs(g))
        if self.change <= self.tolerance:
            return CONVERGED
        improved = abs(r) < 0.5 * self.best
        self.best = min(self.best, abs(r))
        if self.evaluations > 1 and x != self.x_last:
            self.slope = (r - self.r_last) / (x - self.x_last)
        if self.bracketed:
            self._replace_end(x, r, g)
            self.bisecting = not improved
        elif self.evaluations > 1 and (r > 0.0) != (self.r_last > 0.0):
            self.bracketed = True
            self.a, self.ra, self.fa, self.ga = self.x_last, self.r_last, self.r_last, self.g_last
            self.b, self.rb, self.fb, self.gb = x, r, r, g
        if self.bracketed and self._at_jump():
            # the post-event end: its output lies farther from the smooth prediction
            if abs(self.ga - self.prediction) >= abs(self.gb - self.prediction):
                self.x_post, self.g_post, self.g_pre = self.a, self.ga, self.gb
            else:
                self.x_post, self.g_post, self.g_pre = self.b, self.gb, self.ga
            self.phase = LEFT_LIMIT
            self.guess = self.g_pre
            return CONTINUE
        if self.evaluations >= self.max_evaluations:
            return EXHAUSTED
        self.guess = self._next(x, r, g)
        self.x_last, self.r_last, self.g_last = x, r, g
        return CONTINUE

    def _replace_end(self, x: float, r: float, g: float) -> None:
        """Keep the bracket around the sign change; Illinois: an end kept twice in a row
        has its weighted residual halved, so that the next interpolation moves off it."""
        if (r > 0.0) == (self.ra > 0.0):
            self.a, self.ra, self.fa, self.ga = x, r, r, g
            if self.kept == 1:
                self.fb *= 0.5
            self.kept = 1
        else:
            self.b, self.rb, self.fb, self.gb = x, r, r, g
            if self.kept == -1:
                self.fa *= 0.5
            self.kept = -1

    def _at_jump(self) -> bool:
        width = abs(self.b - self.a)
        return (width <= JUMP_RESOLUTION * abs(self.ra - self.rb)
                or width <= self.tolerance * (1.0 + max(abs(self.a), abs(self.b))))

    def _next(self, x: float, r: float, g: float) -> float:
        if not self.bracketed:
            # A Newton step with the latest secant slope where r falls (G' < 1, as for any
            # contraction and for the rig, whose loop gain is below m_p / (m_c + m_p)); else
            # a fixed-point step. Why: a secant through points on the two sides of a jump
            # has a meaningless slope.
            guess = x - r / self.slope if self.slope < 0.0 else g
            return guess if math.isfinite(guess) else g
        middle = 0.5 * (self.a + self.b)
        if self.bisecting:
            return middle
        guess = self.a - self.fa * (self.b - self.a) / (self.fb - self.fa)
        if not (min(self.a, self.b) < guess < max(self.a, self.b)):
            return middle
        return guess
