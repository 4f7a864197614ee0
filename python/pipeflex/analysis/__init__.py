"""Analyses as free functions of a model and a state.

Each name imports its module on first use (:mod:`pipeflex._lazy`): the transient and
static analyses need neither scipy nor the eigen-analysis modules.
"""
from typing import TYPE_CHECKING

from .. import _lazy

#: the public names of each analysis module
_MODULES = {"campbell": ["Campbell", "campbell",
           "InstabilityChart", "ParametricStability", "instability_chart", "parametric_stability", "pulsating_flow"],
            "critical": ["CriticalFlow", "critical_mass_flow"],
            "eigen": ["EigenResult", "eigenvalues", "stability"],
            "linearize": ["Linearization", "linearize"],
            "parametric": ["InstabilityChart", "ParametricStability", "instability_chart", "parametric_stability",
                           "pulsating_flow"],
            "periodic": ["Bifurcation", "OrbitBranch", "OrbitGuess", "PeriodicOrbit", "continue_orbits",
                         "orbit_guess", "periodic_orbit", "switch_branch"],
            "rotating": ["RotatingFrequencies", "resonance_speed", "rotating_frequencies", "rotating_state"],
            "static": ["StaticResult", "static_equilibrium"],
            "steady": ["SteadyRotation", "SystemSteadyRotation", "steady_rotation"],
            "transient": ["Sine", "TransientResult", "simulate"]}
_LAZY = {name: f"{__name__}.{module}:{name}" for module, names in _MODULES.items() for name in names}
__getattr__, __dir__ = _lazy.attach(__name__, _LAZY)

if TYPE_CHECKING:  # the lazy names, spelt out for editors and type checkers (tests/test_static_api.py)
    from .campbell import Campbell, campbell
    from .critical import CriticalFlow, critical_mass_flow
    from .eigen import EigenResult, eigenvalues, stability
    from .linearize import Linearization, linearize
    from .parametric import (InstabilityChart, ParametricStability, instability_chart, parametric_stability,
                             pulsating_flow)
    from .periodic import (Bifurcation, OrbitBranch, OrbitGuess, PeriodicOrbit, continue_orbits, orbit_guess,
                           periodic_orbit, switch_branch)
    from .rotating import RotatingFrequencies, resonance_speed, rotating_frequencies, rotating_state
    from .static import StaticResult, static_equilibrium
    from .steady import SteadyRotation, SystemSteadyRotation, steady_rotation
    from .transient import Sine, TransientResult, simulate

__all__ = ["CriticalFlow", "critical_mass_flow", "EigenResult", "eigenvalues", "stability",
           "Linearization", "linearize", "OrbitBranch", "OrbitGuess", "PeriodicOrbit", "continue_orbits", "orbit_guess", "periodic_orbit",
           "Bifurcation", "switch_branch", "StaticResult", "static_equilibrium",
           "Sine", "TransientResult", "simulate", "SteadyRotation", "SystemSteadyRotation", "steady_rotation",
           "RotatingFrequencies", "resonance_speed", "rotating_frequencies", "rotating_state", "Campbell", "campbell",
           "InstabilityChart", "ParametricStability", "instability_chart", "parametric_stability", "pulsating_flow"]
