"""Eigenvalues of the quadratic problem (lambda^2 M + lambda C + K) x = 0 and stability.

Dense, exact method: the reduced coordinates are split into the independent blocks of
the linearised system (a straight pipe's two bending planes, its axial and torsional
motion decouple), and each block is solved in inverted companion form
    mu^2 K x + mu C x + M x = 0,   mu = 1/lambda,
which keeps the low (physically relevant) eigenvalues accurate and tolerates a singular
mass matrix (massless coordinates give mu = 0, i.e. infinite lambda, and are dropped).

Sparse method for a few eigenvalues of a large model (``eigenvalues(lin, n_modes=k)``):
each block is solved by shift-invert Arnoldi (ARPACK) on the first-order form of the
quadratic in mu = lambda - sigma, T(sigma) + mu T'(sigma) + mu^2 M, with the state
z = [x; mu x / tau]; its operator maps [f; g] to [y; f / tau], T(sigma) y = -(T'(sigma) f
+ tau M g), with eigenvalues nu = 1/(lambda - sigma), largest for the lambda nearest
sigma. Applying it needs one sparse LU of the n x n quadratic T(sigma) = sigma^2 M +
sigma C + K, so only T(sigma) must be regular: a singular M (massless coordinates) gives
nu = 0, which Arnoldi never returns, and needs neither condensation nor QZ. The scale
tau ~ |mu_k| (the k-th wanted distance, from a short Arnoldi run) keeps the operator's
unwanted part below the wanted nu (see :func:`_velocity_scale`; with tau = 1 ARPACK
stalled on ~40 eigenvalues of a fine beam). In an undamped conservative block (K, M
symmetric, C skew) the eigenvalues on the imaginary axis are then taken from the
Rayleigh functional of their vectors (:func:`_rayleigh_on_axis`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import List, Optional

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.sparse.csgraph import breadth_first_order, connected_components

from .. import _checks
from ..results import Result
from .._blas import pin as pin_blas, pinned as blas_pinned

#: An eigenvalue counts as growing when Re(lambda) exceeds GROWTH_TOL * |lambda| and
#: its round-off bound (see :func:`block_eigenvalues`).
GROWTH_TOL = 1e-9

#: ``method="auto"`` takes the sparse path when a few modes are asked for (``n_modes``)
#: and the model has at least this many reduced coordinates: the break-even of the
#: cantilever pipe (8 of its eigenvalues, one BLAS thread: 32 elements, 192 coordinates,
#: 5.3 ms dense against 6.4 ms sparse; 48 elements 12 against 8.5 ms; 128 elements 125
#: against 10 ms), above which the dense cost grows like N^3.
SPARSE_MIN_DOFS = 240


@dataclass(frozen=True)
class Block(Result):
    """One decoupled block: its reduced coordinates ``dofs`` and dense ``K``, ``C``, ``M``
    (CSC sparse from ``split_blocks(..., sparse=True)``, the sparse path; units as in
    :class:`~pipeflex.analysis.Linearization`)."""

    dofs: np.ndarray
    K: np.ndarray
    C: np.ndarray
    M: np.ndarray


@dataclass(frozen=True)
class EigenResult(Result):
    """Finite eigenvalues lambda [1/s] (complex; Im = angular frequency [rad/s]).

    Attributes:
        values: lambda [1/s] eigenvalues sorted by abs(Im) then Re.
        vectors: (n_dofs, k) complex mode shapes (columns) if requested, else None.
        block_of: index of the block each eigenvalue belongs to.
        static_negative: number of negative stiffness eigenvalues in massless blocks.
        noise: round-off bound on each eigenvalue [1/s].
        blocks: the decoupled blocks (:class:`Block`) the eigenvalues were found in.
        dof_labels: (node, component) of each reduced coordinate (the model's, from the
            :class:`~pipeflex.analysis.Linearization`; None if it has none), to name
            the free coordinates of a mechanism.
    """

    values: np.ndarray
    noise: np.ndarray = None
    vectors: np.ndarray = None
    block_of: np.ndarray = None
    static_negative: int = 0
    blocks: List[Block] = field(default_factory=list, repr=False)
    dof_labels: Optional[tuple] = field(default=None, repr=False)

    @property
    def frequencies(self) -> np.ndarray:
        """Angular frequencies abs(Im lambda) [rad/s] of the eigenvalues with Im >= 0."""
        return np.abs(self.values[self.values.imag >= 0].imag)

    def growth(self) -> float:
        """Largest Re(lambda) [1/s]."""
        return float(np.max(self.values.real)) if len(self.values) else -np.inf


def split_blocks(K, C, M, *, tol: float = 1e-13, sparse: bool = False) -> List[Block]:
    """Decompose the coordinates into the connected components of the coupling pattern.

    An entry X_ij couples i and j unless |X_ij| <= tol sqrt(|X_ii X_jj|) (or, with a zero
    diagonal, tol max|X|): a scale-invariant test that only drops round-off.
    With ``sparse=True`` the blocks hold CSC matrices (without the dropped entries).
    """
    n = K.shape[0]
    entries = []  # (pattern, values) of K, C, M; linearize's three share one pattern
    for X in (K, C, M):
        if not (sp.issparse(X) and X.format == "csc" and X.has_canonical_format):  # (linearize's are)
            X = sp.csc_matrix(X)
            if not X.has_canonical_format:
                X = X.copy()
                X.sum_duplicates()
        pattern = next((p for p, _ in entries if p.matches(X)), None) or _CscPattern.of(X)
        entries.append((pattern, X.data))
    kept = {}  # per pattern: the entries that couple in any of the matrices
    for pattern, data in entries:
        if len(data) == 0:
            continue
        d = np.zeros(n)
        d[pattern.row[pattern.diagonal]] = np.abs(data[pattern.diagonal])
        ref = np.sqrt(d[pattern.row] * d[pattern.col])
        ref[ref == 0.0] = np.max(np.abs(data))
        keep = np.abs(data) > tol * ref
        kept[pattern] = kept[pattern] | keep if pattern in kept else keep
    ncomp, labels = _components(n, kept)
    return [Block(dofs, *mats) for dofs, mats in _split_entries(entries, ncomp, labels, sparse)]


def _components(n, kept):
    """The connected components (count, label per coordinate) of the coupling graph of the
    entries ``kept`` (pattern -> mask), the last result again for the same entries."""
    global _partition
    last = _partition  # one read: another thread may replace it (a sweep's threads)
    if (last is not None and last[0] == n and len(last[1]) == len(kept)
            and all(p is q and np.array_equal(k, l) for (p, k), (q, l) in zip(kept.items(), last[1]))):
        return last[2]
    r = np.concatenate([np.arange(n)] + [p.row[keep] for p, keep in kept.items()])
    c = np.concatenate([np.arange(n)] + [p.col[keep] for p, keep in kept.items()])
    coupling = sp.csr_matrix((np.ones(len(r), bool), (r, c)), shape=(n, n))
    result = connected_components(coupling, directed=False)
    _partition = n, list(kept.items()), result
    return result


_partition = None  # the last (n, entries kept, components) of _components


class _CscPattern:
    """Row and column of each entry of a canonical CSC matrix, and which are diagonal."""

    @classmethod
    def of(cls, X):
        """The pattern of X: the last one made again if X has its arrays (a scan's repeated
        linearisations: one pattern)."""
        global _last_pattern
        last = _last_pattern  # one read: another thread may replace it
        if last is None or not last.matches(X):
            last = _last_pattern = cls(X)
        return last

    def __init__(self, X):
        self.indptr, self.indices = X.indptr, X.indices
        self.row = X.indices
        self.col = np.repeat(np.arange(X.shape[1]), np.diff(X.indptr))
        self.diagonal = np.flatnonzero(self.row == self.col)

    def matches(self, X):
        return np.array_equal(X.indptr, self.indptr) and np.array_equal(X.indices, self.indices)


class _BlockLayout:
    """Where the entries of a CSC pattern go in the blocks of a partition ``labels``: each
    block's entries in CSC order (a stable sort by block keeps it), coordinates renumbered
    increasingly inside the block, so they form its CSC arrays as they are. Cross-block
    entries (round-off) are left out."""

    def __init__(self, pattern, ncomp, labels):
        self.pattern, self.labels = pattern, labels
        self.dofs = [np.flatnonzero(labels == c) for c in range(ncomp)]
        local = np.empty(len(labels), np.int64)
        for dofs in self.dofs:
            local[dofs] = np.arange(len(dofs))
        owner = labels[pattern.col]
        order = np.flatnonzero(labels[pattern.row] == owner)
        order = order[np.argsort(owner[order], kind="stable")]
        bounds = np.searchsorted(owner[order], np.arange(ncomp + 1))
        self.parts = []  # per block: (entries taken, CSC indices, CSC indptr, column of each entry)
        for c, dofs in enumerate(self.dofs):
            sel = order[bounds[c]:bounds[c + 1]]
            cols = local[pattern.col[sel]]
            counts = np.bincount(cols, minlength=len(dofs))
            indptr = np.concatenate([[0], np.cumsum(counts)]).astype(np.int32)
            self.parts.append((sel, local[pattern.row[sel]].astype(np.int32), indptr, cols))

    def matches(self, pattern, labels):
        return (pattern is self.pattern or pattern.matches(self.pattern)) and np.array_equal(labels, self.labels)

    def blocks(self, data, sparse=True):
        """The block matrices of the values ``data``: CSC (explicit zeros dropped) or dense."""
        out = []
        for (sel, indices, indptr, cols), dofs in zip(self.parts, self.dofs):
            if not sparse:  # (a small model's: no sparse matrix to build and check)
                Y = np.zeros((len(dofs), len(dofs)), data.dtype)
                Y[indices, cols] = data[sel]
                out.append(Y)
                continue
            Y = sp.csc_matrix((data[sel], indices.copy(), indptr.copy()), shape=(len(dofs), len(dofs)))
            Y.has_canonical_format = True
            Y.eliminate_zeros()
            out.append(Y)
        return out


_layout = None  # the last block layout: the repeated splits of an analysis reuse it
_last_pattern = None  # the last _CscPattern.of


def _split_entries(entries, ncomp, labels, sparse):
    """[(dofs, [K, C, M] of the block)] for the partition ``labels`` (CSC or dense blocks)."""
    global _layout
    layouts = {}  # per pattern of this call
    for pattern, _ in entries:
        if pattern not in layouts:
            layout = _layout
            if layout is None or not layout.matches(pattern, labels):
                layout = _BlockLayout(pattern, ncomp, labels)
            layouts[pattern] = _layout = layout
    mats = [layouts[pattern].blocks(data, sparse) for pattern, data in entries]
    dofs_of = next(iter(layouts.values())).dofs  # one partition: every layout's is the same
    return [(dofs, [m[c] for m in mats]) for c, dofs in enumerate(dofs_of)]


_similar_signs = {}  # (dofs of a, of b) -> the signs d last found: the repeated analyses of a scan reuse them


def _sign_similarity_sparse(a: Block, b: Block):
    """:func:`_sign_similarity` for sparse blocks."""
    if len(a.dofs) != len(b.dofs):
        return None
    pairs = [(a.K, b.K), (a.C, b.C), (a.M, b.M)]
    for x, y in pairs:
        if x.nnz != y.nnz or not (np.array_equal(x.indptr, y.indptr) and np.array_equal(x.indices, y.indices)):
            return None
        if not np.allclose(np.abs(x.data), np.abs(y.data), rtol=1e-14, atol=0.0):
            return None
    key = (a.dofs.tobytes(), b.dofs.tobytes())
    d = _similar_signs.get(key)
    if d is None or not _signs_map(d, pairs):
        d = _find_signs(a, pairs)
        if d is None:
            return None
        _remember_signs(key, d)
    return d


def _remember_signs(key, d) -> None:
    """Keep the signs d of the pair ``key`` for the next analysis (at most 16 pairs)."""
    if len(_similar_signs) >= 16:
        _similar_signs.clear()
    _similar_signs[key] = d


def _signs_map(d, pairs) -> bool:
    """y = D x D for each (x, y) of ``pairs`` (sparse, one pattern), D = diag(d)."""
    for x, y in pairs:  # (D x D)_ij = d_i x_ij d_j on x's pattern, which is y's
        cols = np.repeat(np.arange(x.shape[1]), np.diff(x.indptr))
        if not np.allclose(d[x.indices] * x.data * d[cols], y.data, rtol=1e-14, atol=0.0):
            return False
    return True


def _find_signs(a: Block, pairs):
    """The signs d of :func:`_sign_similarity_sparse` (None if there are none): the signs
    of the entries met along a spanning tree of the coupling, checked on all entries."""
    n = len(a.dofs)
    links = (abs(a.K) + abs(a.C) + abs(a.M)).tocsr()
    order, pred = breadth_first_order(links, 0, directed=False, return_predecessors=True)
    if len(order) != n:
        return None
    child = order[1:]
    parent = pred[child]
    sgn = np.zeros(len(child))
    for x, y in pairs:  # sign(x_ij) sign(y_ij) of the first matrix coupling i and j
        # x_ij at (parent, child) from the CSC arrays (column child; rows sorted: canonical)
        lo_, hi_ = x.indptr[child], x.indptr[child + 1]
        key = x.indices.astype(np.int64) + np.repeat(np.arange(n, dtype=np.int64), np.diff(x.indptr)) * n
        pos = np.minimum(np.searchsorted(key, child.astype(np.int64) * n + parent), max(len(key) - 1, 0))
        hit = (pos >= lo_) & (pos < hi_) & (x.indices[pos] == parent) if len(key) else np.zeros(len(child), bool)
        xv = np.where(hit, x.data[pos] if len(key) else 0.0, 0.0)
        yv = np.where(hit, y.data[pos] if len(key) else 0.0, 0.0)  # the same pattern
        todo = (sgn == 0.0) & (xv != 0.0)
        sgn[todo] = np.sign(xv[todo]) * np.sign(yv[todo])
    if np.any(sgn == 0.0):
        return None
    d = np.zeros(n)
    d[0] = 1.0
    for j, i, s_ in zip(child, parent, sgn):
        d[j] = d[i] * s_
    return d if _signs_map(d, pairs) else None


def _sign_similarity(a: Block, b: Block):
    """Signs d (+-1) with b.X = D a.X D for X = K, C, M, or None.

    The two bending planes of a straight pipe are such a pair (their rotation coordinates
    differ in sign); they then share eigenvalues and, up to D, eigenvectors.
    """
    if len(a.dofs) != len(b.dofs):
        return None
    pairs = [(a.K, b.K), (a.C, b.C), (a.M, b.M)]
    # The signs of the same blocks' last pair, if they still map a to b (this test implies
    # the next on |X|): they are unique (a is connected), so the search below finds them.
    key = (a.dofs.tobytes(), b.dofs.tobytes())
    d = _similar_signs.get(key)
    if d is not None and _dense_signs_map(d, pairs):
        return d
    for x, y in pairs:
        if not np.allclose(np.abs(x), np.abs(y), rtol=1e-14, atol=0.0):
            return None
    n = len(a.dofs)
    d = np.zeros(n)
    d[0] = 1.0
    stack = [0]
    links = np.abs(a.K) + np.abs(a.C) + np.abs(a.M)
    while stack:
        i = stack.pop()
        for j in np.nonzero(links[i])[0]:
            if d[j] != 0.0:
                continue
            x, y = next((x[i, j], y[i, j]) for x, y in pairs if x[i, j] != 0.0)
            d[j] = d[i] * np.sign(x) * np.sign(y)
            stack.append(j)
    if np.any(d == 0.0) or not _dense_signs_map(d, pairs):
        return None
    _remember_signs(key, d)
    return d


def _dense_signs_map(d, pairs) -> bool:
    """y = D x D for each (x, y) of ``pairs`` (dense), D = diag(d)."""
    D = np.outer(d, d)
    for x, y in pairs:
        z = D * x
        # (a straight pipe's two bending planes are equal to the bit: the cheaper test first)
        if not (np.array_equal(z, y) or np.allclose(z, y, rtol=1e-14, atol=0.0)):
            return False
    return True


def block_eigenvalues(b: Block, *, vectors: bool = False):
    """Finite eigenvalues, their round-off bounds and (top-half) eigenvectors of one block.

    Coordinates without mass (the null space of M, e.g. the torsion of a pipe without
    rotary inertia) carry no dynamics: when C does not act on them they are condensed
    out exactly (Schur complement of K), which avoids the defective mu = 0 pairs they
    would otherwise add; else the generalised (QZ) eigen-problem is solved.
    Returns ``(lam, noise, V, negative)`` with ``negative`` the number of negative
    stiffness eigenvalues of the condensed coordinates.
    """
    n = len(b.dofs)
    K, C, M = b.K, b.C, b.M
    if not np.any(M) and not np.any(C):
        return np.zeros(0, complex), np.zeros(0), np.zeros((n, 0), complex), _negative(K)
    if _regular(M):
        lam, noise, V = _companion(K, C, M, vectors)
        return lam, noise, V, 0
    w, Q = np.linalg.eigh(0.5 * (M + M.T))
    zero = w <= 1e-12 * w.max()
    Q0, Qm = Q[:, zero], Q[:, ~zero]
    c_scale = max(np.abs(C).max(), 1e-300)
    # Does C act on the massless coordinates? The null space Q0 is only known to about
    # eps |M| / w_gap (w_gap: the smallest nonzero mass eigenvalue; Davis-Kahan), and
    # so is C's coupling to it: below that it is round-off (e.g. ~1e-12 on a deformed
    # U-tube without rotary inertia), and QZ on such a pencil returned infinite
    # eigenvalues as finite ones (lambda ~ 1e11: a spurious divergence).
    w_gap = w[~zero].min() if np.any(~zero) else w.max()
    coupling_tol = min(1e-8, max(1e-12, 10 * np.finfo(float).eps * w.max() / w_gap))
    if np.abs(Q0.T @ C).max() > coupling_tol * c_scale or np.abs(C @ Q0).max() > coupling_tol * c_scale:
        lam, noise, V = _generalized(K, C, M, vectors)
        return lam, noise, V, 0
    K00 = Q0.T @ K @ Q0
    try:
        S = np.linalg.solve(K00, Q0.T @ K @ Qm)
    except np.linalg.LinAlgError:
        raise ValueError("the coordinates without inertia (a singular mass matrix) have a singular stiffness "
                         "too: they form a mechanism of their own; give them inertia (e.g. rotary_inertia) or "
                         "support them") from None
    Kc = Qm.T @ K @ Qm - (Qm.T @ K @ Q0) @ S
    lam, noise, Y = _companion(Kc, Qm.T @ C @ Qm, np.diag(w[~zero]), vectors)
    V = (Qm - Q0 @ S) @ Y if vectors else None
    return lam, noise, V, _negative(K00)


def _regular(M) -> bool:
    """Cheap test (Cholesky) that a mass matrix is positive definite and well conditioned."""
    try:
        L = np.linalg.cholesky(M)
    except np.linalg.LinAlgError:
        return False
    d = np.diag(L) ** 2
    return bool(d.min() > 1e-12 * np.abs(M).max())


def _negative(K) -> int:
    ev = np.linalg.eigvals(K).real
    return int(np.sum(ev < -1e-12 * max(1e-300, np.abs(ev).max())))


def _companion(K, C, M, vectors):
    """Inverted companion form mu^2 K x + mu C x + M x = 0 (M regular), lambda = 1/mu.

    Backward-stable eigensolvers perturb mu by about eps ||A||; mapped to lambda = 1/mu
    that is eps ||A|| |lambda|^2, large for the high modes when K is nearly singular.
    An undamped block whose K is symmetric to round-off goes to :func:`_undamped`.
    """
    if not np.any(C) and _nearly_symmetric(K) and _nearly_symmetric(M):
        return _undamped(K, M, vectors)
    n = K.shape[0]
    scale_k = np.max(np.abs(K)) if np.any(K) else 1.0
    scale_m = np.max(np.abs(M))
    sigma = 0.0
    lu = sla.lu_factor(K, check_finite=False)
    u = np.abs(np.diag(lu[0]))
    if u.min() <= 1e-12 * u.max():
        # Singular stiffness (rigid-body motion or exactly critical): shift lambda.
        sigma = 1e-2 * np.sqrt(scale_k / scale_m)
        K, C = K + sigma * C + sigma**2 * M, C + 2 * sigma * M
        lu = sla.lu_factor(K, check_finite=False)
    X = sla.lu_solve(lu, M, check_finite=False)
    Y = sla.lu_solve(lu, C, check_finite=False)
    A = np.zeros((2 * n, 2 * n), np.result_type(X, Y))  # [[0, I], [-X, -Y]]
    A[:n, n:] = np.eye(n)
    np.negative(X, out=A[n:, :n])
    np.negative(Y, out=A[n:, n:])
    if vectors:
        mu, V = np.linalg.eig(A)
    else:
        mu, V = np.linalg.eigvals(A), None
    big = np.max(np.abs(mu)) if len(mu) else 0.0
    finite = np.abs(mu) > 1e-10 * big
    lam = sigma + 1.0 / mu[finite]
    noise = 1e3 * np.finfo(float).eps * np.linalg.norm(A, 1) * np.abs(lam - sigma) ** 2
    return lam, noise, (V[:n, finite] if vectors else None)


def _nearly_symmetric(X, rtol: float = 1e-9) -> bool:
    return bool(np.abs(X - X.T).max() <= rtol * np.abs(X).max())


def _undamped(K, M, vectors):
    """lambda^2 M x + K x = 0 with M positive definite and K symmetric but for a skew part
    E of at most 1e-9 |K| (e.g. dead moments linearised at the reference): the symmetric
    part's generalised eigenvalues w = omega^2 (eigh), lambda = +-i omega (w > 0) or
    +-sqrt(-w) (w < 0: divergence). A skew E moves a simple eigenvalue only to second
    order (x^T E x = 0 for the real vectors), so this is exact to O(|E|^2); the companion
    form instead gives the high modes of an ill-conditioned mass round-off real parts
    ~eps ||A|| |lambda|^2 that can pass for growth (a conservative model called
    flutter, found by the fuzz run)."""
    n = K.shape[0]
    Ks, Ms = 0.5 * (K + K.T), 0.5 * (M + M.T)
    w, X = sla.eigh(Ks, Ms, check_finite=False)
    # the Rayleigh quotients: eigh's w carry eps ||M^-1 K|| absolute, too much for the low
    # modes of a stiff structure; the quotient's error is quadratic in the vector's
    w = np.sum(X * (Ks @ X), axis=0) / np.sum(X * (Ms @ X), axis=0)
    root = np.sqrt(np.abs(w))
    lam = np.concatenate([np.where(w >= 0, 1j * root, root), np.where(w >= 0, -1j * root, -root)])
    # round-off of w: eps (|K| + |w| |M|) |x|^2 / x^T M x (x M-normalised by eigh)
    nk, nm = np.linalg.norm(K, 1), np.linalg.norm(M, 1)
    dw = np.finfo(float).eps * (nk + np.abs(w) * nm) * np.sum(X**2, axis=0) * np.sqrt(n)
    dw = dw + np.abs(K - K.T).max() ** 2 / max(np.abs(K).max(), 1e-300)  # the skew part's second order
    dlam = dw / np.maximum(2.0 * root, np.sqrt(dw))
    noise = np.concatenate([dlam, dlam])
    V = np.concatenate([X, X], axis=1).astype(complex) if vectors else None
    return lam, noise, V


def _generalized(K, C, M, vectors):
    """QZ on the companion pencil [[0, I], [-K, -C]] - lambda [[I, 0], [0, M]]."""
    n = K.shape[0]
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-K, -C]])
    B = np.block([[np.eye(n), np.zeros((n, n))], [np.zeros((n, n)), M]])
    if vectors:
        ab, V = sla.eig(A, B, homogeneous_eigvals=True)
    else:
        ab, V = sla.eig(A, B, right=False, homogeneous_eigvals=True), None
    alpha, beta = ab
    finite = np.abs(beta) > 1e-12 * np.abs(alpha)
    lam = alpha[finite] / beta[finite]
    noise = 1e3 * np.finfo(float).eps * (np.linalg.norm(A, 1) + np.linalg.norm(B, 1) * np.abs(lam))
    return lam, noise, (V[:n, finite] if vectors else None)


@blas_pinned
def eigenvalues(lin, *, vectors: bool = False, n_modes: Optional[int] = None,
                sigma: Optional[complex] = None, method: str = "auto") -> EigenResult:
    """Finite eigenvalues lambda [1/s] of a :class:`~pipeflex.analysis.Linearization`.

    By default all of them (dense method). With ``n_modes=k`` only the k eigenvalues
    nearest ``sigma`` (ties, i.e. complex-conjugate pairs and the repeated eigenvalues of
    symmetric bending planes, are kept together, so a few more may be returned).

    Args:
        lin: the linearisation (M, C, K).
        vectors: also return mode shapes (complex, reduced coordinates).
        n_modes: k, the number of eigenvalues wanted (default: all, dense).
        sigma: lambda [1/s] (complex) target of ``n_modes``; default 0, i.e. the lowest
            frequencies (shifted internally by a tiny amount if the quadratic
            T(0) = K is singular, e.g. rigid-body motion).
        method: "dense", "sparse" (shift-invert Arnoldi, only with ``n_modes``) or
            "auto": sparse when ``n_modes`` is given and the model has at least
            :data:`SPARSE_MIN_DOFS` coordinates, else dense.

    The sparse method's ``static_negative`` counts negative stiffness eigenvalues of the
    massless blocks by the inertia of a symmetric sparse LU; its ``noise`` is the larger
    of the round-off bound of each eigenvalue (:func:`eigen_noise`, ~N^4 eps for a beam
    of N elements) and its first-order error estimate from the residual. A constrained
    linearisation (bodies, coupled systems) adds the round-off of its reduction to the
    null space (:func:`with_reduction_noise`).
    """
    if not all(hasattr(lin, name) for name in ("K", "C", "M")):
        raise TypeError(f"lin must be a Linearization (pipeflex.linearize(model, state)), got {type(lin).__name__}")
    if method not in ("auto", "dense", "sparse"):
        raise ValueError(f"method must be 'auto', 'dense' or 'sparse', not {method!r}")
    if n_modes is not None:
        n_modes = _checks.positive_int("n_modes", n_modes)
    elif sigma is not None or method == "sparse":
        raise ValueError("sigma and method='sparse' need n_modes (the number of eigenvalues near sigma)")
    n = lin.K.shape[0]
    labels = getattr(lin, "dof_labels", None)

    def solve(want_vectors):
        if method == "sparse" or (method == "auto" and n_modes is not None and n >= SPARSE_MIN_DOFS):
            blocks = split_blocks(lin.K, lin.C, lin.M, sparse=True)
            return sparse_eigen_from_blocks(blocks, n, n_modes, sigma=sigma, vectors=want_vectors)
        blocks = split_blocks(lin.K, lin.C, lin.M)
        eig = eigen_from_blocks(blocks, n, vectors=want_vectors)
        if n_modes is not None:
            eig = _select(eig, n_modes, 0.0 if sigma is None else complex(sigma))
        return eig

    eig = with_reduction_noise(solve(vectors), lin, lambda: solve(True))
    return replace(eig, dof_labels=labels, vectors=eig.vectors if vectors else None)


def with_reduction_noise(eig: EigenResult, lin, solve_with_vectors) -> EigenResult:
    """``eig`` with the round-off that a constrained linearisation's reduction adds
    (:func:`pipeflex.analysis.constrained.reduction_noise`) joined to its ``noise`` (the
    larger of the two), so that :func:`classify` (:func:`stability`,
    :func:`~pipeflex.critical_mass_flow`) counts a growth below it as zero: one bound,
    one test. It is joined where it can change that decision, to the eigenvalues that
    grow beyond the eigen-solver's own bound (:func:`_growing`); it needs their vectors,
    so without them ``solve_with_vectors()`` computes ``eig`` again with vectors (only
    then: at a stable point of a critical-flow scan nothing is recomputed). An element
    model's linearisation leaves ``eig`` unchanged."""
    if getattr(lin, "unreduced", None) is None:
        return eig
    suspects = _growing(eig)
    if not suspects.any():
        return eig
    if eig.vectors is None:
        eig = solve_with_vectors()
        suspects = _growing(eig)
        if not suspects.any():
            return eig
    noise = eig.noise.copy()
    noise[suspects] = np.maximum(noise[suspects],
                                 lin.reduction_noise(eig.values[suspects], eig.vectors[:, suspects]))
    return replace(eig, noise=noise)


