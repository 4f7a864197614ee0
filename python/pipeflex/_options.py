"""One vocabulary for options: renamed keywords that still work (with a DeprecationWarning),
the flow of a scene given as a mass flow [kg/s] or, where its paper speaks of one, a
flow speed [m/s], and one default per option of the time integration for every
formulation, with its reason."""
from __future__ import annotations

import functools
import warnings
from typing import Optional

from . import _checks


def renamed(**old_to_new: str):
    """Decorator: each keyword ``old=`` is still accepted for ``new=``, with a
    DeprecationWarning that names the new parameter; giving both is a TypeError."""

    def decorate(func):
        @functools.wraps(func)
        def wrapper(*args, **kwargs):
            for old, new in old_to_new.items():
                if old in kwargs:
                    if new in kwargs:
                        raise TypeError(f"{func.__name__}() got both {new!r} and its deprecated name {old!r}; "
                                        f"give {new!r} only")
                    warnings.warn(f"{func.__name__}(): the parameter {old!r} is deprecated, use {new!r}",
                                  DeprecationWarning, stacklevel=2)
                    kwargs[new] = kwargs.pop(old)
            return func(*args, **kwargs)

        wrapper.renamed_parameters = dict(old_to_new)
        return wrapper

    return decorate


def scene_mass_flow(mass_flow: Optional[float], flow_speed: Optional[float], fluid_mass: float, *,
                    default: Optional[float] = 0.0) -> float:
    """mdot [kg/s] of a scene from ``mass_flow`` mdot [kg/s] or ``flow_speed`` sdot [m/s]
    (mdot = ``fluid_mass`` mu_f [kg/m] x sdot); at most one may be given. Neither: the
    ``default`` mdot [kg/s] (``None``: one of them is required)."""
    if mass_flow is not None and flow_speed is not None:
        raise ValueError(f"give either mass_flow [kg/s] or flow_speed [m/s], not both (got mass_flow = {mass_flow!r}, "
                         f"flow_speed = {flow_speed!r})")
    if flow_speed is not None:
        v = _checks.finite("flow_speed", flow_speed)
        if v != 0.0 and fluid_mass <= 0.0:
            raise ValueError("flow_speed needs a section with fluid_mass > 0 (mass_flow = fluid_mass * flow_speed)")
        return fluid_mass * v
    if mass_flow is not None:
        return _checks.finite("mass_flow", mass_flow)
    if default is None:
        raise ValueError("give the flow: mass_flow [kg/s] or flow_speed [m/s]")
    return default


# ---------------------------------------------------------------------------------------
# One default per option of the transient analyses, for every formulation (element models,
# bodies, coupled systems): pipeflex.simulate and its thin aliases read them here.

#: rho_inf [-], generalised-alpha's spectral radius at infinite frequency. 0.8 for every
#: formulation: the index-3 equations of bodies and couplings need numerical damping of
#: their multipliers (< 1), and a freely spinning body with a preimposed curvature diverges
#: at 0.9 with h = 1 ms (at 0.95 at any step); on element models 0.8 is also the faster:
#: it damps the unresolved modes a flow start excites, so Newton needs fewer iterations
#: (the sprinkler over 1 s at h = 1 ms: 4112 against 5569 at 0.9, 0.075 against 0.093 s)
#: for an error of the resolved motion that hardly changes (8.0e-6 against 7.4e-6;
#: docs/performance.md, "One default").
RHO_INF = 0.8

#: newton_tol [-], Newton's tolerance on the position error left after a step, relative to
#: the model's size (length_scale), for every formulation. 1e-10: at 1e-9 Newton's error
#: shows in the element models' accuracy (the sprinkler, EI = 1000 N m^2, 3 s at h = 1 and
#: 0.5 ms: the Richardson extrapolation meets the direct steady rotation to 1.2e-10 at
#: 1e-10, to 2.6e-6 at 1e-9, 2.6e-5 with rho_inf = 0.9), while 1e-9 saves only 5-20 % of
#: the time (van Voorthuizen et al.'s semicircular pipe of 8 bodies over 4 s: 1.3 s against
#: 1.6 s, its final speed 5.3304267 against 5.3304203 rad/s, both within the published 1e-2).
NEWTON_TOL = 1e-10

#: max_newton, Newton iterations per step before the step is halved.
MAX_NEWTON = 12

#: step [s] of generalised-alpha with integrator="generalized_alpha" and no step given
#: ("auto" chooses one from the linearised model: pipeflex.analysis.transient.default_step).
STEP = 1e-3

#: max_steps: the most steps a run may take (refused before the first step).
MAX_STEPS = 10_000_000
