"""Physics checks of the 3D pipe/beam element (seed 000): tangents, rigid motion, mass."""
import numpy as np
import pytest

from helpers import element, load, residual, tangent
from pipeflex import _core

CASES = [("straight", False, False), ("curved", False, False), ("curved", True, True)]


def random_state(q0, rng, scale=0.3):
    q = q0 + scale * rng.standard_normal(12) * np.r_[0.2, 0.2, 0.2, 1, 1, 1, 0.2, 0.2, 0.2, 1, 1, 1]
    v = rng.standard_normal(12)
    a = rng.standard_normal(12)
    return q, v, a


def fd_jacobian(f, x, h=1e-6):
    J = np.zeros((12, 12))
    for j in range(12):
        e = np.zeros(12)
        e[j] = h
        J[:, j] = (f(x + e) - f(x - e)) / (2 * h)
    return J


@pytest.mark.parametrize("kind,shear,rotary", CASES)
def test_tangents_match_finite_differences(kind, shear, rotary, rng):
    data, q0 = element(kind, shear=shear, rotary=rotary)
    q, v, a = random_state(q0, rng)
    ld = load(mass_flow=2.5, mass_flow_rate=-0.7, gravity=(0.3, -9.81, 1.0))
    frames = (_core.rotation_exp([0.4, -1.0, 2.0]), _core.rotation_exp([-2.5, 0.3, 0.1]))
    r = lambda qq, vv, aa: residual(data, qq, vv, aa, ld, frames)  # noqa: E731
    K = tangent(data, q, v, a, ld, 1, 0, 0, frames)
    C = tangent(data, q, v, a, ld, 0, 1, 0, frames)
    M = tangent(data, q, v, a, ld, 0, 0, 1, frames)
    K_fd = fd_jacobian(lambda x: r(x, v, a), q)
    C_fd = fd_jacobian(lambda x: r(q, x, a), v)
    M_fd = fd_jacobian(lambda x: r(q, v, x), a)
    for J, J_fd in ((K, K_fd), (C, C_fd), (M, M_fd)):
        assert np.max(np.abs(J - J_fd)) <= 1e-6 * np.max(np.abs(J_fd))
    # the weighted tangent is the weighted sum
    W = tangent(data, q, v, a, ld, 0.3, -1.7, 2.9, frames)
    assert np.allclose(W, 0.3 * K - 1.7 * C + 2.9 * M, rtol=1e-13, atol=1e-12 * np.abs(W).max())
    assert np.allclose(M, _core.pipe_mass_matrix(data, frames[0], frames[1], q), rtol=1e-14, atol=0)


def rigid_motion(q0, R, t):
    phi = np.array(_rotation_vector(R))
    return np.concatenate([R @ q0[:3] + t, phi, R @ q0[6:9] + t, phi])


def _rotation_vector(R):
    angle = np.arccos(np.clip((np.trace(R) - 1) / 2, -1, 1))
    w = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    return w / (2 * np.sin(angle)) * angle


@pytest.mark.parametrize("kind", ["straight", "curved"])
def test_rigid_motion_gives_zero_strain_and_force(kind):
    data, q0 = element(kind, shear=True)
    R = _core.rotation_exp(2.6 * np.array([0.48, -0.6, 0.64]))  # a large rotation (149 degrees)
    q = rigid_motion(q0, R, np.array([3.0, -1.0, 0.5]))
    assert np.allclose(_core.pipe_strains(data, np.eye(3), np.eye(3), q), 0.0, atol=1e-13)
    r = residual(data, q, np.zeros(12), np.zeros(12), load())
    assert np.max(np.abs(r)) < 1e-9 * 7.0  # EI = 7: forces scale as EI/l^2
    # the same through the reference frames (re-based rotations): still zero
    qb = q.copy()
    qb[3:6] = qb[9:12] = 0.0
    rb = residual(data, qb, np.zeros(12), np.zeros(12), load(), (R, R))
    assert np.max(np.abs(rb)) < 1e-9 * 7.0