def _select(eig: EigenResult, k: int, sigma: complex) -> EigenResult:
    """The k eigenvalues of ``eig`` nearest sigma (with their ties), in ``eig``'s order."""
    keep = _nearest(eig.values, k, sigma)
    V = None if eig.vectors is None else eig.vectors[:, keep]
    return EigenResult(eig.values[keep], eig.noise[keep], V, eig.block_of[keep], eig.static_negative, eig.blocks)


def _nearest(values, k, sigma) -> np.ndarray:
    """Mask of the k values nearest sigma, and of those tied with the k-th (1e-10 relative)."""
    if len(values) <= k:
        return np.ones(len(values), bool)
    dist = np.abs(values - sigma)
    cut = np.sort(dist)[k - 1]
    return dist <= cut * (1 + 1e-10) + 1e-300


def one_norms(K, C, M) -> list:
    """The 1-norms of K, C, M (sparse or dense), as :func:`eigen_noise` reads them."""
    return [_sparse_norm1(X) if sp.issparse(X) else np.linalg.norm(X, 1) for X in (K, C, M)]


def _sparse_norm1(X) -> float:
    """max_j sum_i |X_ij| of a sparse X, from its CSC arrays (scipy's norm builds |X| and
    sums it as a matrix: ~1 ms on a 2048-coordinate block, called per eigen-solve)."""
    X = X if X.format == "csc" else sp.csc_matrix(X)
    if X.nnz == 0:
        return 0.0
    cols = np.repeat(np.arange(X.shape[1]), np.diff(X.indptr))
    return float(np.bincount(cols, weights=np.abs(X.data), minlength=X.shape[1]).max())


