"""The integrators' LU on a fixed pattern (cpp/include/pipeflex/solvers/sparse_lu.hpp):
the storage it chooses, and its solves against numpy's dense LU.

Generalised-alpha factors its iteration matrix in the band whenever the pattern fits the
band (band_first), also below the dense size: a pipe of 8 elements (48 unknowns,
half-bandwidth 11) factors in 5 us instead of 16-19 us (docs/performance.md).
"""
import numpy as np
import pytest

from pipeflex import _core

DENSE_BELOW = 100  # kDenseLuBelow


def banded(n, kl, ku, rng, *, zero_diagonal=False):
    """Triplets of a random n x n matrix with kl sub- and ku super-diagonals; with
    zero_diagonal every other diagonal entry is 0, so partial pivoting must exchange rows."""
    rows, cols, vals = [], [], []
    for j in range(n):
        for i in range(max(0, j - ku), min(n, j + kl + 1)):
            v = rng.standard_normal()
            if i == j and zero_diagonal and j % 2 == 0:
                v = 0.0
            rows.append(i)
            cols.append(j)
            vals.append(v)
    return rows, cols, vals


def dense(n, rows, cols, vals):
    A = np.zeros((n, n))
    np.add.at(A, (rows, cols), vals)
    return A


def test_band_first_takes_the_band_below_the_dense_size():
    rng = np.random.default_rng(1)
    n = 48  # 8 pipe elements
    rows, cols, vals = banded(n, 11, 11, rng)
    b = rng.standard_normal(n)
    assert _core._fixed_pattern_lu(n, rows, cols, vals, b, DENSE_BELOW, True)[0] == "band"
    assert _core._fixed_pattern_lu(n, rows, cols, vals, b, DENSE_BELOW, False)[0] == "dense"
    # a pattern outside the band stays dense below the dense size, sparse above it
    full = [(i, j) for i in range(n) for j in range(n)]
    r, c = [i for i, _ in full], [j for _, j in full]
    v = list(rng.standard_normal(n * n) + n * (np.array(r) == np.array(c)))
    assert _core._fixed_pattern_lu(n, r, c, v, b, DENSE_BELOW, True)[0] == "dense"
    m = 150
    rows, cols, vals = banded(m, 11, 11, rng)
    assert _core._fixed_pattern_lu(m, rows, cols, vals, np.ones(m), DENSE_BELOW, False)[0] == "band"


@pytest.mark.parametrize("n, kl, ku", [(6, 5, 5), (13, 2, 7), (48, 11, 11), (60, 11, 3)])
@pytest.mark.parametrize("zero_diagonal", [False, True])
def test_band_solve_equals_the_dense_solve(n, kl, ku, zero_diagonal):
    rng = np.random.default_rng(n + kl + ku)
    rows, cols, vals = banded(n, kl, ku, rng, zero_diagonal=zero_diagonal)
    # repeated triplets are summed, as the assembler's are
    rows, cols, vals = rows + rows[:5], cols + cols[:5], vals + [0.25] * 5
    A = dense(n, rows, cols, vals)
    b = rng.standard_normal(n)
    storage, ok, x = _core._fixed_pattern_lu(n, rows, cols, vals, b, DENSE_BELOW, True)
    assert storage == "band" and ok
    expected = np.linalg.solve(A, b)
    cond = np.linalg.cond(A)
    assert np.linalg.norm(x - expected) <= 1e-13 * cond * np.linalg.norm(expected)
    assert np.linalg.norm(A @ x - b) <= 1e-12 * np.linalg.norm(A, 1) * np.linalg.norm(x)


def test_a_singular_band_is_refused():
    rng = np.random.default_rng(7)
    n = 20
    rows, cols, vals = banded(n, 3, 3, rng)
    vals = [0.0 if c == 9 else v for c, v in zip(cols, vals)]  # column 9 empty
    storage, ok, _ = _core._fixed_pattern_lu(n, rows, cols, vals, np.ones(n), DENSE_BELOW, True)
    assert storage == "band" and not ok
