"""Linearisation of constrained systems (bodies, coupled element + body models).

The core's ``linear_matrices`` gives, about a state with its multipliers, the sparse::

    M dq'' + C dq' + K dq + C_q^T dlam = 0,   C_q dq = 0

in the system's coordinates q (K with the constraint forces' geometric stiffness). The
motions the constraints allow are q = T z with C_q T = 0, T a basis of the null space:
the reduced matrices T^T X T are what :func:`pipeflex.eigenvalues` and
:func:`pipeflex.stability` analyse, one linearisation for every kind of system.

The basis is sparse, by elimination of dependent coordinates, and chosen in the metric of
K's diagonal, y = D q with ``D = |diag K|^(1/2)`` (:func:`null_space_basis`): only the
columns of C_q with nonzeros take part (a coupled arm's joint touches 24 of its 6 N
coordinates), every other coordinate keeps a column of its own, and T^T X T is a sparse
product, so a linearisation costs O(N) (a dense SVD of C_q and a dense T cost O(N^3):
55 s for a coupled arm of 1024 elements). The metric decides which coordinates are
eliminated: each constraint row pivots on its largest entry in y, so that the multipliers
stay O(1) there and no column carries a stiff coordinate's stiffness beside a soft one's.
A basis orthonormal in q instead mixes the few coordinates a joint ties (a stiff hub
body's axial coordinate, EA/l ~ 1e20 N/m, with a pipe's bending at its root, ~1e3 N/m)
into several columns, so that the reduced stiffness carries the hub's 1e20 in every one
of them and the pipe's stiffness only in their differences: round-off ``eps |K|`` ~ 3e4
N/m there, a reduced stiffness singular to round-off after any diagonal scaling
(:func:`pipeflex.stability` called the cantilever on a stiff clamped hub a mechanism) and
the bending planes split by 1e-7. In the metric each column carries stiffness of its own
scale: the cantilever's eigenvalues then agree with the clamped one's to 4e-9, the planes
exactly, and the conditioning is the clamped cantilever's (6.5e-5). Eigenvalues do not
depend on the basis (congruence); only the round-off does. A free motion (a hinge with
nothing to turn it back) falls in one column, whose stiffness is the core's round-off:
:func:`stiffness_floor` makes it zero, so that a mechanism stays one.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Optional, Tuple

import numpy as np
import scipy.sparse as sp

from ..results import Result


def _csc(data, indices, indptr, n, *, rows=None):
    """The core's compressed columns (rows ascending, no repeats) as a scipy CSC matrix,
    ``rows`` (default n) x n, without a copy."""
    A = sp.csc_matrix((data, indices, indptr), shape=(n if rows is None else rows, n), copy=False)
    A.has_sorted_indices = True  # the core's pattern: rows ascending, no repeats
    A.has_canonical_format = True
    return A


@dataclass(frozen=True)
class ConstrainedLinearization(Result):
    """M, C, K (CSC) in independent coordinates z: the system's coordinates are
    q = q0 (+) T z with C_q T = 0 (``basis`` T, N x n_dofs, CSC, by elimination in the
    metric of K's diagonal: :func:`null_space_basis`), about ``state``,
    at ``mass_flow`` mdot [kg/s]. Same use as :class:`pipeflex.Linearization`
    (:func:`pipeflex.eigenvalues`, :func:`pipeflex.stability`). ``unreduced``:
    (M, C, K) in the system's coordinates q (CSC), whose absolute values bound the
    reduction's round-off (:func:`reduction_noise`; taken only where it is needed)."""

    M: sp.csc_matrix
    C: sp.csc_matrix
    K: sp.csc_matrix
    mass_flow: float
    state: Any
    basis: sp.csc_matrix
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
    """(K, C, M, C_q) as CSC matrices from the core's ``linear_matrices`` dictionary (its
    compressed columns, taken without a copy)."""
    n, nc = out["n"], out["nc"]
    return (_csc(*out["K"], n), _csc(*out["C"], n), _csc(*out["M"], n), _csc(*out["Cq"], n, rows=nc))


def metric(K, n: int) -> np.ndarray:
    """``d = |diag K|^(1/2)``, the metric of :func:`null_space_basis` (ones without K;
    coordinates without stiffness, e.g. the frame of a free body, take the median of the
    others).

    Args:
        K: K [N/m] (n x n, sparse; N m/rad on rotations) the stiffness, or None.
        n: the number of coordinates.
    """
    if K is None:
        return np.ones(n)
    k = np.abs(K.diagonal())
    stiff = k[k > 0.0]
    return np.sqrt(np.where(k > 0.0, k, np.median(stiff) if len(stiff) else 1.0))


def null_space_basis(Cq, K=None) -> sp.csc_matrix:
    """Sparse basis T (CSC, N x N - rank) of the null space of the constraint Jacobian C_q
    (nc x N), C_q T = 0, by elimination of dependent coordinates (module doc): only the
    columns with nonzeros take part; every other coordinate is independent. In the metric
    ``D = |diag K|^(1/2)`` (the identity without K; coordinates without stiffness, e.g. the
    frame of a free body, take the median of the others) y = D q, A = C_q D^-1 is brought
    to row-echelon form U row by row, each row's pivot its largest entry in the metric, so
    that the dependent coordinates are the ones whose motion costs least stiffness
    per unit of the constraint and the multipliers ``|U_d^-1 U_i|`` stay O(1); then
    T = D^-1 P [-U_d^-1 U_i; I]. A row whose remainder is at most 1e-10 of C_q's largest
    row norm (in C_q itself: in the metric a constraint on a stiff coordinate has entries
    of 1/sqrt(K_ii), ~1e-10 relative for the stiff hub, which a relative cutoff there would
    drop, freeing a motion the joint locks) is redundant (it repeats constraints already
    imposed). T is not orthonormal in any metric (eigenvalues do not depend on the basis;
    the module doc says why the metric's pivots keep the round-off small). Columns follow
    the independent coordinates' order. Cost: the elimination row by row and a back
    substitution into U_d^-1 U_i, rank x (touched - rank), dense: small for the joints of
    a coupled arm (12 x 12), ~N^2/4.5 for a chain of bodies, whose frames are each
    eliminated through the one before (a column per body upstream).

    Args:
        Cq: C_q [-] (nc x N, sparse or dense) the constraint Jacobian.
        K: K [N/m] (N x N, sparse) stiffness, whose diagonal sets the metric (optional).
    """
    Cq = sp.csr_matrix(Cq, dtype=float)
    Cq.eliminate_zeros()
    nc, n = Cq.shape
    d = metric(K, n)
    touched = np.flatnonzero(np.bincount(Cq.indices, minlength=n))
    if len(touched) == 0:
        return sp.diags(1.0 / d, format="csc")
    if not np.all(np.isfinite(Cq.data)):
        raise ValueError("Cq must be finite (the constraint Jacobian)")
    m = len(touched)
    local = np.zeros(n, dtype=np.int64)
    local[touched] = np.arange(m)
    A = sp.csr_matrix((Cq.data / d[Cq.indices], local[Cq.indices], Cq.indptr), shape=(nc, m))
    row_of = np.repeat(np.arange(nc), np.diff(Cq.indptr))
    tol = 1e-10 * np.sqrt(np.bincount(row_of, weights=Cq.data**2, minlength=nc).max())
    dep, R = _eliminate(A, d[touched], tol)
    # T: the independent coordinates (all but touched[dep]) in order, each a column 1/d
    # there, and -R / d on the dependent rows
    indep = np.ones(n, bool)
    indep[touched[dep]] = False
    col = np.cumsum(indep) - 1  # the column of each independent coordinate
    own = np.flatnonzero(indep)
    free = np.ones(m, bool)
    free[dep] = False
    k, j = np.nonzero(R)
    rows = np.concatenate([own, touched[dep][k]])
    cols = np.concatenate([col[own], col[touched[free][j]]])
    vals = np.concatenate([1.0 / d[own], -R[k, j] / d[touched[dep][k]]])
    return sp.csc_matrix((vals, (rows, cols)), shape=(n, len(own)))


def _eliminate(A: sp.csr_matrix, scale: np.ndarray, tol: float):
    """The dependent columns of A (nc x m, CSR, in the metric) and R = U_d^-1 U_i (rank x
    the other columns, dense), U the row-echelon form of A built row by row: each row less
    its components on the earlier pivot rows (in their order, so that no pivot comes
    back), pivoted on its largest entry and divided by it; a row whose remainder times
    ``scale`` (in C_q's units) has a 2-norm at most ``tol`` is redundant and left out. U_d
    is unit upper triangular with entries of at most 1 in step order: R by back
    substitution."""
    m = A.shape[1]
    step = np.full(m, -1)  # the step at which a column became a pivot
    w = np.zeros(m)  # the current row, dense over the touched columns (reset after each)
    dep, U_cols, U_vals = [], [], []
    for i in range(A.shape[0]):
        lo, hi = A.indptr[i], A.indptr[i + 1]
        supp = A.indices[lo:hi]
        w[supp] = A.data[lo:hi]
        while True:
            s = np.unique(supp)
            piv = s[(step[s] >= 0) & (w[s] != 0.0)]
            if len(piv) == 0:
                break
            j = piv[np.argmin(step[piv])]
            k = step[j]
            w[U_cols[k]] -= w[j] * U_vals[k]
            w[j] = 0.0  # exactly eliminated
            supp = np.concatenate([s, U_cols[k]])
        s = np.unique(supp)
        vals = w[s]
        w[s] = 0.0
        nz = vals != 0.0
        s, vals = s[nz], vals[nz]
        if len(s) == 0 or np.linalg.norm(vals * scale[s]) <= tol:
            continue  # redundant
        p = int(np.argmax(np.abs(vals)))
        step[s[p]] = len(dep)
        dep.append(s[p])
        U_cols.append(s)
        U_vals.append(vals / vals[p])
    r = len(dep)
    free = step < 0
    pos = np.cumsum(free) - 1  # the column of R of each independent column
    R = np.zeros((r, m - r))
    for k in range(r - 1, -1, -1):  # R_k = U_ik - sum over later pivots j of U_kj R_j
        cols, vals = U_cols[k], U_vals[k]
        own = free[cols]
        R[k, pos[cols[own]]] = vals[own]
        later = ~own & (cols != dep[k])
        if later.any():
            R[k] -= vals[later] @ R[step[cols[later]]]
    return np.array(dep, dtype=int), R


def reduce(T, *matrices):
    """T^T X T (CSC, sorted indices) of each X: products of sparse matrices, O(nnz).

    Args:
        T: T [-] (N x n) the null-space basis (sparse; a dense T is taken as sparse).
        matrices: X (N x N, sparse) M [kg], C [N s/m], K [N/m], ... to reduce.
    """
    T = sp.csc_matrix(T)
    Tt = T.T.tocsc()  # CSC @ CSC: no conversion of the product X T

    def reduced(X):
        R = Tt @ (sp.csc_matrix(X) @ T)
        R.sort_indices()
        return R
    return tuple(reduced(X) for X in matrices)


def linearization(cls, out: dict, mass_flow: float, state):
    """A ``cls`` (a :class:`ConstrainedLinearization`) from the core's ``linear_matrices``
    about ``state``: the matrices reduced to the constraints' null space, with the
    unreduced ones, whose absolute values bound the reduction's round-off."""
    K, C, M, Cq = from_core(out)
    T = null_space_basis(Cq, K)
    Mr, Cr, Kr = reduce(T, M, C, K)
    return cls(Mr, Cr, stiffness_floor(Kr, T, metric(K, K.shape[0])), mass_flow, state, T, (M, C, K))


def stiffness_floor(Kr, T, d) -> sp.csc_matrix:
    """The reduced stiffness with the entries at most eps sqrt(s_i s_j) set to zero, s =
    diag(T^T D^2 T) the stiffness that the metric gives each column (~1: a column of T is
    1/d at its own coordinate). Such an entry is round-off of the core's assembly (a free
    body frame's stiffness, ~1e-37 N/m against 1e6), below what the metric resolves; left
    in, it makes a free motion that the basis puts in one column look stiff after a
    diagonal scaling (:func:`pipeflex.stability`'s mechanism rule): zero, the free motion
    is a zero column.

    Args:
        Kr: T^T K T [N/m] (n x n, sparse) the reduced stiffness (not modified).
        T: T [-] (N x n) the basis it was reduced with.
        d: d [sqrt(N/m)] (N) the metric (:func:`metric`).
    """
    T = sp.csc_matrix(T)
    s = np.asarray(T.multiply(T).T @ (d * d)).ravel()
    Kr = Kr.tocsc(copy=True)
    col = np.repeat(np.arange(Kr.shape[1]), np.diff(Kr.indptr))
    Kr.data[np.abs(Kr.data) <= np.finfo(float).eps * np.sqrt(s[Kr.indices] * s[col])] = 0.0
    Kr.eliminate_zeros()
    return Kr


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
    y, al = abs(lin.basis) @ np.abs(X), np.abs(lam)  # (a sparse or a dense T)
    num = np.sum(y * (al**2 * (Ma @ y) + al * (Ca @ y) + Ka @ y), axis=0)
    den = np.abs(np.sum(X.conj() * (2 * lam * (lin.M @ X) + lin.C @ X), axis=0))
    return lin.basis.shape[0] * np.finfo(float).eps * num / np.maximum(den, 1e-300)