def eigen_noise(K, C, M, lam, x, *, compensated: bool = False, norms=None) -> np.ndarray:
    """Round-off level [1/s] of eigenvalues lam of the quadratic with right vectors x (columns).

    First-order perturbation: rounding the terms of T(lam) x = (lam^2 M + lam C + K) x
    componentwise moves lam by about y^H E x / y^H T'(lam) x. With |E| ~ eps (|lam|^2 |M|
    + |lam| |C| + |K|) and independent signs this is eps kappa |lam| / sqrt(n),
        kappa = (|lam|^2 |M| + |lam| |C| + |K|) |x|^2 / (|lam| |x^H T'(lam) x|)
    (1-norms; x stands in for the left vector y), the eigenvalue's condition number. For
    a beam of N elements kappa ~ (omega_max / omega)^2 grows like N^4: the lowest modes
    of a 128-element beam are good to ~1e-9 relative, of a 1024-element one to ~1e-5.
    That is the measured size of the scatter, no worst case: the cantilever's crossing
    eigenvalue refined in double from perturbed starts and from permuted and rescaled
    copies of its block scatters by 0.3 to 2.1 times it at 64 to 8192 elements; the
    componentwise worst case (signs aligned, Higham's bound) is 1.1 to 13 times larger
    still (docs/performance.md, "Critical flow at 8192 elements").

    ``compensated``: K x summed in twice the working precision
    (:meth:`QuadraticPencil.residual`, as :func:`~pipeflex.analysis.critical.refine_eigenpair`
    does on sparse blocks): its round-off is eps^2 |K| instead of eps |K|, and the level
    falls to that of the mass and damping terms.

    ``norms``: :func:`one_norms` of K, C, M, where the caller has them already.
    """
    eps = np.finfo(float).eps
    nm = list(one_norms(K, C, M) if norms is None else norms)
    if compensated:
        nm[0] *= eps
    lam = np.atleast_1d(np.asarray(lam, complex))
    x = np.asarray(x, complex).reshape(K.shape[0], -1)
    d = np.abs(np.sum(x.conj() * (2 * lam * (M @ x) + C @ x), axis=0))
    scale = (np.abs(lam) ** 2 * nm[2] + np.abs(lam) * nm[1] + nm[0]) * np.sum(np.abs(x) ** 2, axis=0)
    return eps * scale / np.maximum(d, 1e-300) / np.sqrt(K.shape[0])


