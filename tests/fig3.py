"""The paper's friction test (Fig. 3) through the Cart FMU, and its analytic edge times.

With eta = 1, k_M = k_D = 1 and m_p = 0 the cart is the paper's 0.5 kg mass and its
input current is the force in newtons: F(t) = sin(2 pi t / P), P = 0.63 s.
The mass sticks until F exceeds F_S = 0.8 N at t_b = P asin(0.8) / (2 pi). After each
reversal it sticks again (v reaches 0 while |F| < F_S) and, since a stuck mass keeps no
memory, it breaks away again exactly when |F| passes F_S: at t_b + k P / 2.
"""

from __future__ import annotations

import math

import numpy as np

from pendfmu.simulator import ComponentFMU

PERIOD = 0.63
OMEGA = 2 * math.pi / PERIOD
PARAMETERS = dict(m_c=0.5, m_p=0.0, eta=1.0, k_M=1.0, k_D=1.0, k_fwc=2.0, F_Kc=0.3, F_Sc=0.8)
BREAKAWAY = PERIOD * math.asin(0.8) / (2 * math.pi)  # 0.0929777 s


def force(t):
    return math.sin(OMEGA * t)


def force_derivatives(t):
    """1st to 3rd derivative: a cubic Taylor polynomial over 1 ms is exact to 4e-10 N."""
    return [OMEGA * math.cos(OMEGA * t), -OMEGA**2 * math.sin(OMEGA * t), -OMEGA**3 * math.cos(OMEGA * t)]


def run_cs(step: float, stop: float = 2.0, exact_input: bool = True) -> dict[str, np.ndarray]:
    times = np.linspace(0.0, stop, int(round(stop / step)) + 1)
    with ComponentFMU("Cart", PARAMETERS) as cart:
        return cart.run(times, ["x", "v", "a", "mode", "t_mode"], inputs=lambda t: {"I": force(t)},
                        derivatives=(lambda t: {"I": force_derivatives(t)}) if exact_input else None)


def edges(result: dict[str, np.ndarray]) -> list[tuple[float, int, int]]:
    """(time, old mode, new mode) of each mode change, time from the FMU's t_mode."""
    mode = result["mode"]
    changed = np.nonzero(np.diff(mode))[0] + 1
    return [(result["t_mode"][k], int(mode[k - 1]), int(mode[k])) for k in changed]
