"""Linearisation of constrained systems (bodies, coupled element + body models).

The core's ``linear_matrices`` gives, about a state with its multipliers, the sparse
    M dq'' + C dq' + K dq + C_q^T dlam = 0,   C_q dq = 0
in the system's coordinates q (K with the constraint forces' geometric stiffness). The
motions the constraints allow are q = T z with C_q T = 0, T an orthonormal basis of the
null space: the reduced matrices T^T X T are what :func:`pipeflex.eigenvalues` and
:func:`pipeflex.stability` analyse, one linearisation for every kind of system.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from ..results import Result


@dataclass(frozen=True)
class ConstrainedLinearization(Result):
    """M, C, K (CSC) in independent coordinates z: the system's coordinates are
    q = q0 (+) T z with C_q T = 0 (``basis`` T, N x n_dofs, orthonormal), about ``state``,
    at ``mass_flow`` mdot [kg/s]. Same use as :class:`pipeflex.Linearization`
    (:func:`pipeflex.eigenvalues`, :func:`pipeflex.stability`)."""

    M: sp.csc_matrix
    C: sp.csc_matrix
    K: sp.csc_matrix
    mass_flow: float
    state: Any
    basis: np.ndarray


def from_core(out: dict):
    """(K, C, M, C_q) as CSC matrices from the core's ``linear_matrices`` dictionary."""
    n, nc = out["n"], out["nc"]

    def csc(key, rows):
        r, c, v = out[key]
        return sp.csc_matrix((v, (r, c)), shape=(rows, n))

    return csc("K", n), csc("C", n), csc("M", n), csc("Cq", nc)


def null_space_basis(Cq) -> np.ndarray:
    """Orthonormal basis T (N x N - rank) of the null space of the constraint Jacobian."""
    Cq = Cq.toarray() if sp.issparse(Cq) else np.asarray(Cq)
    if Cq.shape[0] == 0:
        return np.eye(Cq.shape[1])
    return sla.null_space(Cq, rcond=1e-10)


def reduce(T: np.ndarray, *matrices):
    """T^T X T (CSC) of each sparse X."""
    return tuple(sp.csc_matrix(T.T @ (X @ T)) for X in matrices)


def linearization(cls, out: dict, mass_flow: float, state):
    """A ``cls`` (a :class:`ConstrainedLinearization`) from the core's ``linear_matrices``
    about ``state``: the matrices reduced to the constraints' null space."""
    K, C, M, Cq = from_core(out)
    T = null_space_basis(Cq)
    Mr, Cr, Kr = reduce(T, M, C, K)
    return cls(Mr, Cr, Kr, mass_flow, state, T)
