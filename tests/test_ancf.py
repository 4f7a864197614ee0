"""Planar ANCF beam, elastic Model A (seed 002): the appendix matrices, tangents, rigid
motion. (The element is a kernel so far; its model integration is issue 4.)"""
import numpy as np
import pytest

from pipeflex import _core


def data(l=0.7, EA=3.0e6, EI=2.0e2, mass=1.5, tip=0.4):
    d = _core.AncfElementData()
    d.l, d.EA, d.EI, d.mass, d.tip_mass = l, EA, EI, mass, tip
    return d


def upper(entries, l):
    """Symmetric 8x8 from the seed's upper-triangle rows (entries as functions of l)."""
    A = np.zeros((8, 8))
    for i, row in enumerate(entries):
        A[i, i:] = row
    return A + np.triu(A, 1).T


def seed_matrices(l):
    """Seed 002, appendix: A-1 (divided by m), A-6, A-7, A-8 (divided by EA/l), A-10 (by EI/l^3)."""
    M = upper([[13 / 35, 0, 11 * l / 210, 0, 9 / 70, 0, -13 * l / 420, 0],
               [13 / 35, 0, 11 * l / 210, 0, 9 / 70, 0, -13 * l / 420],
               [l**2 / 105, 0, 13 * l / 420, 0, -l**2 / 140, 0], [l**2 / 105, 0, 13 * l / 420, 0, -l**2 / 140],
               [13 / 35, 0, -11 * l / 210, 0], [13 / 35, 0, -11 * l / 210], [l**2 / 105, 0], [l**2 / 105]], l)
    KA = upper([[-6 / 35, 0, -6 * l / 70, 0, 6 / 35, 0, l / 70, 0], [-6 / 35, 0, -6 * l / 70, 0, 6 / 35, 0, l / 70],
                [6 * l**2 / 105, 0, 6 * l / 70, 0, -l**2 / 105, 0], [6 * l**2 / 105, 0, 6 * l / 70, 0, -l**2 / 105],
                [-6 / 35, 0, -l / 70, 0], [-6 / 35, 0, -l / 70], [-l**2 / 105, 0], [-l**2 / 105]], l)
    KM = upper([[54 / 35, 0, 12 * l / 70, 0, -54 / 35, 0, 12 * l / 70, 0],
                [54 / 35, 0, 12 * l / 70, 0, -54 / 35, 0, 12 * l / 70],
                [9 * l**2 / 105, 0, -12 * l / 70, 0, -l**2 / 70, 0], [9 * l**2 / 105, 0, -12 * l / 70, 0, -l**2 / 70],
                [54 / 35, 0, -12 * l / 70, 0], [54 / 35, 0, -12 * l / 70], [9 * l**2 / 105, 0], [9 * l**2 / 105]], l)
    KB = upper([[-6 / 35, 0, l / 70, 0, 6 / 35, 0, -6 * l / 70, 0], [-6 / 35, 0, l / 70, 0, 6 / 35, 0, -6 * l / 70],
                [-l**2 / 105, 0, -l / 70, 0, -l**2 / 105, 0], [-l**2 / 105, 0, -l / 70, 0, -l**2 / 105],
                [-6 / 35, 0, 6 * l / 70, 0], [-6 / 35, 0, 6 * l / 70], [6 * l**2 / 105, 0], [6 * l**2 / 105]], l)
    Kt = upper([[12, 0, 6 * l, 0, -12, 0, 6 * l, 0], [12, 0, 6 * l, 0, -12, 0, 6 * l],
                [4 * l**2, 0, -6 * l, 0, 2 * l**2, 0], [4 * l**2, 0, -6 * l, 0, 2 * l**2],
                [12, 0, -6 * l, 0], [12, 0, -6 * l], [4 * l**2, 0], [4 * l**2]], l)
    return M, KA, KM, KB, Kt


def test_matrices_equal_the_seed_appendix():
    d = data()
    l = d.l
    M, KA, KM, KB, Kt = seed_matrices(l)
    m = d.mass * l
    M_tip = np.zeros((8, 8))
    M_tip[4, 4] = M_tip[5, 5] = d.tip_mass
    for which, ref, scale in ((0, KA, d.EA / l), (1, KM, d.EA / l), (2, KB, d.EA / l), (3, Kt, d.EI / l**3),
                              (4, m * M + M_tip, 1.0)):
        got = _core.ancf_model_a_matrix(d, which)
        assert np.allclose(got, scale * ref, rtol=1e-12, atol=1e-12 * np.abs(scale * ref).max())


def test_tangent_matches_finite_differences():
    rng = np.random.default_rng(5)
    d = data()
    e = np.array([0.1, -0.2, 0.95, 0.2, 0.1 + 0.68, -0.05, 0.9, -0.3]) + 0.01 * rng.standard_normal(8)
    v, a = rng.standard_normal(8), rng.standard_normal(8)
    r0, K = _core.ancf_model_a_tangent(d, e, v, a, 1.0, 0.0, 0.0)
    _, W = _core.ancf_model_a_tangent(d, e, v, a, 0.5, 3.0, 2.0)
    h = 1e-7
    K_fd = np.column_stack([(_core.ancf_model_a_tangent(d, e + h * np.eye(8)[j], v, a, 0, 0, 0)[0] -
                             _core.ancf_model_a_tangent(d, e - h * np.eye(8)[j], v, a, 0, 0, 0)[0]) / (2 * h)
                            for j in range(8)])
    assert np.abs(K - K_fd).max() <= 1e-6 * np.abs(K_fd).max()
    assert np.allclose(W, 0.5 * K + 2.0 * _core.ancf_model_a_matrix(d, 4), rtol=1e-13, atol=1e-9)


@pytest.mark.parametrize("angle", [0.0, 0.7, 2.5])
def test_rigid_motion_gives_zero_elastic_force(angle):
    d = data()
    c, s = np.cos(angle), np.sin(angle)
    t = np.array([0.3, -1.2])
    rA, rB, slope = t, t + d.l * np.array([c, s]), np.array([c, s])
    e = np.concatenate([rA, slope, rB, slope])
    r, _ = _core.ancf_model_a_tangent(d, e, np.zeros(8), np.zeros(8), 0, 0, 0)
    assert np.abs(r).max() < 1e-9 * d.EA


def test_uniform_stretch_gives_axial_end_forces():
    """A straight element stretched by eps: nodal forces -+EA eps along the axis (to first
    order: Model A's K_l e with eps_A = eps_M = eps_B = eps)."""
    d = data(EA=1.0e3, EI=1.0, tip=0.0)
    eps = 1e-6
    e = np.array([0, 0, 1 + eps, 0, d.l * (1 + eps), 0, 1 + eps, 0])
    r, _ = _core.ancf_model_a_tangent(d, e, np.zeros(8), np.zeros(8), 0, 0, 0)
    assert r[0] == pytest.approx(-d.EA * eps, rel=1e-5)
    assert r[4] == pytest.approx(d.EA * eps, rel=1e-5)
    assert abs(r[1]) < 1e-12 and abs(r[5]) < 1e-12
