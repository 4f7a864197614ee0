"""Analyses as free functions of a model and a state."""
from .campbell import Campbell, campbell
from .critical import CriticalFlow, critical_mass_flow
from .eigen import EigenResult, eigenvalues, stability
from .linearize import Linearization, linearize
from .periodic import OrbitBranch, OrbitGuess, PeriodicOrbit, continue_orbits, orbit_guess, periodic_orbit
from .rotating import RotatingFrequencies, resonance_speed, rotating_frequencies, rotating_state
from .static import StaticResult, static_equilibrium
from .steady import SteadyRotation, steady_rotation
from .transient import Sine, TransientResult, simulate

__all__ = ["CriticalFlow", "critical_mass_flow", "EigenResult", "eigenvalues", "stability",
           "Linearization", "linearize", "OrbitBranch", "OrbitGuess", "PeriodicOrbit", "continue_orbits", "orbit_guess", "periodic_orbit",
           "StaticResult", "static_equilibrium",
           "Sine", "TransientResult", "simulate", "SteadyRotation", "steady_rotation",
           "RotatingFrequencies", "resonance_speed", "rotating_frequencies", "rotating_state", "Campbell", "campbell"]
