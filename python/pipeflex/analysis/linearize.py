"""Linearisation M dq_ddot + C dq_dot + K dq = 0 about a state."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import scipy.sparse as sp

from .. import _checks
from .._lazy import loaded_instance
from ..results import Result
from ..state import State, as_core
from ._assembly import KCM, require_model, tangents
from .._blas import pinned as blas_pinned


@dataclass(frozen=True)
class Linearization(Result):
    """Sparse (CSC) matrices of the linearised equations in the reduced coordinates.

    ``M`` [kg, kg m, kg m^2] mass, ``C`` damping/gyroscopic (Coriolis of the flow
    included), ``K`` stiffness (elastic, geometric, follower and fluid centripetal terms).
    The rotation coordinates are spatial rotation increments [rad] about the state.
    ``mass_flow`` mdot [kg/s]; ``state`` the :class:`~pipeflex.state.State` linearised
    about (re-based: phi = 0); ``dof_labels`` the model's (node, component) of each
    coordinate (None if not known), which name the free coordinates of a mechanism.
    """

    M: sp.csc_matrix
    C: sp.csc_matrix
    K: sp.csc_matrix
    mass_flow: float
    state: Optional[State]
    dof_labels: Optional[tuple] = None


@blas_pinned
def linearize(model, state=None, *, mass_flow: Optional[float] = None) -> Linearization:
    """Linearise the equations of motion about ``state`` (default: reference configuration).

    The state's rotations are first re-based (phi = 0), so the rotation increments are
    small rotations about the current orientation.

    Args:
        model: the model.
        state: state to linearise about (positions, velocities, accelerations; a
            :class:`~pipeflex.state.State` or ``_core.State``); not modified.
        mass_flow: mdot [kg/s] (default the model's).

    A :class:`~pipeflex.multibody.MultibodySystem` and a :class:`~pipeflex.CoupledSystem`
    are linearised in independent coordinates by :func:`pipeflex.multibody.linearize` and
    :func:`pipeflex.coupled.linearize` (one constrained linearisation,
    :mod:`pipeflex.analysis.constrained`).
    """
    if loaded_instance(model, "pipeflex.multibody.system", "MultibodySystem"):
        from ..multibody import linearize as multibody_linearize

        return multibody_linearize(model, state, mass_flow=mass_flow)
    own = getattr(model, "_linearize", None)  # a system with its own (pipeflex.CoupledSystem)
    if own is not None:
        return own(state, mass_flow=mass_flow)
    require_model(model)
    s = as_core(model, state)
    s.rebase(0.0)
    mdot = model.mass_flow if mass_flow is None else _checks.finite("mass_flow", mass_flow)
    load = model.load_state(mass_flow=mdot)
    K, C, M = tangents(model, s, load, KCM)
    return Linearization(M, C, K, mdot, State.from_core(s, model), model.dof_labels)
