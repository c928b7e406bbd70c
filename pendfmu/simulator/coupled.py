"""Coupled steps of the co-simulation master: a group of FMUs that feed each other (cart
and pendulum on a back-drivable screw), stepped together over one communication step.

The loop is torn at one signal (graph.tear_of; the cart's acceleration for the rig) and
solved by the root finder of tear.py, with the members rolled back with fmi2SetFMUstate
between evaluations. That alone converges through every stick-slip event; what it cannot
make right is the decision taken *at* an event inside the step.

Why events inside a step need more. When the cart comes to rest at tau inside [t, t+h],
its FMU decides there, by the paper's law (docs/user-guide/model.md), whether it sticks
(|F_A| <= F_S) or reverses. F_A contains the pendulum's reaction A m_p l (w^2 sin(phi) -
alpha cos(phi)), and the pendulum's alpha jumps at tau too, because the cart's acceleration
does: the law is an instantaneous problem of both joints together (the reference simulator
solves it as such).
Inside a co-simulation step the cart sees alpha interpolated between the step's ends,
which near the step's start is still the value from before the event: a cart whose
holding force lies within that jump of the threshold takes the wrong branch (measured on a
random rig: it reversed at h = 0.2, 0.1, 0.05 and 0.025 ms where the reference sticks with
5 % margin; the jump of the holding force was 8 %), and the pendulum sees the cart's jump
smeared over the step (an error of order jump * h).

So events are located. A member that reports the time of its last mode change in a Real
variable `t_mode` (pendfmu's components do; other FMUs are stepped whole) is asked for it
after each accepted piece of the step. If an event fell inside the piece [a, b], the piece
is rolled back and stepped in two: up to EVENT_MARGIN * h before the event (re-solved; if
the event comes earlier now that the inputs follow the course before it, this repeats),
then across the event in a short held piece, in which every coupled input of the group is
held at its end value instead of interpolated. The tear's fixed point over a held piece is
the instantaneous consistent state: the pendulum's alpha is the one the cart's post-event
acceleration causes, and the cart decided its mode with that alpha: stuck means a = 0 and
the holding force, with the pendulum's response to a = 0, within the threshold. The FMUs'
own mode logic decides; the master only gives it consistent partners. The rest of the step
follows as another piece. The held piece's own error is of order jump * EVENT_MARGIN * h.

Both engines implement this: the native one in pendfmu/csrc/runner/runner.c, operation for
operation, so that they stay bit-identical. Change both together.
"""

from __future__ import annotations

from pendfmu.errors import FMUError
from pendfmu.simulator.tear import CONTINUE, CONVERGED, EXHAUSTED, JUMP, TearSolver

#: The held piece across an event starts this fraction of the communication step before it
#: and ends as far after it. Why 1e-3: the event time estimated from a piece whose inputs
#: follow the course before the event moves by far less when re-solved (on 60 random rigs,
#: 184 of 190 steps with an event needed no second estimate), so the event stays inside the
#: held piece, whose error (the pendulum sees the cart's post-event acceleration from the
#: piece's start on: |jump| * 2e-3 h at most) is a small part of the smearing it replaces
#: (up to |jump| * h / 2).
EVENT_MARGIN = 1e-3
#: Pieces one communication step may be cut into; beyond, the rest is stepped whole (a
#: chattering joint cannot make a step endless).
MAX_PIECES = 16


class CouplingError(FMUError):
    """A coupled group (algebraic loop) did not converge at a communication point."""


