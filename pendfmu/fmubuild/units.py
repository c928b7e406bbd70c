"""SI base-unit exponents of every unit our variables use, for the FMI UnitDefinitions.

Units are written as Modelica writes them ("N.m", "m/s2"), so the FMUs and the
Modelica library name them alike.
"""

BASE_UNITS: dict[str, dict[str, int]] = {
    "1": {},
    "s": {"s": 1},
    "Hz": {"s": -1},
    "A": {"A": 1},
    "A/s": {"A": 1, "s": -1},
    "rad": {"rad": 1},
    "rad/s": {"rad": 1, "s": -1},
    "rad/s2": {"rad": 1, "s": -2},
    "kg": {"kg": 1},
    "kg.m2": {"kg": 1, "m": 2},
    "m": {"m": 1},
    "1/m": {"m": -1},
    "m/s": {"m": 1, "s": -1},
    "m/s2": {"m": 1, "s": -2},
    "N": {"kg": 1, "m": 1, "s": -2},
    "N.m": {"kg": 1, "m": 2, "s": -2},
    "N.m/A": {"kg": 1, "m": 2, "s": -2, "A": -1},
    "N.s/m": {"kg": 1, "s": -1},
    "N/s": {"kg": 1, "m": 1, "s": -3},  # rate of a force (the Cart's electrical lag)
    "N.m.s": {"kg": 1, "m": 2, "s": -1},
    "N.m.s2": {"kg": 1, "m": 2},  # quadratic drag k_dp: torque per (rad/s)^2
    "1/s": {"s": -1},  # the RigController's gains
    "1/s2": {"s": -2},
    "N/A": {"kg": 1, "m": 1, "s": -2, "A": -1},
}
