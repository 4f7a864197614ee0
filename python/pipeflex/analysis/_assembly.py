"""Calls into the C++ assembler, returning scipy sparse matrices."""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .. import _core
from ..model import Model
from ..state import State


def require_model(model, name: str = "model"):
    """``model`` is a :class:`~pipeflex.Model`, else TypeError naming ``name`` (a
    :class:`~pipeflex.multibody.MultibodySystem` is dispatched before this check)."""
    if not isinstance(model, Model):
        hint = " (a tuple: pass the state as state=)" if isinstance(model, tuple) else ""
        raise TypeError(f"{name} must be a pipeflex.Model (ModelBuilder.build() or a scene) or a "
                        f"MultibodySystem, got {type(model).__name__}{hint}")
    return model


def residual_and_tangent(model, state, load, *, load_factor=1.0, wK=1.0, wC=0.0, wM=0.0, matrix=True):
    """Reduced residual R and tangent wK dR/dq + wC dR/dq_dot + wM M (CSC) at ``state``
    (a ``_core.State`` or a :class:`~pipeflex.state.State`)."""
    if isinstance(state, State):
        state = state.to_core(model)
    r, trip = _core.assemble(model.core, state, load, load_factor, wK, wC, wM, matrix)
    if trip is None:
        return np.asarray(r), None
    rows, cols, vals = trip
    n = model.n_dofs
    return np.asarray(r), sp.csc_matrix((vals, (rows, cols)), shape=(n, n))
