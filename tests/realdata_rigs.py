"""Three more real data sets, as a new user would bring them to today's stages, and the one
that today's stages cannot take.

The conversions live in ``examples/realdata/<name>/convert.py`` (one copy, shared with the
examples, ``realdata_cases.py`` and ``scripts/realdata_fits.py``); this module loads them:

* :data:`carriage`, ``friction-identification`` (cart stage, driven by ``I``): a servo
  carriage, start-up and braking to rest;
* :data:`furuta`, ``rotary-inverted-pendulum`` (pendulum stage, free decay): a Furuta
  pendulum's free swing with the arm held still;
* :data:`emps`, ``EMPS`` (cart stage, driven by ``I``): a positioning stage under its own
  position loop, replayed open loop from the recorded controller output.

``physical-cartpole`` is not adapted: see :data:`SKIPPED`.
"""

from __future__ import annotations

from realdata import REALDATA, load_example

carriage = load_example("friction-identification")
furuta = load_example("rotary-inverted-pendulum")
emps = load_example("EMPS")

# ================================================================ physical-cartpole

CARTPOLE_CSV = REALDATA / "physical-cartpole" / "ICRA_ODE_2.csv"
SKIPPED = {
    "physical-cartpole": (
        "not fitted: today's stages cannot describe this run. (1) The command is a PWM duty to an "
        "H-bridge, a voltage: the force then depends on the motor's back-EMF and the supply, not on a "
        "current the cart stage can take. (2) The cart is belt driven, so back-drivable, and the pole "
        "swings up through the whole circle: the cart stage needs the pole's phi, w and alpha, which "
        "the recording holds only as a potentiometer angle and its finite difference. (3) The pendulum "
        "stage needs the cart's acceleration: the second difference of a 21 ms encoder position with "
        "latency jitter is mostly noise. (4) It is a closed loop (MPC) whose parameters were hand "
        "tuned, so there is no published identification to compare with either."),
}
