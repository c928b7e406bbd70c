"""The Modelica library (run by rumoca) behaves like the component FMUs (Co-Simulation).

Tolerances. Both sides solve the same equations with very different integrators:
- FMU: fixed-step RK4 with h <= 1e-4 s (omega*h <= 5e-4 for the pendulum, h <= T_i/10 for
  the current loop, h << (m_c+m_p)/k_fwc = 0.1 s for the cart), so its global error is
  ~1e-13 of a signal's range; events are located to 1e-12 s; smooth inputs are given
  with their derivatives (a cubic Taylor polynomial of a <= 1.6 Hz sine over 1 ms is
  exact to 4e-10 relative).
- rumoca: variable-step solver at rtol = 1e-10, atol = 1e-12 (TIGHT). Its global error
  follows rtol: from rtol = 1e-8 (LOOSE) to 1e-10 every difference below shrinks 29x-90x,
  and at LOOSE the largest is 1.3e-6 of the signal's range (the 10 s free decay).
So at TIGHT the solver's error is ~2e-8 of a range, and REL = 1e-6 of the range leaves
a factor 50 for it, while a model difference of that size fails (a parameter off by
1e-5 relative already shows: g off by 1e-5 moves the 8-period decay by ~1e-4 rad).
Measured at TIGHT: free decay phi, w 2e-8 of their range; shaken pendulum 4e-9; the
cart's x, v, a and the current I 4e-10 to 1e-9.
Each comparison reruns rumoca at LOOSE and requires the difference to grow at least 10x
(CONVERGENCE): a difference that follows the solver tolerance is the solver's error; a
model difference would stay put.
Mode edges: issue 3 asks for 1e-4 s (EDGE_SPEC); the solvers support 1e-6 s (EDGE_TOL):
measured differences are below 6e-9 s at TIGHT (Fig. 3: 8e-11 s; 7e-9 s at LOOSE).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from modelica_runs import LOOSE, TIGHT, at_times, compiled, edge_time_error, fmu_edges, modelica_edges, simulate
from pendfmu.simulator import ComponentFMU

REL = 1e-6
EDGE_SPEC = 1e-4
EDGE_TOL = 1e-6
CONVERGENCE = 10.0


def assert_close(name: str, modelica: np.ndarray, fmu: np.ndarray, rel: float = REL) -> float:
    """|modelica - fmu| <= rel * (range, max - min, of the FMU signal); returns the largest
    difference. The range, not the largest value: phi swings by ~1 rad around pi."""
    scale = float(np.ptp(fmu))
    difference = float(np.max(np.abs(modelica - fmu)))
    assert scale > 0, f"{name}: the signal is constant; nothing is compared"
    assert difference <= rel * scale, f"{name}: differs by {difference:.3g} > {rel:g} * {scale:.3g}"
    return difference


def sine_input(amplitude: float, omega: float):
    """The value and the 1st-3rd derivatives of amplitude*sin(omega t), for ComponentFMU.run."""
    def value(t):
        return amplitude * math.sin(omega * t)

    def derivatives(t):
        s, c = math.sin(omega * t), math.cos(omega * t)
        return [amplitude * omega * c, -amplitude * omega**2 * s, -amplitude * omega**3 * c]

    return value, derivatives


# ---------------------------------------------------------------- paper Fig. 3

PERIOD = 0.63
BREAKAWAY = PERIOD * math.asin(0.8) / (2 * math.pi)  # 0.0929777 s
# The Cart FMU as the paper's 0.5 kg mass: F_A = eta k_M k_D I = I newtons.
FIG3_CART = dict(m_c=0.5, m_p=0.0, eta=1.0, k_M=1.0, k_D=1.0, k_fwc=2.0, F_Kc=0.3, F_Sc=0.8)


def run_fig3_fmu(F_S: float) -> dict[str, np.ndarray]:
    force, derivatives = sine_input(1.0, 2 * math.pi / PERIOD)
    times = np.linspace(0.0, 2.0, 2001)
    with ComponentFMU("Cart", {**FIG3_CART, "F_Sc": F_S}) as cart:
        return cart.run(times, ["v", "mode", "t_mode"], inputs=lambda t: {"I": force(t)},
                        derivatives=lambda t: {"I": derivatives(t)})


@pytest.mark.parametrize("F_S", [0.8, 0.2])
def test_fig3_edges_match_the_fmu(F_S):
    """The paper's F_S = 0.8 N; and F_S = 0.2 N < F_K = 0.3 N, where the breakaway
    threshold is max(F_S, F_K) = F_K (friction.h) and the mass reverses without resting."""
    fmu = fmu_edges(run_fig3_fmu(F_S))
    params = {"mass.F_S": F_S}
    tight = modelica_edges(simulate("PendulumID.Examples.FrictionTest", 2.0, 1e-3, params), "mass.mode")
    loose = modelica_edges(simulate("PendulumID.Examples.FrictionTest", 2.0, 1e-3, params, LOOSE), "mass.mode")
    error = edge_time_error(tight, fmu)
    assert error < EDGE_SPEC
    assert error < EDGE_TOL, f"edges differ by {error:.3g} s"
    assert edge_time_error(loose, fmu) > CONVERGENCE * error
    # the first breakaway is the analytic one, 0.63 asin(max(F_S, F_K) / 1 N) / (2 pi)
    assert tight[0][1:] == (0, 1)
    assert abs(tight[0][0] - PERIOD * math.asin(max(F_S, 0.3)) / (2 * math.pi)) < EDGE_TOL
    if F_S == 0.8:
        assert abs(tight[0][0] - BREAKAWAY) < EDGE_TOL
        assert [new for _, _, new in tight] == [1, 0, -1, 0] * 3 + [1]
    else:
        assert [new for _, _, new in tight] == [1, -1, 1, -1, 1, -1, 1]


def test_fig3_stuck_mass_does_not_creep():
    """While stuck the speed is exactly 0 (reinit at the stop, der(v) = 0 after)."""
    result = simulate("PendulumID.Examples.FrictionTest", 2.0, 1e-3)
    stuck = np.asarray(result["mass.mode"]) == 0
    assert stuck.sum() > 100
    assert np.all(np.asarray(result["mass.v"])[stuck] == 0.0)
    assert np.all(np.asarray(result["mass.a"])[stuck] == 0.0)


# ---------------------------------------------------------------- the pendulum


def compare_pendulum(model, stop, fmu_parameters, a_input, names, prefix="pendulum."):
    """Pendulum FMU vs a Modelica model holding a `pendulum`; returns the largest differences."""
    value, derivatives = a_input
    times = np.linspace(0.0, stop, int(round(stop / 1e-3)) + 1)
    with ComponentFMU("Pendulum", fmu_parameters) as pendulum:
        fmu = pendulum.run(times, [*names, "mode", "t_mode"], inputs=lambda t: {"a": value(t)},
                           derivatives=lambda t: {"a": derivatives(t)})
    differences = {}
    for config in (TIGHT, LOOSE):
        result = simulate(model, stop, 1e-3, config=config)
        got = at_times(result, [prefix + n for n in names], times)
        edges = modelica_edges(result, prefix + "mode")
        if config is TIGHT:
            assert int(np.asarray(result[prefix + "mode"])[0]) == int(fmu["mode"][0])
            differences = {n: assert_close(n, got[prefix + n], fmu[n]) for n in names}
            differences["edges"] = edge_time_error(edges, fmu_edges(fmu))
            assert differences["edges"] < EDGE_TOL
        else:
            loose = {n: float(np.max(np.abs(got[prefix + n] - fmu[n]))) for n in names}
            loose["edges"] = edge_time_error(edges, fmu_edges(fmu))
    for key, tight in differences.items():
        assert loose[key] > CONVERGENCE * tight, f"{key}: {loose[key]:.3g} at rtol 1e-8 vs {tight:.3g} at 1e-10"
    return differences, fmu


def test_pendulum_free_decay_matches_the_fmu():
    """Released at rest 0.5 rad from hanging, pivot still, 10 s: about 8 periods whose
    amplitude decays by viscous and Coulomb friction, reversing at each turning point."""
    differences, fmu = compare_pendulum("PendulumID.Examples.PendulumFreeDecay", 10.0, {"phi0": math.pi + 0.5},
                                        (lambda t: 0.0, lambda t: [0.0]), ["phi", "w"])
    assert len(fmu_edges(fmu)) >= 14  # a reversal at every turning point
    assert differences["phi"] < 1e-7


def test_pendulum_on_a_shaken_pivot_matches_the_fmu():
    """Hanging at rest, the pivot accelerated by 2 m/s2 sin(2 pi t): the pendulum sticks
    until m_p l |a| exceeds T_Sp (at 5.3 ms), then swings; this exercises the input a."""
    differences, fmu = compare_pendulum("ShakenPendulum", 5.0, {}, sine_input(2.0, 2 * math.pi),
                                        ["phi", "w", "alpha"])
    first = fmu_edges(fmu)[0]
    assert first[1:] == (0, 1)
    assert abs(first[0] - math.asin(0.004 / (0.2 * 0.3 * 2.0)) / (2 * math.pi)) < 1e-9


# ---------------------------------------------------------------- current loop and cart

I_ON, T_ON, T_OFF, STOP = 5.0, 0.01, 0.3, 0.6  # as in Examples.CartStartStop


def command(t: float) -> float:
    """The command current at a communication point t. Grid times carry rounding errors
    (linspace gives 0.01 - 2e-18): a step that falls on a grid point must act there."""
    return I_ON if T_ON <= t + 1e-9 < T_OFF else 0.0


def cart_grid() -> np.ndarray:
    """1e-4 s steps, refined to 1e-5 s for the 5 ms after each command step, where the
    current changes fast (T_i = 0.3 ms); every 1e-4 s point is on the grid."""
    pieces = [np.arange(0.0, STOP, 1e-4)]
    for start in (T_ON, T_OFF):
        pieces.append(start + np.arange(500) * 1e-5)
    return np.unique(np.round(np.concatenate(pieces + [[STOP]]), 12))


def run_cart_fmus() -> dict[str, np.ndarray]:
    """CurrentLoop -> Cart in Co-Simulation, Gauss-Seidel: the current loop steps first,
    then the cart gets the current over the same step as the quadratic through I(t_k),
    I(t_k+1) with the slope dI/dt(t_k+1) the current loop reports (exact on the ramps;
    on the exponential its error is ~h^3 I''' / 15 = 2e-6 A at h = 1e-5 s)."""
    times = cart_grid()
    rows = []
    with ComponentFMU("CurrentLoop") as loop, ComponentFMU("Cart", {"m_p": 0.0}) as cart:
        current = loop.get("I")[0]
        rows.append([current, *loop.get("mode", "t_mode"), *cart.get("x", "v", "a", "mode", "t_mode")])
        for t, t_next in zip(times[:-1], times[1:]):
            h = t_next - t
            loop.step(h, {"I_c": command(t)})
            new_current, slope = loop.get("I", "der(I_mean)")
            curvature = (slope * h - (new_current - current)) / h**2
            cart.step(h, {"I": current}, {"I": [(new_current - current) / h - curvature * h, 2 * curvature]})
            current = new_current
            rows.append([current, *loop.get("mode", "t_mode"), *cart.get("x", "v", "a", "mode", "t_mode")])
    data = np.array(rows)
    names = ["I", "loop_mode", "loop_t_mode", "x", "v", "a", "mode", "t_mode"]
    return {"time": times, **{n: data[:, j] for j, n in enumerate(names)}}


@pytest.fixture(scope="module")
def cart_fmus():
    return run_cart_fmus()


def test_cart_start_and_stop_match_the_fmus(cart_fmus):
    """Pendulum removed; a 5 A command pulse from 10 ms to 300 ms through the current loop:
    the cart breaks away during the current's ramp, runs, and brakes to a stop at 0.52 s."""
    fmu = cart_fmus
    on_grid = np.abs(fmu["time"] / 1e-4 - np.round(fmu["time"] / 1e-4)) < 1e-6
    names = {"currentLoop.I": "I", "cart.x": "x", "cart.v": "v", "cart.a": "a"}
    differences = {}
    for config in (TIGHT, LOOSE):
        result = simulate("PendulumID.Examples.CartStartStop", STOP, 1e-4, config=config)
        got = at_times(result, list(names), fmu["time"][on_grid])
        cart_edges = edge_time_error(modelica_edges(result, "cart.mode"), fmu_edges(fmu))
        loop_edges = edge_time_error(modelica_edges(result, "currentLoop.mode"),
                                     fmu_edges({"mode": fmu["loop_mode"], "t_mode": fmu["loop_t_mode"]}))
        if config is TIGHT:
            differences = {n: assert_close(n, got[m], fmu[n][on_grid]) for m, n in names.items()}
            assert cart_edges < EDGE_TOL and loop_edges < EDGE_TOL
            differences["cart edges"] = cart_edges
        else:
            for m, n in names.items():
                assert np.max(np.abs(got[m] - fmu[n][on_grid])) > CONVERGENCE * differences[n], n
            assert cart_edges > CONVERGENCE * differences["cart edges"]
    stops = [e for e in fmu_edges(fmu) if e[2] == 0]
    assert len(stops) == 1 and 0.5 < stops[0][0] < 0.55


def test_current_ripple_matches_the_fmu():
    """The PWM ripple a_h sin(2 pi f_h t + phase_h) on the current, in hertz and radians."""
    ripple = {"a_h": 0.1, "f_h": 1000.0, "phase_h": 0.3}
    times = np.linspace(0.0, STOP, int(round(STOP / 1e-4)) + 1)
    with ComponentFMU("CurrentLoop", ripple) as loop:
        fmu = loop.run(times, ["I"], inputs=lambda t: {"I_c": command(t)})
    result = simulate("PendulumID.Examples.CartStartStop", STOP, 1e-4,
                      params={f"currentLoop.{k}": v for k, v in ripple.items()})
    got = at_times(result, ["currentLoop.I"], times)["currentLoop.I"]
    assert_close("I", got, fmu["I"])
    assert abs(got[0] - 0.1 * math.sin(0.3)) < 1e-15  # ripple present from t = 0


# ---------------------------------------------------------------- the coupled rig


@pytest.mark.parametrize("model, loops", [("PendulumID.Examples.Rig", 0), ("PendulumID.Examples.RigBackDrivable", 1)])
def test_rig_is_a_valid_model_for_either_screw(model, loops):
    """eta <= 0.5 (self-locking: the cart ignores the pendulum) and eta > 0.5 (back-drivable:
    an algebraic loop between the two accelerations) both compile and simulate."""
    structure = compiled(model).structure()
    assert structure.is_balanced and structure.is_matched
    assert structure.n_algebraic_loops == loops
    result = simulate(model, 3.0, 1e-3, config=LOOSE)
    value = {n: np.asarray(result[n]) for n in ("cart.a", "pendulum.a", "cart.phi", "pendulum.phi", "cart.x")}
    assert np.array_equal(value["pendulum.a"], value["cart.a"])
    coupled = value["cart.phi"] == value["pendulum.phi"]
    assert coupled.all() if loops else np.all(value["cart.phi"] == math.pi)
    assert np.ptp(value["pendulum.phi"]) > 0.05 and value["cart.x"][-1] > 0.05  # both moved
