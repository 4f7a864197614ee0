"""The element assembler's own calls, returning scipy sparse matrices: the residual
(static and rotating analyses' checks) and, as the tests' reference, the tangents of one
pass over the elements (``_core.assemble_csc``). The analyses linearise through the one
system object (``Model._linearization``: the core's ``linear_matrices``)."""
from __future__ import annotations

import numpy as np

from .. import _core
from ..model import Model
from ..state import State


def require_model(model, name: str = "model", *, why: str = ""):
    """``model`` is a :class:`~pipeflex.Model`, else TypeError naming ``name`` (the
    analyses that take a :class:`~pipeflex.multibody.MultibodySystem` or a
    :class:`~pipeflex.CoupledSystem` dispatch them before this check; for the others the
    message says that they take element models only, and ``why``)."""
    if not isinstance(model, Model):
        kind = type(model).__name__
        if isinstance(model, tuple):
            hint = " (a tuple: pass the state as state=)"
        elif kind in ("MultibodySystem", "CoupledSystem"):
            hint = (f": this analysis takes element models only{': ' + why if why else ''} (docs/capabilities.md "
                    "lists which analysis takes which system)")
        else:
            hint = (" (static_equilibrium, linearize, critical_mass_flow, steady_rotation and simulate also take a "
                    "MultibodySystem or a CoupledSystem)")
        raise TypeError(f"{name} must be a pipeflex.Model (ModelBuilder.build() or a scene), got {kind}{hint}")
    return model


# the weights of K, C and M, for tangents()
KCM = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))


def tangents(model, state, load, weights, *, load_factor=1.0, residual=False):
    """Tangents wK dR/dq + wC dR/dq_dot + wM M (CSC) for each (wK, wC, wM) in ``weights``,
    assembled by the core in one pass over the elements straight into the model's cached
    CSC pattern (no triplets), at ``state`` as it is (not re-based); with ``residual``,
    (R, [matrices]) else [matrices]. The tests' reference: no analysis calls it."""
    from .constrained import _csc  # scipy: on first use

    if isinstance(state, State):
        state = state.to_core(model)
    r, data, indices, indptr = _core.assemble_csc(model.core, state, load, load_factor,
                                                  [tuple(map(float, w)) for w in weights], residual)
    n = model.n_dofs
    mats = [_csc(d, indices if k == 0 else indices.copy(), indptr if k == 0 else indptr.copy(), n)
            for k, d in enumerate(data)]
    return (np.asarray(r), mats) if residual else mats


def residual_and_tangent(model, state, load, *, load_factor=1.0, wK=1.0, wC=0.0, wM=0.0, matrix=True):
    """Reduced residual R and tangent wK dR/dq + wC dR/dq_dot + wM M (CSC) at ``state``
    (a ``_core.State`` or a :class:`~pipeflex.state.State`); None for the matrix unless
    ``matrix``."""
    if isinstance(state, State):
        state = state.to_core(model)
    if not matrix:
        r, _ = _core.assemble(model.core, state, load, load_factor, wK, wC, wM, False)
        return np.asarray(r), None
    r, (J,) = tangents(model, state, load, [(wK, wC, wM)], load_factor=load_factor, residual=True)
    return r, J