class CoupledSteps:
    """The coupled-step part of pendfmu.simulator.Master (a mixin: it uses the master's
    connections, tears, _set_inputs, _do_step, _get, _publish and _solve_point)."""

    def _coupled_step(self, fmus, signals, start, external, group, internal, t, h) -> None:
        tear = self.tears.get(tuple(group))
        if tear is None:
            self._iterated_step(fmus, signals, start, external, group, internal, t, h)
            return
        end_time = t + h
        at = {(c.source, c.output): start[(c.source, c.output)] for c in internal}  # group signals at a
        a, b, held, pieces, event = t, end_time, False, 0, None
        prediction = self._previous_end.get(tear, start[tear])
        saved = {name: fmus[name].slave.getFMUstate() for name in group}
        try:
            while True:
                outcome, solver, inside, estimate = self._solve_piece(fmus, signals, start, external, group, tear,
                                                                      at, saved, t, h, a, b, held, prediction)
                pieces += 1
                if inside is not None and pieces < MAX_PIECES:
                    # roll back; step to just before the event, or across it held
                    event = estimate
                    for name in group:
                        fmus[name].slave.setFMUstate(saved[name])
                    before = event - EVENT_MARGIN * h
                    held = not before > a
                    b = min(event + EVENT_MARGIN * h, end_time) if held else before
                    prediction = at[tear]
                    continue
                self.events += held
                if outcome == JUMP:
                    self._settle(fmus, signals, internal, b)
                if b == end_time:
                    break
                for key in at:  # accept the piece [a, b]; the next starts at b
                    at[key] = self._get(fmus[key[0]], key[1])
                # after the piece that ends just before an event, the held piece across it
                held = event is not None and not held and b < event
                a, b, prediction = b, min(event + EVENT_MARGIN * h, end_time) if held else end_time, at[tear]
                for name in group:
                    fmus[name].slave.freeFMUstate(saved[name])
                    saved[name] = fmus[name].slave.getFMUstate()
        finally:
            for name in group:
                fmus[name].slave.freeFMUstate(saved[name])
        self._publish(fmus, signals, group)
        # The next step's first guess: this end extrapolated linearly along the step if the
        # step was smooth; held where it had an event (extrapolating across it is wrong).
        end = signals[tear]
        smooth = outcome == CONVERGED and event is None
        self._previous_end[tear] = 2 * end - start[tear] if smooth else end
        self._tear_slope[tear] = 0.0 if outcome == JUMP else solver.slope  # across a jump: meaningless

    def _solve_piece(self, fmus, signals, start, external, group, tear, at, saved, t, h, a, b, held, prediction):
        """Solve the tear over the piece [a, b] of the step [t, t+h] from the states `saved`
        at a; leaves the members at b as accepted and returns (outcome, solver, inside,
        estimate).

        `inside`: the time of the earliest event inside the accepted piece (None: none, or a
        held piece); `estimate`: that event's time as the first evaluation had it, if it had
        one inside, else `inside`. Why the first: it follows the predicted course from before
        the event, while the accepted evaluation's coupled inputs lean towards their values
        after it, which moves the event earlier (on a rig's breakaway by 6.6 us, a thirtieth
        of a step; pieces then crept up on the event and used up MAX_PIECES short of it)."""
        solver = TearSolver(prediction, self._tear_slope.get(tear, 0.0), self.loop_tolerance, self.max_iterations)
        first = None
        while True:  # the piece as last evaluated is the one accepted
            self.iterations += 1
            x = solver.guess
            g = self._torn_step(fmus, signals, start, external, group, tear, at, x, t, h, a, b, held)
            if solver.evaluations == 0 and not held:
                first = self._event_inside(fmus, group, a, b)
            outcome = solver.update(x, g)
            if outcome != CONTINUE:
                break
            for name in group:
                fmus[name].slave.setFMUstate(saved[name])
        if outcome == EXHAUSTED:
            raise CouplingError(
                f"algebraic loop {self._loop_text()} did not converge over [{t:.9g}, {t + h:.9g}] s "
                f"after {self.max_iterations} iterations (last relative change {solver.change:.3g})")
        self.jumps += outcome == JUMP
        inside = None if held else self._event_inside(fmus, group, a, b)
        return outcome, solver, inside, inside if first is None else first

    def _torn_step(self, fmus, signals, start, external, group, tear, at, x, t, h, a, b, held) -> float:
        """Step the members in order over the piece [a, b] of [t, t+h] with the torn signal's
        end value guessed as x; returns its end value as computed. Inputs from outside the
        group follow their line over [t, t+h]; coupled ones go from their value at a to the
        guess or to the outputs of the members stepped before (held: stay at those)."""
        end_time = t + h
        length = h if (a == t and b == end_time) else b - a
        first, last = {}, {}
        for key in signals:
            if key in at:
                first[key] = last[key] = at[key]
            else:
                first[key] = start[key] if a == t else start[key] + (signals[key] - start[key]) * ((a - t) / h)
                last[key] = signals[key] if b == end_time else start[key] + (signals[key] - start[key]) * ((b - t) / h)
        last[tear] = x
        for name in group:
            if held:
                for key in at:
                    first[key] = last[key]
            self._set_inputs(fmus, external, first, last, t, h, members=[name], length=length, offset=a - t)
            self._do_step(fmus[name], a, length)
            for key in last:
                if key[0] == name and key != tear:
                    last[key] = self._get(fmus[name], key[1])
        return self._get(fmus[tear[0]], tear[1])

    def _event_inside(self, fmus, group, a, b) -> float | None:
        """The earliest mode change of a member strictly inside (a, b), from `t_mode`."""
        earliest = None
        for name in group:
            if "t_mode" in fmus[name].vr:
                t_mode = self._get(fmus[name], "t_mode")
                if a < t_mode < b and (earliest is None or t_mode < earliest):
                    earliest = t_mode
        return earliest

    def _settle(self, fmus, signals, internal, t) -> None:
        """After a piece accepted at a jump of the loop map (tear.py): the consumers were
        stepped with the torn signal's left limit, not with its computed end value, so the
        group's signals at t disagree by the jump. Pass them on around the loop until they
        agree; each FMU makes its mode consistent with its new inputs when its outputs are
        read. The FMUs' own mode logic decides."""
        self._solve_point(fmus, signals, t, internal)

    def _iterated_step(self, fmus, signals, start, external, group, internal, t, h) -> None:
        """A group without a single-signal tear: fixed-point iteration on all its internal
        signals (neither robust through events nor located; no such group in the rig)."""
        keys = sorted({(c.source, c.output) for c in internal})
        guesses = dict(signals)
        for key in keys:
            guesses[key] = self._previous_end.get(key, start[key])
        saved = {name: fmus[name].slave.getFMUstate() for name in group}
        try:
            for _ in range(self.max_iterations):
                self.iterations += 1
                self._set_inputs(fmus, external, start, guesses, t, h, members=group)
                for name in group:
                    self._do_step(fmus[name], t, h)
                ends = {key: self._get(fmus[key[0]], key[1]) for key in keys}
                change = max(abs(ends[k] - guesses[k]) / (1.0 + abs(ends[k])) for k in keys)
                if change <= self.loop_tolerance:
                    break
                guesses.update(ends)
                for name in group:
                    fmus[name].slave.setFMUstate(saved[name])
            else:
                raise CouplingError(
                    f"algebraic loop {self._loop_text()} did not converge over [{t:.9g}, {t + h:.9g}] s "
                    f"after {self.max_iterations} iterations (last relative change {change:.3g})")
        finally:
            for name in group:
                fmus[name].slave.freeFMUstate(saved[name])
        # The next interval's first guess: this interval's end, extrapolated linearly.
        self._previous_end.update({k: 2 * ends[k] - start[k] for k in keys})
        self._publish(fmus, signals, group)
