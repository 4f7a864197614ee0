"""pipeflex: flexible multibody dynamics of beams and fluid-conveying pipes.

SI units throughout. See ``docs/`` for the theory, conventions and user guide.
"""
from . import coriolis, limit_cycle, scenes, work_precision
from .analysis import (CriticalFlow, EigenResult, Linearization, StaticResult, critical_mass_flow,
                       eigenvalues, linearize, simulate, stability, static_equilibrium,
                       Sine, TransientResult, SteadyRotation, steady_rotation,
                       RotatingFrequencies, resonance_speed, rotating_frequencies, rotating_state)
from .errors import ConvergenceError
from .model import Model, ModelBuilder
from .sections import PipeSection

__version__ = "0.1.0"

__all__ = ["scenes", "coriolis", "limit_cycle", "work_precision", "CriticalFlow", "EigenResult", "Linearization", "StaticResult",
           "critical_mass_flow", "eigenvalues", "linearize", "simulate", "stability", "static_equilibrium",
           "Sine", "TransientResult", "SteadyRotation", "steady_rotation",
           "RotatingFrequencies", "resonance_speed", "rotating_frequencies", "rotating_state",
           "ConvergenceError", "Model", "ModelBuilder", "PipeSection"]