def _sparse_negative(K) -> int:
    """Negative eigenvalues of a symmetric sparse K (Sylvester's inertia of an LU with
    symmetric pivoting); dense for an unsymmetric K."""
    K = sp.csc_matrix(K)
    n = K.shape[0]
    asym = abs(K - K.T).max() if K.nnz else 0.0
    if K.nnz and asym <= 1e-12 * abs(K).max():
        try:
            lu = spla.splu(K, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                           options=dict(SymmetricMode=True))
            if np.array_equal(lu.perm_r, lu.perm_c):
                return int(np.sum(lu.U.diagonal() < 0))
        except RuntimeError:
            pass
    if n > 4000:
        raise NotImplementedError("the sign count of a large unsymmetric massless block")
    return _negative(K.toarray())


def sparse_block_eigenvalues(b: Block, k: int, sigma: complex, *, vectors: bool = False, guess=None,
                             scale: Optional[float] = None):
    """The (about) k eigenvalues nearest sigma of one sparse block, by shift-invert Arnoldi.

    Returns ``(lam, noise, V, negative)`` as :func:`block_eigenvalues`. Small blocks are
    solved densely. ``guess`` = (lambda, x): an eigenpair near the one sought (e.g. at a
    neighbouring flow) starts the Krylov space at its state vector [x, lambda x], which
    cuts the Arnoldi iterations when following an eigenvalue. ``scale``: the velocity
    scale tau [1/s] of the state (:func:`_velocity_scale`), e.g. the largest
    |lambda - sigma| of this block's solution at a neighbouring flow; default: estimated
    by a short Arnoldi run.
    """
    n = len(b.dofs)
    K, C, M = (sp.csc_matrix(X) for X in (b.K, b.C, b.M))
    if M.nnz == 0 and C.nnz == 0:
        return np.zeros(0, complex), np.zeros(0), np.zeros((n, 0), complex), _sparse_negative(K)
    if 2 * n <= max(4 * k + 8, 64):
        dense = Block(b.dofs, K.toarray(), C.toarray(), M.toarray())
        lam, noise, V, neg = block_eigenvalues(dense, vectors=True)
        keep = _nearest(lam, k, sigma)
        return lam[keep], noise[keep], V[:, keep], neg
    sigma = complex(sigma)
    T, lu = _shift_factor(QuadraticPencil(K, C, M), sigma)
    real = sigma.imag == 0.0
    s = sigma.real if real else sigma
    dtype = float if real else complex
    Cs = C + 2 * s * M  # T'(sigma): the damping of the quadratic in mu = lambda - sigma

    def operator(tau):
        # shift-invert of the first-order form on the state [x; mu x / tau]: [f; g] -> [y; f / tau]
        # with T(sigma) y = -(T'(sigma) f + tau M g), [T'(sigma), tau M] one matrix: one product
        A = sp.hstack([Cs, tau * M], format="csr")

        def op(v):
            v = np.asarray(v).ravel()
            y = -lu.solve(np.asarray(A @ v, dtype=dtype))
            return np.concatenate([y, v[:n] / tau])
        return op

    rng = np.random.default_rng(0)
    v0 = rng.standard_normal(2 * n)
    if not real:
        v0 = v0 + 1j * rng.standard_normal(2 * n)
    kk = min(k + 2, 2 * n - 2)
    if scale is not None and scale > 0.0:
        tau = float(scale)
    else:
        tau = _velocity_scale(operator(1.0), v0, kk)
    ops = _Operator(operator(tau), 2 * n, dtype)
    if guess is not None:
        lam_g, x_g = guess
        z = np.concatenate([x_g, (lam_g - sigma) * x_g / tau])
        # a little of the random start keeps the other wanted eigenvectors reachable
        v0 = (z if not real else z.real) / np.linalg.norm(z) + 1e-3 * v0 / np.linalg.norm(v0)
    ncv = max(2 * kk + 1, 40)
    while True:  # a too small Krylov space can stall on undamped (+-i omega) spectra
        try:
            pin_blas()  # ARPACK's level-2 BLAS is twice as slow on two threads (docs/performance.md)
            nu, Z = spla.eigs(ops, k=kk, which="LM", tol=0.0, v0=v0, ncv=min(2 * n - 1, ncv))
            break
        except spla.ArpackNoConvergence as e:
            if ncv >= 2 * n - 1 or ncv > 8 * kk + 100:
                if len(e.eigenvalues) >= min(k, kk):
                    nu, Z = e.eigenvalues, e.eigenvectors
                    break
                raise
            ncv *= 2
    big = np.max(np.abs(nu))
    finite = np.abs(nu) > 1e-10 * big
    lam = sigma + 1.0 / nu[finite]
    X = Z[:n, finite]
    X = X / np.linalg.norm(X, axis=0)
    MX, CX = M @ X, C @ X
    if _conservative(K, C, M):
        lam = _rayleigh_on_axis(lam, X, MX, CX, K @ X)
    # Arnoldi's residual is small relative to the largest |nu| = 1/|lambda_nearest - sigma|:
    # the eigenvalues farther from sigma are less accurate. Their first-order error
    # x^H T(lam) x / x^H T'(lam) x (x standing in for the left vector) joins the bound.
    TX = lam**2 * MX + lam * CX + K @ X
    dTX = 2 * lam * MX + CX
    first = np.abs(np.sum(X.conj() * TX, axis=0)) / np.maximum(np.abs(np.sum(X.conj() * dTX, axis=0)), 1e-300)
    noise = np.maximum(eigen_noise(K, C, M, lam, X), 3.0 * first)
    return lam, noise, X, 0


