"""`pendfmu check`: a battery of checks on any FMI 2.0 FMU (Co-Simulation and Model
Exchange): static (model description, exports, GUID, capabilities), call sequence (misuse
answered with an error, never a crash or NaN), determinism (fresh instances and reset),
state rollback, step-size convergence and finite outputs over the inputs' range. Each
check gives `CheckResult(name, passed, figure, message)` rows; see battery.run_battery."""

from pendfmu.check.fmu import CheckResult

__all__ = ["CheckResult", "run_battery"]


def run_battery(*args, **kwargs):
    from pendfmu.check.battery import run_battery as run

    return run(*args, **kwargs)
