"""Floating frame of reference (van Voorthuizen et al.): flexible bodies, joints, analyses."""
from .analysis import MultibodyResult, MultibodyStatic, linearize, simulate, static_equilibrium
from .body import FlexibleBody, flexible_body
from .system import MultibodyBuilder, MultibodyState, MultibodySystem

__all__ = ["FlexibleBody", "flexible_body", "MultibodyBuilder", "MultibodyState", "MultibodySystem",
           "MultibodyLinearization", "MultibodyResult", "MultibodyStatic", "linearize",
           "simulate", "static_equilibrium"]


def __getattr__(name):
    if name == "MultibodyLinearization":  # imported when asked (it loads scipy.sparse)
        from .analysis import MultibodyLinearization

        return MultibodyLinearization
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
