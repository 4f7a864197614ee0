"""pipeflex: flexible multibody dynamics of beams and fluid-conveying pipes.

SI units throughout. See ``docs/`` for the theory, conventions and user guide. The
library (models, sections, elements, bodies and joints, analyses, plotting) is
importable without the seed studies; ``pf.scenes`` (the seeds' test problems) and
:mod:`pipeflex.seeds` (their published numbers, studies and figures) load on first use.
"""
from typing import TYPE_CHECKING

from . import analysis
from . import _lazy
from . import _progress  # noqa: F401 (the "pipeflex" logger's NullHandler, from the first import)
from .errors import ConvergenceError, LimitPointError, SingularMatrixError, UnitWarning
from .model import Model, ModelBuilder
from .results import Result
from .sections import PipeSection
from .state import State
from .time_functions import Pulse, Sine

__version__ = "0.1.0"

# Attributes that load a module on first access (PEP 562, pipeflex._lazy), so that
# `import pipeflex` imports neither the seed studies nor scipy, matplotlib or threadpoolctl:
# "module" for a module, "module:attribute" for a module's attribute.
_LAZY = {"scenes": "pipeflex.scenes", "seeds": "pipeflex.seeds", "work_precision": "pipeflex.work_precision",
         "plotting": "pipeflex.plotting", "plot": "pipeflex.plot", "multibody": "pipeflex.multibody",
         "coriolis": "pipeflex.seeds.seed000.coriolis", "limit_cycle": "pipeflex.seeds.seed000.limit_cycle",
         "sweep": "pipeflex.sweeps:sweep", "sensor": "pipeflex.sensor", "coupled": "pipeflex.coupled",
         "CoupledSystem": "pipeflex.coupled:CoupledSystem",
         "load_model": "pipeflex.model_files:load_model", "save_model": "pipeflex.model_files:save_model",
         "stability_map": "pipeflex.analysis.stability_map:stability_map",
         **{name: f"pipeflex.analysis.forced:{name}"
            for name in ("Backbone", "FrequencyResponse", "FrequencySweep", "backbone", "forced_response",
                         "frequency_sweep")},
         **{name: f"pipeflex.analysis:{name}" for name in analysis.__all__ if name != "Sine"}}
__getattr__, __dir__ = _lazy.attach(__name__, _LAZY)

if TYPE_CHECKING:  # the lazy names, spelt out for editors and type checkers (tests/test_static_api.py)
    from . import coupled, multibody, plot, plotting, scenes, seeds, sensor, work_precision  # noqa: F401 (namespaces)
    from .analysis import (Bifurcation, Campbell, CriticalFlow, EigenResult, InstabilityChart, Linearization,
                           OrbitBranch,
                           OrbitGuess, ParametricStability, PeriodicOrbit, RotatingFrequencies, StaticResult,
                           SteadyRotation, SystemSteadyRotation, TransientResult, campbell, continue_orbits,
                           critical_mass_flow, eigenvalues, instability_chart, linearize, orbit_guess,
                           parametric_stability, periodic_orbit, pulsating_flow, resonance_speed,
                           rotating_frequencies, rotating_state, simulate, stability, static_equilibrium,
                           steady_rotation, switch_branch)
    from .analysis.forced import (Backbone, FrequencyResponse, FrequencySweep, backbone, forced_response,
                                  frequency_sweep)
    from .analysis.stability_map import stability_map
    from .coupled import CoupledSystem
    from .model_files import load_model, save_model
    from .seeds.seed000 import coriolis, limit_cycle  # noqa: F401 (namespaces)
    from .sweeps import sweep


__all__ = ["CriticalFlow", "EigenResult", "Linearization", "StaticResult",
           "critical_mass_flow", "eigenvalues", "linearize", "simulate", "stability", "static_equilibrium",
           "Pulse", "Sine", "TransientResult", "SteadyRotation", "SystemSteadyRotation", "steady_rotation",
           "RotatingFrequencies", "resonance_speed", "rotating_frequencies", "rotating_state",
           "OrbitBranch", "OrbitGuess", "PeriodicOrbit", "continue_orbits", "orbit_guess", "periodic_orbit",
           "Bifurcation", "switch_branch", "Campbell", "campbell", "stability_map", "sweep",
           "Backbone", "FrequencyResponse", "FrequencySweep", "backbone", "forced_response", "frequency_sweep",
           "InstabilityChart", "ParametricStability", "instability_chart", "parametric_stability", "pulsating_flow",
           "ConvergenceError", "LimitPointError", "SingularMatrixError", "UnitWarning", "Model", "ModelBuilder", "PipeSection", "Result", "State", "CoupledSystem", "load_model", "save_model", "__version__"]
