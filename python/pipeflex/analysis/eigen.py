"""Eigenvalues of the quadratic problem (lambda^2 M + lambda C + K) x = 0 and stability.

Dense, exact method: the reduced coordinates are split into the independent blocks of
the linearised system (a straight pipe's two bending planes, its axial and torsional
motion decouple), and each block is solved in inverted companion form
    mu^2 K x + mu C x + M x = 0,   mu = 1/lambda,
which keeps the low (physically relevant) eigenvalues accurate and tolerates a singular
mass matrix (massless coordinates give mu = 0, i.e. infinite lambda, and are dropped).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import List

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from ..results import Result

#: An eigenvalue counts as growing when Re(lambda) exceeds GROWTH_TOL * |lambda| and
#: its round-off bound (see :func:`block_eigenvalues`).
GROWTH_TOL = 1e-9


@dataclass(frozen=True)
class Block(Result):
    """One decoupled block: its reduced coordinates ``dofs`` and dense ``K``, ``C``, ``M``
    (units as in :class:`~pipeflex.analysis.Linearization`)."""

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
    """

    values: np.ndarray
    noise: np.ndarray = None
    vectors: np.ndarray = None
    block_of: np.ndarray = None
    static_negative: int = 0
    blocks: List[Block] = field(default_factory=list, repr=False)

    @property
    def frequencies(self) -> np.ndarray:
        """Angular frequencies abs(Im lambda) [rad/s] of the eigenvalues with Im >= 0."""
        return np.abs(self.values[self.values.imag >= 0].imag)

    def growth(self) -> float:
        """Largest Re(lambda) [1/s]."""
        return float(np.max(self.values.real)) if len(self.values) else -np.inf


def split_blocks(K, C, M, *, tol: float = 1e-13) -> List[Block]:
    """Decompose the coordinates into the connected components of the coupling pattern.

    An entry X_ij couples i and j unless |X_ij| <= tol sqrt(|X_ii X_jj|) (or, with a zero
    diagonal, tol max|X|): a scale-invariant test that only drops round-off.
    """
    n = K.shape[0]
    rows, cols = [np.arange(n)], [np.arange(n)]
    for X in (K, C, M):
        X = sp.coo_matrix(X)
        if X.nnz == 0:
            continue
        d = np.zeros(n)
        on_diag = X.row == X.col
        np.add.at(d, X.row[on_diag], np.abs(X.data[on_diag]))
        ref = np.sqrt(d[X.row] * d[X.col])
        ref[ref == 0.0] = np.max(np.abs(X.data))
        keep = np.abs(X.data) > tol * ref
        rows.append(X.row[keep])
        cols.append(X.col[keep])
    r, c = np.concatenate(rows), np.concatenate(cols)
    pattern = sp.csr_matrix((np.ones(len(r), bool), (r, c)), shape=(n, n))
    dense = [X.toarray() if sp.issparse(X) else np.asarray(X) for X in (K, C, M)]
    ncomp, labels = connected_components(sp.csr_matrix(pattern), directed=False)
    blocks = []
    for c in range(ncomp):
        idx = np.nonzero(labels == c)[0]
        ix = np.ix_(idx, idx)
        blocks.append(Block(idx, dense[0][ix], dense[1][ix], dense[2][ix]))
    return blocks


def _sign_similarity(a: Block, b: Block):
    """Signs d (+-1) with b.X = D a.X D for X = K, C, M, or None.

    The two bending planes of a straight pipe are such a pair (their rotation coordinates
    differ in sign); they then share eigenvalues and, up to D, eigenvectors.
    """
    if len(a.dofs) != len(b.dofs):
        return None
    pairs = [(a.K, b.K), (a.C, b.C), (a.M, b.M)]
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
    if np.any(d == 0.0):
        return None
    D = np.outer(d, d)
    for x, y in pairs:
        if not np.allclose(D * x, y, rtol=1e-14, atol=0.0):
            return None
    return d


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
    if np.abs(Q0.T @ C).max() > 1e-12 * c_scale or np.abs(C @ Q0).max() > 1e-12 * c_scale:
        lam, noise, V = _generalized(K, C, M, vectors)
        return lam, noise, V, 0
    K00 = Q0.T @ K @ Q0
    S = np.linalg.solve(K00, Q0.T @ K @ Qm)
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
    """
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
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-X, -Y]])
    if vectors:
        mu, V = np.linalg.eig(A)
    else:
        mu, V = np.linalg.eigvals(A), None
    big = np.max(np.abs(mu)) if len(mu) else 0.0
    finite = np.abs(mu) > 1e-10 * big
    lam = sigma + 1.0 / mu[finite]
    noise = 1e3 * np.finfo(float).eps * np.linalg.norm(A, 1) * np.abs(lam - sigma) ** 2
    return lam, noise, (V[:n, finite] if vectors else None)


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


def eigenvalues(lin, *, vectors: bool = False) -> EigenResult:
    """Finite eigenvalues of a :class:`~pipeflex.analysis.Linearization`.

    Args:
        lin: the linearisation (M, C, K).
        vectors: also return mode shapes (complex, reduced coordinates).
    """
    blocks = split_blocks(lin.K, lin.C, lin.M)
    return eigen_from_blocks(blocks, lin.K.shape[0], vectors=vectors)


def eigen_from_blocks(blocks, n, *, vectors=False) -> EigenResult:
    vals, noises, vecs, owner = [], [], [], []
    static_negative = 0
    solved = []  # (block, lam, noise, V) already computed
    for i, b in enumerate(blocks):
        for a, lam_a, noise_a, V_a in solved:
            d = _sign_similarity(a, b)
            if d is not None:
                lam, noise, V = lam_a, noise_a, (None if V_a is None else d[:, None] * V_a)
                break
        else:
            lam, noise, V, negative = block_eigenvalues(b, vectors=vectors)
            static_negative += negative
            solved.append((b, lam, noise, V))
        if len(lam) == 0:
            continue
        vals.append(lam)
        noises.append(noise)
        owner.append(np.full(len(lam), i))
        if vectors:
            full = np.zeros((n, len(lam)), complex)
            full[b.dofs] = V
            vecs.append(full)
    values = np.concatenate(vals) if vals else np.zeros(0, complex)
    noise = np.concatenate(noises) if noises else np.zeros(0)
    block_of = np.concatenate(owner) if owner else np.zeros(0, int)
    order = np.lexsort((values.real, np.round(np.abs(values.imag), 12)))
    V = np.concatenate(vecs, axis=1)[:, order] if vectors and vecs else None
    return EigenResult(values[order], noise[order], V, block_of[order], static_negative, blocks)


def stability(eig: EigenResult) -> str:
    """'stable', 'divergence' (a real eigenvalue > 0) or 'flutter' (a growing oscillation)."""
    lam = eig.values
    growing = lam[lam.real > np.maximum(GROWTH_TOL * np.abs(lam), eig.noise)]
    if len(growing) == 0:
        return "divergence" if eig.static_negative else "stable"
    worst = growing[np.argmax(growing.real)]
    return "divergence" if abs(worst.imag) <= 1e-6 * abs(worst) else "flutter"
