"""`pendfmu check`: a battery of checks on any FMI 2.0 or 3.0 FMU (Co-Simulation and Model
Exchange): static (model description, exports, GUID, capabilities), call sequence (misuse
answered with an error, never a crash or NaN), determinism (fresh instances and reset),
state rollback, step-size convergence, finite outputs over the inputs' range, and agreement
with a reference result inside a tolerance tube (reference.py; `compare` for results already
computed, reference results carried in the FMU under FMI-LS-REF). Each check gives
`CheckResult(name, verdict, figure, message)` rows (PASS, WARN, FAIL, INCONCLUSIVE); see battery.run_battery."""

from pendfmu.check.fmu import CheckResult

__all__ = ["CheckResult", "compare", "run_battery"]


def run_battery(*args, **kwargs):
    from pendfmu.check.battery import run_battery as run

    return run(*args, **kwargs)


def compare(*args, **kwargs):
    """pendfmu.check.reference.compare: results inside the reference's tolerance tube."""
    from pendfmu.check.reference import compare as tube_compare

    return tube_compare(*args, **kwargs)
