"""The pipe element kernels' shortcuts give the values of their general paths: a polar-only
rotary inertia (E Jb E^T x as J_x e_x (e_x . x)) in the residual, against the general path
(bending inertias far below the round-off) and the hand tangent; an identity end offset (no
R_ref R_offset product), against the same end triads formed the other way round."""
import numpy as np

from helpers import assert_close_ulps, element, load
from pipeflex import _core

WEIGHTS = (1.0, 0.4, 0.2)


def moving_state(q0, rng):
    q = q0.copy()
    q[3:6] = 0.3 * rng.standard_normal(3)
    q[9:12] = 0.3 * rng.standard_normal(3)
    return q, rng.standard_normal(12), rng.standard_normal(12)


def residual(data, fp, fq, ld, q, v, a):
    r, _ = _core.pipe_tangent(data, fp, fq, ld, q, v, a, 0.0, 0.0, 0.0)  # pipe_residual's path
    return r


def test_polar_rotary_inertia_equals_the_general_path(rng):
    data, q0 = element("curved")
    fp, fq = _core.rotation_exp([0.4, -1.0, 2.0]), _core.rotation_exp([-2.5, 0.3, 0.1])
    ld = load(mass_flow=2.5, gravity=(0.0, 0.0, -9.81))
    for _ in range(5):
        q, v, a = moving_state(q0, rng)
        data.rotary_inertia = [0.0, 0.0, 0.0]
        r_none = residual(data, fp, fq, ld, q, v, a)
        data.rotary_inertia = [0.02, 0.0, 0.0]
        r_polar = residual(data, fp, fq, ld, q, v, a)
        # bending inertias far below the round-off: the general E Jb E^T path, the same sums
        data.rotary_inertia = [0.02, 1e-300, 1e-300]
        r_general = residual(data, fp, fq, ld, q, v, a)
        assert_close_ulps(r_polar, r_general, ulps=2, scale=np.abs(r_general).max(), what="residual")
        assert np.abs(r_polar - r_none).max() > 1e-6 * np.abs(r_polar).max()  # the inertia acts
        # the hand tangent (its own E Jb E^T) against the derivatives of the polar path
        data.rotary_inertia = [0.02, 0.0, 0.0]
        r, J = _core.pipe_tangent(data, fp, fq, ld, q, v, a, *WEIGHTS)
        r_ad, J_ad = _core.pipe_tangent_ad(data, fp, fq, ld, q, v, a, *WEIGHTS)
        assert np.abs(r - r_ad).max() <= 1e-13 * np.abs(r_ad).max()
        assert np.abs(J - J_ad).max() <= 1e-11 * np.abs(J_ad).max()


def test_identity_offset_equals_the_offset_product(rng):
    # E = exp(phi) R_ref R_offset: (R_ref = F, R_offset = I) skips the product that
    # (R_ref = I, R_offset = F) forms; both give the same triads, residual and tangent
    data, q0 = element("straight", rotary=True)
    F = data.offset_p @ _core.rotation_exp([0.2, -0.1, 0.3])
    G = data.offset_q @ _core.rotation_exp([-0.3, 0.2, 0.1])
    ld = load(mass_flow=2.5, mass_flow_rate=-0.7, gravity=(0.3, 0.0, -9.81))
    q, v, a = moving_state(q0, rng)
    data.offset_p, data.offset_q = np.eye(3), np.eye(3)
    r1, J1 = _core.pipe_tangent(data, F, G, ld, q, v, a, *WEIGHTS)
    data.offset_p, data.offset_q = F, G
    r2, J2 = _core.pipe_tangent(data, np.eye(3), np.eye(3), ld, q, v, a, *WEIGHTS)
    assert_close_ulps(r1, r2, ulps=4, scale=np.abs(r2).max(), what="residual")
    assert_close_ulps(J1, J2, ulps=4, scale=np.abs(J2).max(), what="tangent")
