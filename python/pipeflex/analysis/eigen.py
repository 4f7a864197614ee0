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

#: An eigenvalue counts as growing when Re(lambda) exceeds GROWTH_TOL * |lambda| and
#: its round-off bound (see :func:`block_eigenvalues`).
GROWTH_TOL = 1e-9


@dataclass
class Block:
    """One decoupled block: its reduced coordinates and dense K, C, M."""

    dofs: np.ndarray
    K: np.ndarray
    C: np.ndarray
    M: np.ndarray


@dataclass
class EigenResult:
    """Finite eigenvalues lambda [1/s] (complex; Im = angular frequency [rad/s]).

    Attributes:
        values: eigenvalues sorted by |Im| then Re.
        vectors: (n_dofs, k) complex mode shapes (columns) if requested, else None.
        block_of: index of the block each eigenvalue belongs to.
        static_negative: number of negative stiffness eigenvalues in massless blocks.
        noise: round-off bound on each eigenvalue [1/s].
    """

    values: np.ndarray
    noise: np.ndarray = None
    vectors: np.ndarray = None
    block_of: np.ndarray = None
    static_negative: int = 0
    blocks: List[Block] = field(default_factory=list, repr=False)

    @property
    def frequencies(self) -> np.ndarray:
        """Angular frequencies |Im lambda| [rad/s] of the eigenvalues with Im >= 0."""
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

    Backward-stable eigensolvers perturb mu by about eps ||A||; mapped to lambda = 1/mu
    that is eps ||A|| |lambda|^2, large for the high modes when K is nearly singular.
    """
    n = len(b.dofs)
    if not np.any(b.M) and not np.any(b.C):
        return np.zeros(0, complex), np.zeros(0), np.zeros((n, 0), complex)
    scale_k = np.max(np.abs(b.K)) if np.any(b.K) else 1.0
    scale_m = np.max(np.abs(b.M)) if np.any(b.M) else scale_k
    sigma = 0.0
    K, C = b.K, b.C
    lu = sla.lu_factor(K, check_finite=False)
    u = np.abs(np.diag(lu[0]))
    if u.min() <= 1e-12 * u.max():
        # Singular stiffness (rigid-body motion or exactly critical): shift lambda.
        sigma = 1e-2 * np.sqrt(scale_k / scale_m)
        K = b.K + sigma * b.C + sigma**2 * b.M
        C = b.C + 2 * sigma * b.M
        lu = sla.lu_factor(K, check_finite=False)
    X = sla.lu_solve(lu, b.M, check_finite=False)
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
    vec = V[:n, finite] if vectors else None
    return lam, noise, vec


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
            lam, noise, V = block_eigenvalues(b, vectors=vectors)
            solved.append((b, lam, noise, V))
        if len(lam) == 0:
            ev = np.linalg.eigvals(b.K)
            static_negative += int(np.sum(ev.real < -1e-12 * max(1e-300, np.abs(ev).max())))
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
