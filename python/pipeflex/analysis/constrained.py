"""Linearisation of constrained systems (bodies, coupled element + body models).

The core's ``linear_matrices`` gives, about a state with its multipliers, the sparse
    M dq'' + C dq' + K dq + C_q^T dlam = 0,   C_q dq = 0
in the system's coordinates q (K with the constraint forces' geometric stiffness). The
motions the constraints allow are q = T z with C_q T = 0, T an orthonormal basis of the
null space: the reduced matrices T^T X T are what :func:`pipeflex.eigenvalues` and
:func:`pipeflex.stability` analyse, one linearisation for every kind of system.
"""
from __future__ import annotations

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp


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
