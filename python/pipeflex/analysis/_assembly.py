"""Calls into the C++ assembler, returning scipy sparse matrices."""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .. import _core
from ..state import State


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
