"""Floating frame of reference (van Voorthuizen et al.): flexible bodies, joints, analyses."""
from .analysis import (MultibodyLinearization, MultibodyResult, MultibodyStatic, linearize,
                       simulate, static_equilibrium)
from .body import FlexibleBody, flexible_body
from .system import MultibodyBuilder, MultibodyState, MultibodySystem

__all__ = ["FlexibleBody", "flexible_body", "MultibodyBuilder", "MultibodyState", "MultibodySystem",
           "MultibodyLinearization", "MultibodyResult", "MultibodyStatic", "linearize",
           "simulate", "static_equilibrium"]
