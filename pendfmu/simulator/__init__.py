"""Simulators: run component FMUs (alone or connected) on inputs from experiments."""

from pendfmu.errors import FMUError
from pendfmu.simulator.component import ComponentFMU, ParameterError
from pendfmu.simulator.fmi import unpacked_fmu

__all__ = ["ComponentFMU", "FMUError", "ParameterError", "unpacked_fmu"]
