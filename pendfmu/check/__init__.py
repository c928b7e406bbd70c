"""`pendfmu check`: a battery of checks on any FMI 2.0 or 3.0 FMU (Co-Simulation and Model
Exchange): static (model description, exports, GUID, capabilities), call sequence (misuse
answered with an error, never a crash or NaN), the events a stimulus shows (events.py),
determinism (fresh instances and reset), state rollback, step-size convergence, finite
outputs over the inputs' range and beyond an undeclared one, and agreement with a reference
result inside a tolerance tube (reference.py; `compare` for results already computed,
reference results carried in the FMU under FMI-LS-REF). The dynamic checks run on a stimulus
searched for to move the outputs and show events (stimulus.py), and say what they exercised
(exercise.py). Each check gives `CheckResult(name, verdict, figure, message)` rows (PASS, WARN,
FAIL, INCONCLUSIVE: nothing exercised); see battery.run_battery."""

from pendfmu.check.battery import run_battery
from pendfmu.check.fmu import CheckResult
from pendfmu.check.reference import compare

__all__ = ["CheckResult", "compare", "run_battery"]