def test_deformation_gives_nonzero_strain():
    data, q0 = element("straight")
    q = q0.copy()
    q[11] += 0.01  # bend the outlet end
    assert np.max(np.abs(_core.pipe_strains(data, np.eye(3), np.eye(3), q))) > 1e-4


@pytest.mark.parametrize("kind", ["straight", "curved"])
def test_mass_of_rigid_translation_is_element_mass(kind):
    data, q0 = element(kind)
    M = _core.pipe_mass_matrix(data, np.eye(3), np.eye(3), q0)
    mass = (data.pipe_mass + data.fluid_mass) * data.l0
    for d in np.eye(3):
        u = np.concatenate([d, np.zeros(3), d, np.zeros(3)])
        assert u @ M @ u == pytest.approx(mass, rel=1e-14)
    assert np.allclose(M, M.T, atol=1e-15 * np.abs(M).max())
    assert np.min(np.linalg.eigvalsh(M)) > -1e-14 * np.abs(M).max()


def test_split_form_plus_kink_forces_equals_unsplit():
    """Eqs. 19-20 in split form plus the forces of eqs. 21-22 at both ends = unsplit form."""
    rng = np.random.default_rng(3)
    unsplit, q0 = element("curved")
    split, _ = element("curved", fluid_end_terms=False)
    q, v, a = random_state(q0, rng)
    mdot = 3.0
    ld = load(mass_flow=mdot)
    P = unsplit.kv * mdot**2 / unsplit.fluid_mass
    Ep = _core.rotation_exp(q[3:6]) @ unsplit.offset_p
    Eq = _core.rotation_exp(q[9:12]) @ unsplit.offset_q
    F_in = mdot * v[0:3] + P * Ep[:, 0]     # eq. 22 at the inlet
    F_out = -mdot * v[6:9] - P * Eq[:, 0]   # eq. 21 at the outlet
    applied = np.concatenate([F_in, np.zeros(3), F_out, np.zeros(3)])
    r_u = residual(unsplit, q, v, a, ld)
    r_s = residual(split, q, v, a, ld)
    assert np.allclose(r_u, r_s - applied, rtol=0, atol=1e-12 * np.abs(r_u).max())


def test_convective_angular_acceleration_is_the_rate_of_the_jacobian(rng):
    """d/dt[T(phi)] phi_dot along phi(t) = phi + t phi_dot, against central differences of
    T, from near the identity (the coefficients' series) to large angles."""
    for scale in (0.0, 1e-5, 1e-2, 0.5, 3.0):
        phi = scale * rng.standard_normal(3)
        phid = rng.standard_normal(3)
        h = 1e-5 * max(1.0, scale)
        dT = (_core.rotation_jacobian(phi + h * phid) - _core.rotation_jacobian(phi - h * phid)) / (2 * h)
        expected = dT @ phid
        got = _core.convective_angular_acceleration(phi, phid)
        assert np.allclose(got, expected, rtol=0, atol=1e-8 * max(1.0, np.abs(expected).max())), scale
    # rotation about a fixed axis: T phi_dot = phi_dot, no convective part
    axis = rng.standard_normal(3)
    assert np.allclose(_core.convective_angular_acceleration(0.7 * axis, 2.0 * axis), 0.0, atol=1e-14)


def test_rotation_jacobian_is_derivative_of_exp(rng):
    for scale in (1e-4, 0.5, 3.0):
        phi = scale * rng.standard_normal(3)
        R = _core.rotation_exp(phi)
        assert np.allclose(R @ R.T, np.eye(3), atol=1e-15)
        T = _core.rotation_jacobian(phi)
        h = 1e-6
        for k in range(3):
            e = np.zeros(3)
            e[k] = h
            dR = (_core.rotation_exp(phi + e) - _core.rotation_exp(phi - e)) / (2 * h)
            W = dR @ R.T  # skew(T e_k)
            w = np.array([W[2, 1], W[0, 2], W[1, 0]])
            assert np.allclose(w, T[:, k], atol=1e-9)
