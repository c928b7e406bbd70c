"""Closing a sampled controller's loop around the independent reference simulator (tests only).

The controller reads the quantized encoders at each sample t_k = k T_s and its command is
held until the next. The reference simulator (reference_rig) restarts its integration at
every breakpoint of a piecewise-constant input and re-resolves the friction modes there
from the state it has reached: `_SampledRig` takes that moment, where it is handed the
state, to run the controller and set the command for the coming interval. So one
event-driven simulation runs the whole loop, the plant's physics untouched, and the
friction modes carry over from one sample to the next as in one open-loop run.
"""

from __future__ import annotations

import math

import numpy as np

from reference_rig import INITIAL_DEFAULTS, _Rig, _Signal, rig_params

SOLVER = {"rtol": 1e-6, "atol": 1e-8}  # 1e-8 moves x by 1e-11 m over a second, at twice the cost
# [m/s, rad/s]: how far from 0 a joint's stop is located (see _SampledRig.events)
STOP_OFFSET = 1e-12


def quantize(value: float, step: float) -> float:
    return step * round(value / step)


class _SampledRig(_Rig):
    """The reference rig whose command current is set by `controller(x_read, phi_read)` at
    each input breakpoint (the samples), from the encoders' quantized readings."""

    def __init__(self, params: dict, controller, dx: float, dphi: float):
        super().__init__(params, loop=True, cart="dynamic", pend="dynamic")
        self.controller, self.dx, self.dphi = controller, dx, dphi
        self.held = 0.0
        self.samples: list[tuple[float, float, float, float]] = []  # (t, x, phi, I_c), true x and phi

    def events(self, modes, u):
        """The simulator's events, a stop located when the speed is STOP_OFFSET short of 0.

        Why: after a reversal the joint restarts at speed exactly 0, where its new stop event
        function is 0 too; when the current slews, the joint can come back to rest within the
        integrator's first step, and the root finder, handed a bracket with a zero at its
        start, returns the start: a stop at the reversal's own instant, in no consistent mode
        (the simulator refuses the state). Shifted, the function is nonzero at the start."""
        shifted = []
        for event in super().events(modes, u):
            joint, kind, _ = event.info
            if kind == "stop":
                event = _shifted(event, STOP_OFFSET * modes[1 if joint == "cart" else 2])
            shifted.append(event)
        return shifted

    def resolve(self, t, y, u, prev, event=None):
        if event is None:  # a breakpoint or the start: a sample
            self.held = self.controller(quantize(y[1], self.dx), quantize(y[3], self.dphi))
            self.samples.append((t, y[1], y[3], self.held))
        return super().resolve(t, y, u, prev, event)


def _shifted(event, offset: float):
    def function(t, y):
        return event(t, y) + offset
    function.terminal, function.direction, function.info = event.terminal, event.direction, event.info
    return function


def close_loop(params: dict, controller, *, T_s: float, duration: float, phi0: float, dx: float,
               dphi: float = 2 * math.pi / 1024) -> dict[str, np.ndarray]:
    """Run `controller(x_read, phi_read) -> I_c` in closed loop for `duration`, the rig
    (reference_rig names) starting at rest at x = 0, phi0; the true x and phi at the samples
    and the commands: time, x, phi, I_c."""
    n = int(round(duration / T_s))
    rig = _SampledRig(rig_params(params), controller, dx, dphi)
    times = T_s * np.arange(n + 1)
    signal = _Signal(lambda t: rig.held, breakpoints=tuple(times[1:-1]))
    y0 = [INITIAL_DEFAULTS["I0"], 0.0, 0.0, phi0, 0.0]
    rig.run({"Ic": signal}, times[[0, -1]], y0, **SOLVER)
    time, x, phi, I_c = (np.array(column) for column in zip(*rig.samples[:n]))
    return {"time": time, "x": x, "phi": phi, "I_c": I_c}


CAPTURED = 0.1  # rad: within this of upright from the capture on


def verdict(run: dict, window: float) -> dict[str, float]:
    """The issue's figures of a closed-loop run: capture time (from when the pendulum stays
    within CAPTURED of upright), RMS of phi [steps of the 10-bit encoder], x [m] and I_c [A] over the last
    `window` seconds, and the largest |x| [m]."""
    phi = np.mod(np.asarray(run["phi"]) + math.pi, 2 * math.pi) - math.pi
    last = run["time"] >= run["time"][-1] - window
    away = np.flatnonzero(np.abs(phi) >= CAPTURED)
    capture = 0.0 if away.size == 0 else float(run["time"][min(away[-1] + 1, len(phi) - 1)])
    rms = {name: float(np.sqrt(np.mean(np.asarray(values)[last] ** 2)))
           for name, values in (("phi", phi), ("x", run["x"]), ("I_c", run["I_c"]))}
    return {"capture": capture, "phi_steps": rms["phi"] / (2 * math.pi / 1024), "x": rms["x"], "I_c": rms["I_c"],
            "x_peak": float(np.max(np.abs(run["x"])))}
