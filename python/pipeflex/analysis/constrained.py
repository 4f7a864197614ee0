"""Linearisation of constrained systems (bodies, coupled element + body models).

The core's ``linear_matrices`` gives, about a state with its multipliers, the sparse::

    M dq'' + C dq' + K dq + C_q^T dlam = 0,   C_q dq = 0

in the system's coordinates q (K with the constraint forces' geometric stiffness). The
motions the constraints allow are q = T z with C_q T = 0, T a basis of the null space:
the reduced matrices T^T X T are what :func:`pipeflex.eigenvalues` and
:func:`pipeflex.stability` analyse, one linearisation for every kind of system.

The basis is orthonormal in the metric of K's diagonal, D T with ``D = |diag K|^(1/2)``
(:func:`null_space_basis`), not in the coordinates' own: a basis orthonormal in q mixes
the few coordinates a joint ties (a stiff hub body's axial coordinate, EA/l ~ 1e20 N/m,
with a pipe's bending at its root, ~1e3 N/m) into several columns, so that the reduced
stiffness carries the hub's 1e20 in every one of them and the pipe's stiffness only in
their differences: round-off ``eps |K|`` ~ 3e4 N/m there, a reduced stiffness singular to
round-off after any diagonal scaling (conditioning 3e-15: :func:`pipeflex.stability`
called the cantilever on a stiff clamped hub a mechanism) and the bending planes split
by 1e-7. In the metric each column carries stiffness of its own scale: the cantilever's
eigenvalues then agree with the clamped one's to 4e-9, the planes exactly, and the
conditioning is the clamped cantilever's (6e-5). Eigenvalues do not depend on the
basis (congruence); only the round-off does.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Optional, Tuple

import numpy as np
import scipy.sparse as sp

from ..results import Result


@dataclass(frozen=True)
class ConstrainedLinearization(Result):
    """M, C, K (CSC) in independent coordinates z: the system's coordinates are
    q = q0 (+) T z with C_q T = 0 (``basis`` T, N x n_dofs, orthonormal in the metric of
    K's diagonal: :func:`null_space_basis`), about ``state``,
    at ``mass_flow`` mdot [kg/s]. Same use as :class:`pipeflex.Linearization`
    (:func:`pipeflex.eigenvalues`, :func:`pipeflex.stability`). ``unreduced``:
    (M, C, K) in the system's coordinates q (CSC), whose absolute values bound the
    reduction's round-off (:func:`reduction_noise`; taken only where it is needed)."""

    M: sp.csc_matrix
    C: sp.csc_matrix
    K: sp.csc_matrix
    mass_flow: float
    state: Any
    basis: np.ndarray
    unreduced: Optional[Tuple[sp.csc_matrix, sp.csc_matrix, sp.csc_matrix]] = None

    @property
    def n_dofs(self) -> int:
        """Number of independent coordinates z."""
        return self.basis.shape[1]

    def reduction_noise(self, lam, X) -> np.ndarray:
        """Round-off bound [1/s] that the reduction T^T X T adds to eigenvalues ``lam``
        with right vectors ``X`` (columns, coordinates z): see :func:`reduction_noise`
        (zeros without ``unreduced``)."""
        if self.unreduced is None:
            return np.zeros(len(np.atleast_1d(lam)))
        return reduction_noise(self, lam, X)


def from_core(out: dict):
    """(K, C, M, C_q) as CSC matrices from the core's ``linear_matrices`` dictionary."""
    n, nc = out["n"], out["nc"]

    def csc(key, rows):
        r, c, v = out[key]
        return sp.csc_matrix((v, (r, c)), shape=(rows, n))

    return csc("K", n), csc("C", n), csc("M", n), csc("Cq", nc)


def null_space_basis(Cq, K=None) -> np.ndarray:
    """Basis T (N x N - rank) of the null space of the constraint Jacobian, C_q T = 0,
    with D T orthonormal, ``D = |diag K|^(1/2)`` (the identity without K; coordinates without
    stiffness, e.g. the frame of a free body, take the median of the others): see the
    module doc. The rank is that of C_q itself (singular values above 1e-10 of the
    largest): in the metric a constraint on a stiff coordinate has a column of 1/sqrt(K_ii)
    (~1e-10 relative for the stiff hub), which a relative cutoff there would drop,
    freeing a motion the joint locks."""
    Cq = Cq.toarray() if sp.issparse(Cq) else np.asarray(Cq)
    n = Cq.shape[1]
    d = np.ones(n)
    if K is not None:
        k = np.abs(K.diagonal())
        stiff = k[k > 0.0]
        d = np.sqrt(np.where(k > 0.0, k, np.median(stiff) if len(stiff) else 1.0))
    if Cq.shape[0] == 0:
        return np.diag(1.0 / d)
    sv = np.linalg.svd(Cq, compute_uv=False)
    rank = int(np.sum(sv > 1e-10 * sv[0])) if sv[0] > 0.0 else 0
    Vt = np.linalg.svd(Cq / d[None, :])[2]
    return Vt[rank:].T / d[:, None]


def reduce(T: np.ndarray, *matrices):
    """T^T X T (CSC) of each sparse X."""
    return tuple(sp.csc_matrix(T.T @ (X @ T)) for X in matrices)


def linearization(cls, out: dict, mass_flow: float, state):
    """A ``cls`` (a :class:`ConstrainedLinearization`) from the core's ``linear_matrices``
    about ``state``: the matrices reduced to the constraints' null space, with the
    unreduced ones, whose absolute values bound the reduction's round-off."""
    K, C, M, Cq = from_core(out)
    T = null_space_basis(Cq, K)
    Mr, Cr, Kr = reduce(T, M, C, K)
    return cls(Mr, Cr, Kr, mass_flow, state, T, (M, C, K))


def reduction_noise(lin: ConstrainedLinearization, lam, X) -> np.ndarray:
    """Round-off bound [1/s] of eigenvalues ``lam`` (right vectors ``X``, columns) that
    the reduction adds: each entry of T^T X T is a sum of N products, in error by at most
    N eps (|T|^T |X| |T|) (componentwise), which moves lam to first order by
        N eps |x|^T (|lam|^2 |M|_T + |lam| |C|_T + |K|_T) |x| / |x^H T'(lam) x|,
    |X|_T = |T|^T |X| |T| (x stands in for the left vector, as in
    :func:`~pipeflex.analysis.eigen.eigen_noise`), computed as y^T |X| y with y = |T| |x|
    from the unreduced |X| (``lin.unreduced``: sparse, no second reduction). A
    worst case (signs aligned), so a
    bound: where the basis mixes a stiff coordinate into the columns of a soft one this
    is large (an orthonormal basis for the cantilever on a stiff hub: 1.4e-4 1/s on its
    4 rad/s mode, 6e6 times the eigen-solver's own bound); in the metric of
    :func:`null_space_basis` it is 5e-10 1/s there (44 times the solver's bound at most,
    below GROWTH_TOL |lambda|)."""
    Ma, Ca, Ka = (abs(X) for X in lin.unreduced)
    lam = np.atleast_1d(np.asarray(lam, complex))
    X = np.asarray(X, complex).reshape(lin.basis.shape[1], -1)
    y, al = np.abs(lin.basis) @ np.abs(X), np.abs(lam)
    num = np.sum(y * (al**2 * (Ma @ y) + al * (Ca @ y) + Ka @ y), axis=0)
    den = np.abs(np.sum(X.conj() * (2 * lam * (lin.M @ X) + lin.C @ X), axis=0))
    return lin.basis.shape[0] * np.finfo(float).eps * num / np.maximum(den, 1e-300)
