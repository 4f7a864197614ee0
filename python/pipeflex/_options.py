"""One vocabulary for options: renamed keywords that still work (with a DeprecationWarning)
and the flow of a scene given as a mass flow [kg/s] or, where its paper speaks of one, a
flow speed [m/s]."""
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
