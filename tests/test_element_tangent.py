"""The hand-derived element tangent against the AD one, and the fluid-forces kernel."""
import itertools

import numpy as np
import pytest

from helpers import element, load
from pipeflex import _core

WEIGHTS = {"K": (1.0, 0.0, 0.0), "C": (0.0, 1.0, 0.0), "M": (0.0, 0.0, 1.0), "mix": (0.3, -1.7, 2.9)}
FRAMES = {"identity": (np.eye(3), np.eye(3)),
          "rotated": (_core.rotation_exp([0.4, -1.0, 2.0]), _core.rotation_exp([-2.5, 0.3, 0.1]))}


# |phi| ranges [rad]: small uses the series branch of T's coefficients (|phi| < 0.1), edge
# straddles the switch to the trigonometric branch, large goes up to 1.
PHI_SIZES = {"zero": (0.0, 0.0), "small": (0.01, 0.05), "edge": (0.0995, 0.1005), "large": (0.2, 1.0)}


def random_rotation_vector(rng, lo, hi):
    """A rotation vector of random direction and magnitude in [lo, hi] [rad]."""
    d = rng.standard_normal(3)
    return d / np.linalg.norm(d) * rng.uniform(lo, hi)


def state(q0, rng, phi, moving):
    q = q0 + 0.05 * rng.standard_normal(12) * np.r_[1, 1, 1, 0, 0, 0, 1, 1, 1, 0, 0, 0]
    lo, hi = PHI_SIZES[phi]
    if hi > 0.0:
        q[3:6] = random_rotation_vector(rng, lo, hi)
        q[9:12] = random_rotation_vector(rng, lo, hi)
    v = rng.standard_normal(12) if moving else np.zeros(12)
    a = rng.standard_normal(12)
    return q, v, a


def assert_close(A, B, rel):
    scale = max(np.abs(B).max(), 1e-300)
    assert np.abs(A - B).max() <= rel * scale, np.abs(A - B).max() / scale


@pytest.mark.parametrize("kind,shear,rotary,phi,moving,frames,end_terms",
                         itertools.product(["straight", "curved"], [False, True], [False, True],
                                           PHI_SIZES, [False, True], FRAMES, [True, False]))
def test_hand_tangent_equals_ad(kind, shear, rotary, phi, moving, frames, end_terms, rng):
    data, q0 = element(kind, shear=shear, rotary=rotary, fluid_end_terms=end_terms)
    q, v, a = state(q0, rng, phi, moving)
    ld = load(mass_flow=2.5, mass_flow_rate=-0.7, gravity=(0.3, -9.81, 1.0))
    fp, fq = FRAMES[frames]
    for wK, wC, wM in WEIGHTS.values():
        r, J = _core.pipe_tangent(data, fp, fq, ld, q, v, a, wK, wC, wM)
        r_ad, J_ad = _core.pipe_tangent_ad(data, fp, fq, ld, q, v, a, wK, wC, wM)
        assert_close(J, J_ad, 1e-11)
        assert_close(r, r_ad, 1e-13)


@pytest.mark.parametrize("mass_flow,mass_flow_rate,gravity", [(0.0, 0.0, (0, 0, 0)), (0.0, 1.3, (0, 0, -9.81)),
                                                              (-4.0, 0.0, (0, 0, 0))])
def test_hand_tangent_equals_ad_other_loads(mass_flow, mass_flow_rate, gravity, rng):
    data, q0 = element("curved", shear=True, rotary=True)
    data.flow_factor = 0.8
    q, v, a = state(q0, rng, "large", True)
    ld = load(mass_flow=mass_flow, mass_flow_rate=mass_flow_rate, gravity=gravity)
    ld.gravity_factor = 0.6
    fp, fq = FRAMES["rotated"]
    for wK, wC, wM in WEIGHTS.values():
        r, J = _core.pipe_tangent(data, fp, fq, ld, q, v, a, wK, wC, wM)
        r_ad, J_ad = _core.pipe_tangent_ad(data, fp, fq, ld, q, v, a, wK, wC, wM)
        assert_close(J, J_ad, 1e-11)
        assert_close(r, r_ad, 1e-13)


def test_tangent_without_matrix_or_with_mass_only(rng):
    data, q0 = element("curved", rotary=True)
    q, v, a = state(q0, rng, "large", True)
    ld = load(mass_flow=2.5, gravity=(0, 0, -9.81))
    fp, fq = FRAMES["rotated"]
    r_ad, _ = _core.pipe_tangent_ad(data, fp, fq, ld, q, v, a, 1.0, 0.0, 0.0)
    r, J = _core.pipe_tangent(data, fp, fq, ld, q, v, a, 0.0, 0.0, 2.0)
    assert_close(r, r_ad, 1e-13)
    assert np.array_equal(J, 2.0 * _core.pipe_mass_matrix(data, fp, fq, q))


@pytest.mark.parametrize("kind,end_terms,frames", itertools.product(["straight", "curved"], [True, False], FRAMES))
def test_fluid_forces_are_the_flow_part_of_the_residual(kind, end_terms, frames, rng):
    data, q0 = element(kind, shear=True, rotary=True, fluid_end_terms=end_terms)
    q, v, a = state(q0, rng, "large", True)
    fp, fq = FRAMES[frames]
    with_flow = load(mass_flow=2.5, mass_flow_rate=-0.7, gravity=(0.3, -9.81, 1.0))
    without = load(gravity=(0.3, -9.81, 1.0))
    r1, _ = _core.pipe_tangent(data, fp, fq, with_flow, q, v, a, 0.0, 0.0, 0.0)
    r0, _ = _core.pipe_tangent(data, fp, fq, without, q, v, a, 0.0, 0.0, 0.0)
    f = _core.pipe_fluid_forces(data, fp, fq, with_flow, q, v)
    assert np.abs(f).max() > 1.0
    assert np.abs(f - (r1 - r0)).max() <= 1e-12 * np.abs(r1).max()
    assert np.array_equal(_core.pipe_fluid_forces(data, fp, fq, without, q, v), np.zeros(12))
