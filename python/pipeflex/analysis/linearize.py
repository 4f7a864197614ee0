"""Linearisation M dq_ddot + C dq_dot + K dq = 0 about a state, of every formulation."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Optional, Tuple

import numpy as np
import scipy.sparse as sp

from .. import _checks
from ..results import Result
from ._protocol import require_system
from .._blas import pinned as blas_pinned


@dataclass(frozen=True)
class Linearization(Result):
    """Sparse (CSC) matrices of the linearised equations in independent coordinates.

    ``M`` [kg, kg m, kg m^2] mass, ``C`` damping/gyroscopic (Coriolis of the flow
    included), ``K`` stiffness (elastic, geometric, follower and fluid centripetal terms;
    with joints, the geometric stiffness of their reactions). ``mass_flow`` mdot [kg/s];
    ``state`` the state linearised about (an element model's: a
    :class:`~pipeflex.state.State`, re-based: phi = 0, the rotation coordinates spatial
    rotation increments [rad] about it; bodies': a
    :class:`~pipeflex.multibody.MultibodyState` with its multipliers; a coupled system's:
    its :class:`~pipeflex.coupled.CoupledState`).

    Element models: the coordinates are the model's reduced coordinates, ``dof_labels``
    the model's (node, component) of each (which name the free coordinates of a
    mechanism). Bodies and coupled systems: q = q0 (+) T z with C_q T = 0, ``basis`` T
    (N x n_dofs, CSC; :func:`pipeflex.analysis.constrained.null_space_basis`) and
    ``unreduced`` (M, C, K) in the system's coordinates q, whose absolute values bound the
    reduction's round-off (:meth:`reduction_noise`); both None for an element model.
    """

    M: sp.csc_matrix
    C: sp.csc_matrix
    K: sp.csc_matrix
    mass_flow: float
    state: Any
    dof_labels: Optional[tuple] = None
    basis: Optional[sp.csc_matrix] = None
    unreduced: Optional[Tuple[sp.csc_matrix, sp.csc_matrix, sp.csc_matrix]] = None

    @property
    def n_dofs(self) -> int:
        """Number of independent coordinates."""
        return self.K.shape[0]

    def reduction_noise(self, lam, X) -> np.ndarray:
        """Round-off bound [1/s] that the reduction T^T X T adds to eigenvalues ``lam``
        with right vectors ``X`` (columns, independent coordinates):
        :func:`pipeflex.analysis.constrained.reduction_noise` (zeros without ``unreduced``)."""
        if self.unreduced is None:
            return np.zeros(len(np.atleast_1d(lam)))
        from .constrained import reduction_noise

        return reduction_noise(self, lam, X)


def constrained_fields(out: dict, mass_flow: float, state) -> dict:
    """:class:`Linearization`'s fields for a system with constraints (bodies, couplings)
    from the core's ``linear_matrices`` dictionary ``out`` about ``state``: the one
    reduction to the constraints' null space (:func:`pipeflex.analysis.constrained.linearization`)."""
    from . import constrained

    def fields(M, C, K, mdot, st, T, unreduced):  # constrained.linearization's positional order
        return dict(M=M, C=C, K=K, state=st, basis=T, unreduced=unreduced)

    return constrained.linearization(fields, out, mass_flow, state)


@blas_pinned
def linearize(model, state=None, *, mass_flow: Optional[float] = None, mass_flow_rate: float = 0.0) -> Linearization:
    """Linearise the equations of motion about ``state``.

    Args:
        model: an element :class:`~pipeflex.Model`, a
            :class:`~pipeflex.multibody.MultibodySystem` or a :class:`~pipeflex.CoupledSystem`.
        state: the state to linearise about (positions, velocities, accelerations; with
            joints their multipliers too); not modified. An element model: a
            :class:`~pipeflex.state.State` or ``_core.State``, default the reference
            configuration; its rotations are first re-based (phi = 0), so the rotation
            increments are small rotations about the current orientation. Bodies: a
            :class:`~pipeflex.multibody.MultibodyState`; a coupled system: a static result
            or a :class:`~pipeflex.coupled.CoupledState`; default the static equilibrium at
            ``mass_flow`` (so that the joint reactions, e.g. of the flow's junction forces,
            are consistent: linearising about a state whose multipliers do not balance its
            forces gives a wrong K).
        mass_flow: mdot [kg/s]; default the state's if it holds one (a static result),
            else the model's.
        mass_flow_rate: d(mdot)/dt [kg/s^2]: the fluid's relative acceleration term of a
            changing flow enters K (linear in it; bodies: the fluid's acceleration sddot
            along their centre line); the state is used as given (not moved to an
            equilibrium under that term).

    Bodies and coupled systems are linearised in independent coordinates (one constrained
    linearisation, :mod:`pipeflex.analysis.constrained`).
    """
    require_system(model)
    if mass_flow is None:
        held = getattr(state, "mass_flow", None)  # a static result holds the flow it is the equilibrium of
        mdot = model.mass_flow if held is None else float(held)
    else:
        mdot = _checks.finite("mass_flow", mass_flow)
    rate = _checks.finite("mass_flow_rate", mass_flow_rate)
    start = state
    if start is None and model._linearize_at_equilibrium:
        from .static import static_equilibrium

        start = model._equilibrium_state(static_equilibrium(model, mass_flow=mdot))
    return Linearization(mass_flow=mdot, **model._linearization(model._system(start, mass_flow=mdot), mdot,
                                                                mass_flow_rate=rate))