def proved_stable(b: Block) -> bool:
    """No eigenvalue of the block has Re(lambda) > 0, proved by its energy: K and M
    symmetric positive definite and the symmetric part of C positive semi-definite, so
    E = (v'Mv + x'Kx)/2 > 0 and dE/dt = -v'C_sym v <= 0 (the skew, gyroscopic part of C
    does no work; Kelvin-Tait-Chetaev). E.g. a straight pipe's axial block with flow: the
    outflow damps it, the flow's follower terms act on the bending blocks only.

    Sufficient tests, each cheap next to an Arnoldi run: symmetry to 1e-12 of the largest
    entry, definiteness by a (band) Cholesky or an LU without pivoting whose pivots are all
    positive, semi-definiteness of C_sym by diagonal dominance with a non-negative
    diagonal (to 1e-12 of its largest entry: Re(lambda) may be round-off above 0, as in
    any computed spectrum). A block that fails a test is simply not proved stable."""
    K, C, M = (sp.csc_matrix(X) for X in (b.K, b.C, b.M))
    if not (K.nnz and M.nnz) or not all(_symmetric(X) for X in (K, M)):
        return False
    if C.nnz:
        S = 0.5 * (C + C.T)
        d = S.diagonal()
        off = np.asarray(abs(S).sum(axis=1)).ravel() - np.abs(d)
        if np.any(d - off < -1e-12 * np.abs(S.data).max()):
            return False
    return _positive_definite(K) and _positive_definite(M)


def _positive_definite(X) -> bool:
    """A symmetric sparse X is positive definite: its band Cholesky (LAPACK pbtrf) exists,
    or (wider patterns) its LU without pivoting has only positive pivots."""
    X = sp.csc_matrix(X)
    cols, low, kl, _ = _band(X)
    if kl <= BAND_MAX:
        ab = np.zeros((kl + 1, X.shape[0]))
        below = low >= 0
        ab[low[below], cols[below]] = X.data[below]
        try:
            sla.cholesky_banded(ab, lower=True, check_finite=True)
            return True
        except (np.linalg.LinAlgError, ValueError):
            return False
    try:
        lu = spla.splu(X, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options=dict(SymmetricMode=True))
    except RuntimeError:
        return False
    return bool(np.array_equal(lu.perm_r, lu.perm_c) and np.all(lu.U.diagonal() > 0.0))


class _Operator(spla.LinearOperator):
    """A LinearOperator whose ``matvec`` is the function ``op`` itself, without
    LinearOperator's shape checks (~40 us a call; ARPACK applies it 50-60 times a block)."""

    def __init__(self, op, n, dtype):
        super().__init__(np.dtype(dtype), (n, n))
        self.matvec = op  # (the instance's: ARPACK's loop calls it)

    def _matvec(self, v):
        return self.matvec(v)


def _conservative(K, C, M, rtol: float = 1e-12) -> bool:
    """K and M symmetric, C skew-symmetric (gyroscopic or none): an undamped conservative
    block, whose T(i w) is Hermitian for real w."""
    return all(_symmetric(X, sign, rtol) for X, sign in ((K, 1.0), (M, 1.0), (C, -1.0)))


def _symmetric(X, sign: float = 1.0, rtol: float = 1e-12) -> bool:
    """X = sign X^T to rtol of its largest entry (sign -1: skew-symmetric)."""
    X = sp.csc_matrix(X)
    if not X.nnz:
        return True
    size = np.abs(X.data).max() if X.has_canonical_format else abs(X).max()
    if X.has_canonical_format:
        Xt = X.tocsr()  # its arrays are X^T's in CSC
        Xt.sort_indices()
        if np.array_equal(Xt.indptr, X.indptr) and np.array_equal(Xt.indices, X.indices):
            return bool(np.abs(X.data - sign * Xt.data).max() <= rtol * size)  # (a symmetric pattern, the usual case)
    return bool(abs(X - sign * X.T).max() <= rtol * size)


def _rayleigh_on_axis(lam, X, MX, CX, KX):
    """The eigenvalues of a conservative block (:func:`_conservative`) from the Rayleigh
    functional of their vectors: the root i w of x^H T(i w) x = 0, i.e. of
    -a w^2 - beta w + c = 0 (a = x^H M x, i beta = x^H C x, c = x^H K x, all real),
    nearest Arnoldi's; Arnoldi's value is kept where that root is not real (off the axis).

    Why: T(i w) is Hermitian, so the functional's error is quadratic in the vector's;
    Arnoldi's own values carry the first-order error of the non-normal first-order
    operator (a real part ~1e-8 |lambda| on an undamped 80-element beam, 1e-6 at 160).
    """
    a = np.real(np.sum(X.conj() * MX, axis=0))
    beta = np.real(np.sum(X.conj() * CX, axis=0) / 1j)
    c = np.real(np.sum(X.conj() * KX, axis=0))
    disc = beta**2 + 4.0 * a * c
    ok = (disc >= 0.0) & (a > 0.0)
    root = np.sqrt(np.where(ok, disc, 0.0))
    a_safe = np.where(ok, a, 1.0)
    w1, w2 = (-beta + root) / (2.0 * a_safe), (-beta - root) / (2.0 * a_safe)
    w = np.where(np.abs(w1 - lam.imag) <= np.abs(w2 - lam.imag), w1, w2)
    return np.where(ok, 1j * w, lam)


