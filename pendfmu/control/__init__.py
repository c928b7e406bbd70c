"""From the identified model to a controller (issue 27): design, the sampled law, its FMU.

design.design(parameters, Options) -> Design (LQR balance, Kalman estimator, energy swing-up,
friction compensation); law.Controller(design).step(x, phi, x_ref) -> I_c, one sample.
"""

from pendfmu.control.design import Design, Options, Weights, design
from pendfmu.control.law import Controller

__all__ = ["Controller", "Design", "Options", "Weights", "design"]
