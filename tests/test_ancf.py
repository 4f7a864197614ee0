"""Planar ANCF beam, elastic Model A (seed 002): the appendix matrices, tangents, rigid
motion, both elastic models."""
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


G0 = np.zeros(2)


F0 = np.zeros(4)  # inertial frame


def tangent(d, e, a=np.zeros(8), *, v=np.zeros(8), g=G0, frame=F0, wK=1.0, wC=0.0, wM=0.0):
    return _core.ancf_tangent(d, e, v, a, g, frame, wK, wC, wM)


def residual(d, e, a=np.zeros(8), g=G0, **kw):
    return tangent(d, e, a, g=g, **kw)[0]


def generic_e(d, seed=5):
    rng = np.random.default_rng(seed)
    return np.array([0.1, -0.2, 0.95, 0.2, 0.1 + d.l * 0.97, -0.05, 0.9, -0.3]) + 0.01 * rng.standard_normal(8)


@pytest.mark.parametrize("model", ["A", "0"])
def test_tangent_matches_finite_differences(model):
    d = data()
    d.elastic = model
    e = generic_e(d)
    a = np.random.default_rng(1).standard_normal(8)
    r0, K = tangent(d, e, a)
    _, W = tangent(d, e, a, wK=0.5, wM=2.0)
    h = 1e-7
    K_fd = np.column_stack([(residual(d, e + h * np.eye(8)[j], a) - residual(d, e - h * np.eye(8)[j], a)) / (2 * h)
                            for j in range(8)])
    assert np.abs(K - K_fd).max() <= 1e-6 * np.abs(K_fd).max()
    assert np.allclose(W, 0.5 * K + 2.0 * _core.ancf_model_a_matrix(d, 4), rtol=1e-13, atol=1e-9)


def test_model_0_force_is_the_energy_gradient():
    """Model 0 is conservative: Q = dU/de (central differences of the energy). (Model A is
    not derived from a potential: its reported energy is a diagnostic.)"""
    d = data()
    d.elastic = "0"
    e = generic_e(d, seed=2)
    h = 1e-6
    U = lambda x: _core.ancf_energies(d, x, np.zeros(8))[1]
    grad = np.array([(U(e + h * np.eye(8)[j]) - U(e - h * np.eye(8)[j])) / (2 * h) for j in range(8)])
    Q = residual(d, e)
    assert np.abs(grad - Q).max() <= 1e-6 * np.abs(Q).max()


def test_kinetic_energy_and_gravity_sum_to_the_element_mass():
    d = data(tip=0.0)
    e = np.array([0, 0, 1, 0, d.l, 0, 1, 0.0])
    v = np.array([2.0, -1.0, 0, 0, 2.0, -1.0, 0, 0])  # translation
    T, U = _core.ancf_energies(d, e, v)
    m = d.mass * d.l
    assert T == pytest.approx(0.5 * m * 5.0, rel=1e-13)
    assert U == pytest.approx(0.0, abs=1e-12)
    f = -residual(d, e, g=np.array([0.0, -9.81]))
    assert f[1] + f[5] == pytest.approx(-9.81 * m, rel=1e-13)
    assert abs(f[0]) + abs(f[4]) < 1e-12 * d.EA


@pytest.mark.parametrize("model", ["A", "0"])
@pytest.mark.parametrize("angle", [0.0, 0.7, 2.5])
def test_rigid_motion_gives_zero_elastic_force(angle, model):
    d = data()
    d.elastic = model
    c, s = np.cos(angle), np.sin(angle)
    t = np.array([0.3, -1.2])
    rA, rB, slope = t, t + d.l * np.array([c, s]), np.array([c, s])
    e = np.concatenate([rA, slope, rB, slope])
    assert np.abs(residual(d, e)).max() < 1e-9 * d.EA
    assert abs(_core.ancf_energies(d, e, np.zeros(8))[1]) < 1e-12 * d.EA


@pytest.mark.parametrize("model", ["A", "0"])
def test_uniform_stretch_gives_axial_end_forces(model):
    """A straight element stretched by eps: nodal forces -+EA eps along the axis (to first
    order: Model A's K_l e with eps_A = eps_M = eps_B = eps)."""
    d = data(EA=1.0e3, EI=1.0, tip=0.0)
    d.elastic = model
    eps = 1e-6
    e = np.array([0, 0, 1 + eps, 0, d.l * (1 + eps), 0, 1 + eps, 0])
    r = residual(d, e)
    assert r[0] == pytest.approx(-d.EA * eps, rel=1e-5)
    assert r[4] == pytest.approx(d.EA * eps, rel=1e-5)
    assert abs(r[1]) < 1e-12 and abs(r[5]) < 1e-12


