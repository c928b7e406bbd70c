"""Four more real data sets, as a new user would bring them to pendfmu.

The conversions live in ``examples/realdata/<name>/convert.py`` (one copy, shared with the
examples, ``realdata_cases.py`` and ``scripts/realdata_fits.py``); this module loads them:

* :data:`carriage`, ``friction-identification`` (cart stage, driven by ``I``): a servo
  carriage, start-up and braking to rest;
* :data:`furuta`, ``rotary-inverted-pendulum`` (pendulum stage, free decay): a Furuta
  pendulum's free swing with the arm held still;
* :data:`emps`, ``EMPS`` (cart stage, driven by ``I``): a positioning stage under its own
  position loop, replayed open loop from the recorded controller output;
* :data:`cartpole`, ``physical-cartpole`` (the Cart FMU driven by ``u`` = Q, back-driven by
  the recorded pole; the pole driven by the cart's acceleration): a belt-driven cart-pole's
  swing-up and balance under MPC.
"""

from __future__ import annotations

from realdata import load_example

carriage = load_example("friction-identification")
furuta = load_example("rotary-inverted-pendulum")
emps = load_example("EMPS")

# ================================================================ physical-cartpole

# ``physical-cartpole`` (a model fit: the Cart FMU driven by the command Q and back-driven by
# the recorded pole, in 1.5 s pieces; the pole from the swing-up's pieces): fitted by its
# example, tested in test_examples_realdata.py (the motion fixes k_u/M and k_fwc/M, not the
# mass, which it bounds from below at 0.81 kg). Its fits are model fits with several
# commands, not one stage, so realdata_cases.py does not repeat them over seeds.
cartpole = load_example("physical-cartpole")
CARTPOLE_CSV = cartpole.CARTPOLE_CSV
SKIPPED: dict[str, str] = {}  # every rig is fitted now