def _velocity_scale(op, v0, k) -> float:
    """|mu_k| = |lambda_k - sigma| of the k-th eigenvalue nearest sigma, from the Ritz
    values of a short Arnoldi run (k + 2 steps) of ``op`` (which reads its scale tau as
    set when called: here 1); an overestimate by a few times, which is harmless.

    Why: each undamped mode pair lambda = sigma +- i w of the state [x; mu x / tau] is a
    2 x 2 block [[0, -tau / w^2], [1 / tau, 0]] of the operator, eigenvalues +-i / w
    but norm max(tau / w^2, 1 / tau). For the unwanted modes (w > |mu_k|) that norm is
    1 / tau; with tau much below |mu_k| (tau = 1 against w ~ 10^3-10^4 rad/s for the
    modes of a fine beam) they are nearly Jordan blocks that one application does not
    shrink below the wanted |nu_k| = 1 / |mu_k|, and ARPACK's Ritz estimates of the
    last wanted pairs stall: 52 000 applications for 40 eigenvalues of a 320-element
    beam. tau ~ |mu_k| keeps every unwanted block below |nu_k| (0.1 to 100 times it
    converge alike, measured), so the wanted ones converge in about 3 k applications.
    """
    steps = min(k + 2, len(v0) - 1)
    Q = np.zeros((len(v0), steps + 1), dtype=v0.dtype)
    H = np.zeros((steps + 1, steps), dtype=v0.dtype)
    Q[:, 0] = v0 / np.linalg.norm(v0)
    for j in range(steps):
        w = op(Q[:, j])
        for _ in range(2):  # classical Gram-Schmidt, repeated once for orthogonality
            h = Q[:, :j + 1].conj().T @ w
            w = w - Q[:, :j + 1] @ h
            H[:j + 1, j] += h
        H[j + 1, j] = np.linalg.norm(w)
        if H[j + 1, j] <= 1e-14 * np.abs(H[:j + 2, :j + 1]).max():
            steps = j + 1  # an invariant subspace: its Ritz values are exact
            break
        Q[:, j + 1] = w / H[j + 1, j]
    ritz = np.sort(np.abs(np.linalg.eigvals(H[:steps, :steps])))[::-1]
    ritz = ritz[ritz > 1e-10 * ritz[0]]  # nu = 0: infinite lambda (massless coordinates), never wanted
    return 1.0 / ritz[min(k, len(ritz)) - 1] if len(ritz) else 1.0


class QuadraticPencil:
    """T(s) = s^2 M + s C + K of sparse K, C, M, all on the union of their patterns, so
    that each T(s) is one combination of value arrays instead of two sparse additions."""

    def __init__(self, K, C, M):
        self.K, self.C, self.M = (sp.csc_matrix(X) for X in (K, C, M))
        first = max((self.K, self.C, self.M), key=lambda X: X.nnz)
        if first.has_canonical_format and all(X.nnz == 0 or (np.array_equal(X.indptr, first.indptr) and
                                                             np.array_equal(X.indices, first.indices))
                                              for X in (self.K, self.C, self.M)):
            # one pattern (linearize's K, C, M share it; an empty matrix takes zeros):
            # the union is that pattern
            self.indices, self.indptr, self.shape = first.indices, first.indptr, first.shape
            self.values = [X.data if X.nnz else np.zeros(first.nnz) for X in (self.K, self.C, self.M)]
            return
        n = self.K.shape[0]
        parts = []  # (column n + row of each entry, value), canonical
        for X in (self.K, self.C, self.M):
            if not X.has_canonical_format:
                X = X.copy()
                X.sum_duplicates()
            parts.append((np.repeat(np.arange(n, dtype=np.int64), np.diff(X.indptr)) * n + X.indices, X.data))
        # the union pattern in CSC order: the keys merged (a stable sort of three sorted runs)
        keys = np.concatenate([k for k, _ in parts])
        order = np.argsort(keys, kind="stable")
        new = np.ones(len(keys), bool)
        np.not_equal(keys[order[1:]], keys[order[:-1]], out=new[1:])
        key = keys[order[new]]
        at = np.empty(len(keys), np.int64)  # each entry's place in the union
        at[order] = np.cumsum(new) - 1
        self.indices = (key % n).astype(np.int32)
        self.indptr = np.searchsorted(key, np.arange(n + 1, dtype=np.int64) * n).astype(np.int32)
        self.shape = self.K.shape
        self.values, start = [], 0
        for xkey, data in parts:
            v = np.zeros(len(key))
            v[at[start:start + len(xkey)]] = data
            self.values.append(v)
            start += len(xkey)

    def __call__(self, s):
        k, c, m = self.values
        T = sp.csc_matrix((s * s * m + s * c + k, self.indices, self.indptr), shape=self.shape)
        T.has_canonical_format = True
        return T

    def bordered(self, s, column, row):
        """[[T(s), column], [row, 0]] (CSC, n + 1 square; ``column``, ``row`` dense n-vectors)
        from the value arrays: the Jacobian of Newton on [T(s) x; c^H x - 1] = 0
        (:func:`~pipeflex.analysis.critical.refine_eigenpair`), without a sparse block
        assembly each step. Each column of T gets the row's entry last."""
        n = self.shape[0]
        if not hasattr(self, "_border"):
            nnz = len(self.indices)
            at = np.arange(nnz) + np.repeat(np.arange(n), np.diff(self.indptr))  # after j row entries
            last = self.indptr[1:] + np.arange(n)
            indptr = np.concatenate([self.indptr + np.arange(n + 1), [nnz + 2 * n]]).astype(np.int32)
            indices = np.empty(nnz + 2 * n, np.int32)
            indices[at], indices[last], indices[nnz + n:] = self.indices, n, np.arange(n)
            self._border = at, last, indices, indptr
        at, last, indices, indptr = self._border
        k, c, m = self.values
        data = np.empty(len(indices), complex)
        data[at] = s * s * m + s * c + k
        data[last] = row
        data[len(indices) - n:] = column
        J = sp.csc_matrix((data, indices, indptr), shape=(n + 1, n + 1))
        J.has_canonical_format = True
        return J

    def residual(self, s, x) -> np.ndarray:
        """T(s) x with K x summed in twice the working precision (compensated: Ogita,
        Rump and Oishi's Dot2, exact products by Dekker's split, error-free sums), the
        small s C x + s^2 M x in double, rounded to complex double at the end.

        Why: near an eigenvalue the stiffness terms of a fine beam (~N^3) cancel to the
        small T(s) x; in double that leaves an error ~N^4 eps in s (:func:`eigen_noise`):
        0.02 1/s at 4096 elements, ~0.3 at 8192, beyond the real part of a pipe's
        crossing eigenvalue near its flutter flow. Summed so, K x is good to about
        eps |K x| + (k eps)^2 |K| |x| (k entries a row), and Newton's steps on it
        (:func:`~pipeflex.analysis.critical.refine_eigenpair`) reach the double
        resolution of s whatever N (measured: 1e-14 to 2e-13 1/s from 128 to 8192 elements)."""
        if not hasattr(self, "_slots"):
            K = self.K.tocsr()
            K.sum_duplicates()
            counts = np.diff(K.indptr)
            short = counts <= _DOT2_ROW
            # the j-th entries of the short rows, one vectorised Dot2 step each
            self._slots = [(rows, K.indptr[rows] + j)
                           for j in range(int(counts[short].max(initial=0)))
                           for rows in [np.nonzero(short & (counts > j))[0]]]
            self._long = [(i, slice(K.indptr[i], K.indptr[i + 1])) for i in np.nonzero(~short)[0]]
            self._k = K.data, K.indices, _split(K.data)
        data, cols, (dh, dl) = self._k
        x = np.asarray(x, complex)
        rest = s * (self.C @ x) + (s * s) * (self.M @ x)

        def stiffness(part):  # K part, as an unevaluated sum hi + lo
            hi, lo = np.zeros(len(part)), np.zeros(len(part))
            for rows, e in self._slots:
                p, err = _two_product(data[e], dh[e], dl[e], part[cols[e]])
                hi[rows], q = _two_sum(hi[rows], p)
                lo[rows] += q + err
            if self._long:  # long rows (a coordinate coupled to many): exactly rounded sums
                p, err = _two_product(data, dh, dl, part[cols])
                for i, e in self._long:
                    hi[i] = math.fsum(np.concatenate([p[e], err[e]]))
            return hi, lo

        (hr, lr), (hi, li) = stiffness(x.real), stiffness(x.imag)
        return (hr + (lr + rest.real)) + 1j * (hi + (li + rest.imag))