def test_models_agree_for_small_deformation_without_prestress():
    """About the straight, unstressed reference both models have the same transverse
    (bending) stiffness; their axial stiffnesses differ (Model A interpolates the strain
    from eps_A, eps_M, eps_B)."""
    K = {}
    for model in ("A", "0"):
        d = data()
        d.elastic = model
        e = np.array([0, 0, 1, 0, d.l, 0, 1, 0.0])
        K[model] = tangent(d, e)[1]
    y = [1, 3, 5, 7]
    assert np.allclose(K["A"][np.ix_(y, y)], K["0"][np.ix_(y, y)], rtol=1e-9, atol=1e-9 * np.abs(K["A"]).max())
    x = [0, 2, 4, 6]
    assert np.allclose(K["A"][np.ix_(x, x)], K["0"][np.ix_(x, x)], rtol=2e-2, atol=2e-2 * np.abs(K["A"]).max())


def test_geometric_stiffness_is_the_strain_part_of_the_tangent():
    """Model A: K(e0 + t de) - K(e0) = t (G(de) + the strain-gradient terms); for a pure
    stretch de of a straight element the change is G(de) alone to first order along the
    transverse coordinates."""
    d = data(tip=0.0)
    e0 = np.array([0, 0, 1, 0, d.l, 0, 1, 0.0])
    de = np.array([0, 0, 1, 0, d.l, 0, 1, 0.0]) * 1e-3  # uniform stretch eps = 1e-3
    G = _core.ancf_geometric_stiffness(d, e0, de)
    KA, KM, KB = (_core.ancf_model_a_matrix(d, k) for k in range(3))
    assert np.allclose(G, 1e-3 * (KA + KM + KB), rtol=1e-12, atol=1e-12 * np.abs(KM).max())
    K0 = tangent(d, e0)[1]
    K1 = tangent(d, e0 + de)[1]
    y = [1, 3, 5, 7]
    assert np.allclose((K1 - K0)[np.ix_(y, y)], G[np.ix_(y, y)], rtol=1e-2, atol=1e-6 * np.abs(G).max())


def test_co_rotating_frame_terms_and_their_tangents():
    """In a frame turning at w with w_dot, a point fixed in the inertial frame has e_dot =
    -w S (e - c) and e_ddot from the kinematics; the fictitious forces must cancel
    M e_ddot then. The tangents match finite differences in e and e_dot."""
    d = data(tip=0.0)
    e = generic_e(d, seed=3)
    rng = np.random.default_rng(4)
    v, a = rng.standard_normal(8), rng.standard_normal(8)
    frame = np.array([2.5, -0.7, 0.3, -0.2])
    _, K = tangent(d, e, a, v=v, frame=frame)
    _, C = tangent(d, e, a, v=v, frame=frame, wK=0.0, wC=1.0)
    h = 1e-7
    I = np.eye(8)
    K_fd = np.column_stack([(residual(d, e + h * I[j], a, v=v, frame=frame) -
                             residual(d, e - h * I[j], a, v=v, frame=frame)) / (2 * h) for j in range(8)])
    # the residual is linear in e_dot: a unit difference is exact up to round-off
    C_fd = np.column_stack([(residual(d, e, a, v=v + I[j], frame=frame) -
                             residual(d, e, a, v=v - I[j], frame=frame)) / 2 for j in range(8)])
    assert np.abs(K - K_fd).max() <= 1e-6 * np.abs(K_fd).max()
    assert np.abs(C - C_fd).max() <= 1e-6 * np.abs(C_fd).max()
    # rigid body at rest in the inertial frame, seen from a frame turning at constant w:
    # e_rel(t) = R(-w t) e_in, so e_dot = -w S (e - c), e_ddot = -w^2 (e - c)
    w = 1.7
    c = np.array([0.3, -0.2])
    ang = 0.4
    cs, sn = np.cos(ang), np.sin(ang)
    rA = c + np.array([0.5, 0.1])
    sl = np.array([cs, sn])
    e = np.concatenate([rA, sl, rA + d.l * sl, sl])
    cc = np.array([c[0], c[1], 0, 0, c[0], c[1], 0, 0])
    S = np.kron(np.eye(4), np.array([[0, -1], [1, 0]]))
    edot = -w * S @ (e - cc)
    eddot = -w**2 * (e - cc)
    r = residual(d, e, eddot, v=edot, frame=np.array([w, 0.0, c[0], c[1]]))
    assert np.abs(r).max() < 1e-9 * d.mass * w**2
