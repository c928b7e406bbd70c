"""Simulators: run component FMUs (alone or connected) on inputs from experiments."""

from pendfmu.simulator.component import ComponentFMU, FMUError, ParameterError, unpacked_fmu

__all__ = ["ComponentFMU", "FMUError", "ParameterError", "unpacked_fmu"]
