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


class _TripletPattern:
    """CSC structure of a triplet list (rows, cols) with duplicates, and where each triplet
    lands in it: the assembler emits the same triplet order at every call, so the sort of a
    COO -> CSC conversion (most of linearize's time beyond the assembly) is done once and
    each later matrix is one weighted bincount."""

    def __init__(self, rows, cols, n):
        self.rows, self.cols, self.n = rows, cols, n
        key = cols.astype(np.int64) * n + rows
        uniq, self.slot = np.unique(key, return_inverse=True)
        self.indices = (uniq % n).astype(np.int32)
        self.indptr = np.concatenate([[0], np.cumsum(np.bincount(uniq // n, minlength=n))]).astype(np.int32)

    def matches(self, rows, cols, n):
        return n == self.n and np.array_equal(rows, self.rows) and np.array_equal(cols, self.cols)

    def csc(self, vals):
        data = np.bincount(self.slot, weights=vals, minlength=len(self.indices))
        A = sp.csc_matrix((data, self.indices.copy(), self.indptr.copy()), shape=(self.n, self.n))
        A.has_canonical_format = True
        return A


_pattern = None  # the last triplet pattern (models alternate rarely; a mismatch rebuilds it)


def residual_and_tangent(model, state, load, *, load_factor=1.0, wK=1.0, wC=0.0, wM=0.0, matrix=True):
    """Reduced residual R and tangent wK dR/dq + wC dR/dq_dot + wM M (CSC) at ``state``
    (a ``_core.State`` or a :class:`~pipeflex.state.State`)."""
    global _pattern
    if isinstance(state, State):
        state = state.to_core(model)
    r, trip = _core.assemble(model.core, state, load, load_factor, wK, wC, wM, matrix)
    if trip is None:
        return np.asarray(r), None
    rows, cols, vals = (np.asarray(x) for x in trip)
    n = model.n_dofs
    pattern = _pattern
    if pattern is None or not pattern.matches(rows, cols, n):
        pattern = _pattern = _TripletPattern(rows, cols, n)
    return np.asarray(r), pattern.csc(vals)