#: Rows of K with up to this many entries are summed by a vectorised Dot2, one step per
#: entry; longer ones (few: e.g. a body's frame coordinate) by math.fsum.
_DOT2_ROW = 64


def _split(a):
    """Dekker's split a = hi + lo, each with at most 26 significant bits."""
    t = 134217729.0 * a  # 2^27 + 1
    hi = t - (t - a)
    return hi, a - hi


def _two_product(a, ah, al, b):
    """p = fl(a b) and its exact error e = a b - p (Dekker; ``ah``, ``al`` = _split(a))."""
    p = a * b
    bh, bl = _split(b)
    return p, al * bl - (((p - ah * bh) - al * bh) - ah * bl)


def _two_sum(a, b):
    """s = fl(a + b) and its exact error (Knuth)."""
    s = a + b
    z = s - a
    return s, (a - (s - z)) + (b - z)


#: A sparse matrix whose entries lie within this many diagonals below and above the main
#: one is factored as a band (:class:`_BandLU`), else by SuperLU.
BAND_MAX = 16


class _BandLU:
    """LU with partial pivoting of a sparse matrix stored as a band (LAPACK gbtrf/gbtrs),
    solving as SuperLU's ``solve``.

    Why: a chain of beam elements numbered along the pipe gives blocks of bandwidth 3;
    SuperLU's solve costs 0.27 ms for such a block of 2048 coordinates, the band's
    0.08 ms, and the shift-invert Arnoldi of :func:`sparse_block_eigenvalues` applies it
    50-60 times per block."""

    def __init__(self, A, kl, ku):
        A = A.tocoo()
        n = A.shape[0]
        ab = np.zeros((2 * kl + ku + 1, n), A.dtype)
        ab[kl + ku + A.row - A.col, A.col] = A.data  # duplicates cannot occur (canonical CSC)
        gbtrf, self._gbtrs = sla.get_lapack_funcs(("gbtrf", "gbtrs"), (ab,))
        self._lu, self._piv, info = gbtrf(ab, kl, ku)
        if info > 0:
            raise RuntimeError("Factor is exactly singular")
        self.kl, self.ku, self.dtype = kl, ku, ab.dtype

    @classmethod
    def of(cls, A):
        """The band LU of the canonical CSC matrix A, or None if its band is wider than BAND_MAX."""
        _, _, kl, ku = _band(A)
        return cls(A, kl, ku) if kl <= BAND_MAX and ku <= BAND_MAX else None

    def u_diagonal(self) -> np.ndarray:
        return self._lu[self.kl + self.ku]

    def solve(self, b):
        if np.iscomplexobj(b) and self.dtype.kind != "c":
            return self.solve(b.real) + 1j * self.solve(b.imag)
        x, info = self._gbtrs(self._lu, self.kl, self.ku, np.asarray(b, self.dtype), self._piv)
        return x


def _band(A):
    """Of a CSC matrix: the column of each entry, its distance below the diagonal (row -
    column) and the lower and upper bandwidths."""
    cols = np.repeat(np.arange(A.shape[1]), np.diff(A.indptr))
    off = A.indices - cols
    kl, ku = (int(max(off.max(), 0)), int(max(-off.min(), 0))) if len(off) else (0, 0)
    return cols, off, kl, ku


def _shift_factor(T, sigma):
    """LU of T(sigma) = sigma^2 M + sigma C + K (a :class:`QuadraticPencil`; a band's by
    :class:`_BandLU`, else SuperLU's); the shift is moved off an (exactly or numerically)
    singular point by a tiny amount."""
    for attempt in range(3):
        s = sigma.real if sigma.imag == 0.0 else sigma
        Ts = T(s)
        try:
            lu = _BandLU.of(Ts)
            if lu is None:
                lu = spla.splu(Ts)
            u = np.abs(lu.u_diagonal() if isinstance(lu, _BandLU) else lu.U.diagonal())
            if u.min() > 1e-13 * u.max():
                return Ts, lu
        except RuntimeError:
            pass
        # move by 1e-6 of the frequency scale sqrt(|K| / |M|) of the lightest/softest terms
        scale = np.sqrt(spla.norm(T.K, 1) / max(spla.norm(T.M, 1), 1e-300)) if T.M.nnz else 1.0
        sigma = sigma + 1e-6 * scale * 10.0 ** attempt
    raise np.linalg.LinAlgError(f"T(sigma) is singular near sigma = {sigma}: choose another sigma")


class BlockSolutions:
    """The block solutions of the last :func:`sparse_eigen_from_blocks` call given this
    object (same k and sigma), for a sequence of analyses at nearby parameters (the
    critical-flow scan). A block whose K, C and M equal (up to coordinate signs, as
    :func:`_solve_blocks` compares blocks) those of a block solved last time takes its
    solution: the same matrices, the same eigenvalues (e.g. a straight pipe's torsion,
    which the flow does not change). Another block at the same coordinates skips
    the short Arnoldi run of :func:`_velocity_scale`: its scale tau is the largest
    |lambda - sigma| of last time's solution (|mu_k| itself, where that run estimates it
    within a few times; 0.1 to 100 times it converge alike)."""

    def __init__(self):
        self.key = None  # (k, sigma) of the solutions
        self.solved = []  # (block, lam, noise, V, negative)

    def known(self, k, sigma):
        return self.solved if self.key == (k, sigma) else []

    def scale(self, block, sigma):
        for a, lam, *_ in self.solved:
            if len(lam) and np.array_equal(a.dofs, block.dofs):
                return float(np.max(np.abs(lam - sigma)))
        return None


def sparse_eigen_from_blocks(blocks, n, k, *, sigma=None, vectors=False,
                             previous: Optional[BlockSolutions] = None,
                             unstable_only: bool = False) -> EigenResult:
    """The k eigenvalues nearest sigma (default 0) of sparse blocks (:func:`split_blocks`
    with ``sparse=True``), as an :class:`EigenResult` in :func:`eigen_from_blocks`' order.
    ``previous``: the solutions of the last call given it (:class:`BlockSolutions`), reused
    where a block is unchanged and as the start of the others; updated to this call's.
    ``unstable_only``: for a stability decision, a block proved stable
    (:func:`proved_stable`) contributes no eigenvalues instead of an Arnoldi run."""
    sigma = 0.0 if sigma is None else complex(sigma)
    known = [] if previous is None else previous.known(k, sigma)

    def solve(b):
        if unstable_only and proved_stable(b):
            m = len(b.dofs)
            return np.zeros(0, complex), np.zeros(0), np.zeros((m, 0), complex), 0
        scale = None if previous is None or previous.key != (k, sigma) else previous.scale(b, sigma)
        return sparse_block_eigenvalues(b, k, sigma, vectors=vectors, scale=scale)

    values, noise, block_of, vecs, static_negative, solved = _solve_blocks(
        blocks, n, solve, _sign_similarity_sparse, vectors, known)
    if previous is not None:
        previous.key, previous.solved = (k, sigma), solved
    keep = _nearest(values, k, sigma)
    values, noise, block_of = values[keep], noise[keep], block_of[keep]
    order = np.lexsort((values.real, np.round(np.abs(values.imag), 12)))
    V = np.concatenate(vecs, axis=1)[:, keep][:, order] if vectors and vecs else None
    return EigenResult(values[order], noise[order], V, block_of[order], static_negative, blocks)


def _solve_blocks(blocks, n, solve, similarity, with_vectors, known=()):
    """Eigenvalues of every block by ``solve(block)`` -> (lam, noise, V, negative), a block
    equal to an earlier one up to DOF signs (``similarity``) reusing its solution (the two
    bending planes of a straight pipe), or equal to one of ``known`` (block, lam, noise,
    V, negative), solved by an earlier call (:func:`_same_block`). Returns the
    concatenated values, noise, owning block, the vectors scattered to all ``n`` DOFs (if
    ``with_vectors``), the count of negative static stiffnesses and this call's distinct
    solutions (as ``known``)."""
    vals, noises, vecs, owner = [], [], [], []
    static_negative = 0
    solved = []  # (block, lam, noise, V, negative) of this call
    for i, b in enumerate(blocks):
        for a, lam_a, noise_a, V_a, negative_a in solved:
            d = similarity(a, b)
            if d is not None:
                lam, noise, V = lam_a, noise_a, (None if V_a is None else d[:, None] * V_a)
                break
        else:
            same = next((s for s in known if _same_block(s[0], b)), None)
            lam, noise, V, negative = same[1:] if same is not None else solve(b)
            static_negative += negative
            solved.append((b, lam, noise, V, negative))
        if len(lam) == 0:
            continue
        vals.append(lam)
        noises.append(noise)
        owner.append(np.full(len(lam), i))
        if with_vectors:
            full = np.zeros((n, len(lam)), complex)
            full[b.dofs] = V
            vecs.append(full)
    values = np.concatenate(vals) if vals else np.zeros(0, complex)
    noise = np.concatenate(noises) if noises else np.zeros(0)
    block_of = np.concatenate(owner) if owner else np.zeros(0, int)
    return values, noise, block_of, vecs, static_negative, solved


def _same_block(a: Block, b: Block) -> bool:
    """The same coordinates and the same K, C, M (sparse: the same CSC arrays) to the bit."""
    if not np.array_equal(a.dofs, b.dofs):
        return False
    for x, y in ((a.K, b.K), (a.C, b.C), (a.M, b.M)):
        if sp.issparse(x) != sp.issparse(y):
            return False
        if not sp.issparse(x):
            if not np.array_equal(x, y):
                return False
        elif not (x.shape == y.shape and np.array_equal(x.indptr, y.indptr)
                  and np.array_equal(x.indices, y.indices) and np.array_equal(x.data, y.data)):
            return False
    return True


def eigen_from_blocks(blocks, n, *, vectors=False) -> EigenResult:
    values, noise, block_of, vecs, static_negative, _ = _solve_blocks(
        blocks, n, lambda b: block_eigenvalues(b, vectors=vectors), _sign_similarity, vectors)
    order = np.lexsort((values.real, np.round(np.abs(values.imag), 12)))
    V = np.concatenate(vecs, axis=1)[:, order] if vectors and vecs else None
    return EigenResult(values[order], noise[order], V, block_of[order], static_negative, blocks)


#: :func:`stability` refuses a stiffness whose least to largest singular value ratio
#: (per block) is below this: singular to round-off, a mechanism (a beam's conditioning
#: falls like N^-3, ~1e-14 only at ~10^4 elements).
MECHANISM_CONDITIONING = 64 * np.finfo(float).eps


def stability(eig: EigenResult) -> str:
    """'stable', 'divergence' (a real eigenvalue > 0) or 'flutter' (a growing oscillation).

    Raises:
        TypeError: ``eig`` is not an :class:`EigenResult`.
        ValueError: the stiffness is singular (a mechanism: missing supports, a free
            joint, an unsupported part); the message names the free coordinates. Its
            round-off eigenvalues near 0 would otherwise decide the answer.
    """
    if not isinstance(eig, EigenResult):
        raise TypeError(f"eig must be an EigenResult (pipeflex.eigenvalues(pipeflex.linearize(model))), got "
                        f"{type(eig).__name__}")
    free = mechanism(eig)
    if free is not None:
        raise ValueError(f"stability: the stiffness is singular, a mechanism ({free}); its "
                         f"eigenvalues near 0 are round-off, so stability is undefined: support the free motion")
    return classify(eig)


def mechanism(eig: EigenResult) -> Optional[str]:
    """The free coordinates, named (:func:`free_coordinates`), if the stiffness of ``eig``
    is singular to round-off (:func:`stiffness_conditioning` below
    MECHANISM_CONDITIONING), else None: the one mechanism rule of :func:`stability` and
    :func:`~pipeflex.critical_mass_flow` (the latter at its equilibrium without flow)."""
    if stiffness_conditioning(eig) < MECHANISM_CONDITIONING:
        return free_coordinates(eig)
    return None


def classify(eig: EigenResult) -> str:
    """:func:`stability` without its checks (for analyses that pass a stiffness that is
    singular at a stability boundary, such as the critical-flow search)."""
    lam = eig.values
    growing = lam[_growing(eig)]
    if len(growing) == 0:
        return "divergence" if eig.static_negative else "stable"
    worst = growing[np.argmax(growing.real)]
    return "divergence" if abs(worst.imag) <= 1e-6 * abs(worst) else "flutter"


def _growing(eig: EigenResult) -> np.ndarray:
    """Mask of the eigenvalues that grow: Re(lambda) above GROWTH_TOL |lambda| and above
    their round-off bound ``noise``."""
    lam = eig.values
    return lam.real > np.maximum(GROWTH_TOL * np.abs(lam), eig.noise)


def _jacobi_scaled(K):
    """D^-1/2 K D^-1/2 with D = |diag K| (1 where the diagonal vanishes): stiffnesses of
    different units and sizes (EA / l against EI / l^3) do not read as ill-conditioning."""
    d = np.abs(K.diagonal())
    d = 1.0 / np.sqrt(np.where(d > 0.0, d, 1.0))
    if sp.issparse(K):
        D = sp.diags(d)
        return D @ K @ D
    return K * d[:, None] * d[None, :]


def stiffness_conditioning(eig) -> float:
    """Smallest ratio of least to largest singular value of the blocks' stiffness after
    a symmetric diagonal (Jacobi) scaling (sparse blocks: its bound
    n / (|K|_1 |K^-1|_1), |K^-1|_1 estimated)."""
    worst = 1.0
    for b in eig.blocks:
        if sp.issparse(b.K):
            n = b.K.shape[0]
            if n == 0:
                continue
            K = sp.csc_matrix(_jacobi_scaled(b.K))
            try:
                lu = spla.splu(K)
            except RuntimeError:
                return 0.0
            inv = spla.LinearOperator(K.shape, matvec=lu.solve, rmatvec=lambda v: lu.solve(v, trans="T"),
                                      dtype=float)
            worst = min(worst, n / (spla.norm(K, 1) * spla.onenormest(inv)))
        elif b.K.size:
            sv = np.linalg.svd(_jacobi_scaled(b.K), compute_uv=False)
            worst = min(worst, sv[-1] / sv[0] if sv[0] > 0 else 0.0)
    return worst


#: Largest matrix whose null space :func:`null_coordinates` computes (a dense SVD).
MAX_NAMED_DOFS = 3000


def null_coordinates(K, *, rtol: float = 1e3 * np.finfo(float).eps) -> np.ndarray:
    """Indices of the coordinates that move in the null space of the (square) K: the
    singular vectors with singular values below rtol times the largest. Empty if K is
    regular or larger than MAX_NAMED_DOFS."""
    K = K.toarray() if sp.issparse(K) else np.asarray(K)
    if K.size == 0 or K.shape[0] > MAX_NAMED_DOFS:
        return np.zeros(0, int)
    _, sv, vt = np.linalg.svd(K)
    null = vt[sv <= rtol * max(sv[0], np.finfo(float).tiny)]
    if not len(null):
        return np.zeros(0, int)
    weight = np.linalg.norm(null, axis=0)
    return np.flatnonzero(weight > 1e-6 * weight.max())


def describe_coordinates(dofs, labels) -> str:
    """'nodes 0..4: uy rz; node 5: uy' for reduced coordinates ``dofs`` with ``labels``
    (node, component) (or 'coordinates 3, 4' without labels); at most 8 groups listed."""
    dofs = sorted(int(i) for i in dofs)
    if labels is None:
        return "coordinates " + ", ".join(map(str, dofs[:24])) + (" ..." if len(dofs) > 24 else "")
    by_node = {}
    for i in dofs:
        node, comp = labels[i]
        by_node.setdefault(node, []).append(comp)
    runs = []  # [first node, last node, components]: consecutive nodes with the same components
    for node, comps in sorted(by_node.items()):
        if runs and runs[-1][1] == node - 1 and runs[-1][2] == comps:
            runs[-1][1] = node
        else:
            runs.append([node, node, comps])
    items = [(f"node {a}" if a == b else f"nodes {a}..{b}") + f": {' '.join(c)}" for a, b, c in runs]
    more = f"; ... ({len(items) - 8} more)" if len(items) > 8 else ""
    return "; ".join(items[:8]) + more


def free_coordinates(eig: EigenResult) -> str:
    """The free coordinates of a singular stiffness, named (see
    :func:`describe_coordinates`), over all blocks of ``eig``."""
    dofs = []
    for b in eig.blocks:
        dofs.extend(np.asarray(b.dofs)[null_coordinates(b.K)])
    if not dofs:
        return "free coordinates not determined"
    return "free: " + describe_coordinates(dofs, eig.dof_labels)
