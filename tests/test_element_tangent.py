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
    assert np.array_equal(J, 2.0 * _core.pipe_mass_matrix(data, fp, fq, q))  # exact: the same M, times 2


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


@pytest.mark.parametrize("kind,end_terms,frames", itertools.product(["straight", "curved"], [True, False], FRAMES))
@pytest.mark.parametrize("mass_flow_rate,kv", [(-0.7, 1.0), (0.0, 1.0), (0.0, 0.0)])
def test_fluid_power_is_minus_v_dot_fluid_forces(kind, end_terms, frames, mass_flow_rate, kv, rng):
    # the transients' fluid work integrates this power: it is the forces' power, formed
    # without the forces (its Coriolis part from the ends' velocities alone)
    data, q0 = element(kind, shear=True, rotary=True, fluid_end_terms=end_terms)
    data.kv = kv
    q, v, a = state(q0, rng, "large", True)
    fp, fq = FRAMES[frames]
    ld = load(mass_flow=2.5, mass_flow_rate=mass_flow_rate, gravity=(0.3, -9.81, 1.0))
    expected = -float(v @ _core.pipe_fluid_forces(data, fp, fq, ld, q, v))
    power = _core.pipe_fluid_power(data, fp, fq, ld, q, v)
    if kv == 0.0 and mass_flow_rate == 0.0 and not end_terms:
        # Coriolis forces and the momentum fluxes through both ends: a gyroscopic pair, no power
        assert abs(power) <= 1e-13 * np.abs(v).max() ** 2 * 2.5
    else:
        assert abs(expected) > 1.0
    assert abs(power - expected) <= 1e-13 * np.abs(v).max() * np.abs(_core.pipe_fluid_forces(data, fp, fq, ld, q, v)).max() * 12
    assert _core.pipe_fluid_power(data, fp, fq, load(gravity=(0.3, -9.81, 1.0)), q, v) == 0.0


def stresses_of(data, fp, fq, q):
    """The generalised stresses (6) at q [N, N m]: pipe_predicted_stresses along no increment."""
    return _core.pipe_predicted_stresses(data, fp, fq, q, np.zeros(12))


@pytest.mark.parametrize("kind,shear,frames", itertools.product(["straight", "curved"], [False, True], FRAMES))
def test_predicted_stresses_are_the_linearised_stresses(kind, shear, frames, rng):
    """pipe_predicted_stresses(q, dq) = sigma(q) + d sigma/dq dq: against central
    differences of the stresses along dq (error O(h^2))."""
    data, q0 = element(kind, shear=shear)
    q, _, _ = state(q0, rng, "large", False)
    dq = 0.1 * rng.standard_normal(12)
    fp, fq = FRAMES[frames]
    h = 1e-5
    fd = (stresses_of(data, fp, fq, q + h * dq) - stresses_of(data, fp, fq, q - h * dq)) / (2 * h)
    expected = stresses_of(data, fp, fq, q) + fd
    assert_close(_core.pipe_predicted_stresses(data, fp, fq, q, dq), expected, 1e-7)
    # zero at the stress-free reference
    assert np.abs(stresses_of(data, *FRAMES["identity"], q0)).max() < 1e-9


@pytest.mark.parametrize("kind,shear,phi,frames", itertools.product(["straight", "curved"], [False, True],
                                                                   ["zero", "large"], FRAMES))
def test_geometric_stresses_change_only_the_geometric_tangent(kind, shear, phi, frames, rng):
    """The tangent with given geometric stresses sigma_g differs from the state's own by
    the Hessian of c . eps(q) with c = sigma_g - sigma(q) held fixed (the strains'
    second derivatives weighted by the stress change), against second central
    differences of pipe_strains; the residual is unchanged, and sigma_g = sigma(q) gives
    the tangent itself."""
    data, q0 = element(kind, shear=shear)
    q, v, a = state(q0, rng, phi, True)
    fp, fq = FRAMES[frames]
    ld = load(mass_flow=2.5, gravity=(0.3, -9.81, 1.0))
    own = stresses_of(data, fp, fq, q)
    c = 50.0 * rng.standard_normal(6)
    r0, J0 = _core.pipe_tangent(data, fp, fq, ld, q, v, a, 1.0, 0.4, 0.2)
    r1, J1 = _core.pipe_tangent(data, fp, fq, ld, q, v, a, 1.0, 0.4, 0.2, sigma_geometric=own + c)
    rs, Js = _core.pipe_tangent(data, fp, fq, ld, q, v, a, 1.0, 0.4, 0.2, sigma_geometric=own)
    assert_close(r1, r0, 1e-15)
    assert_close(Js, J0, 1e-12)

    # strains (pipe_strains: eps - eps0; the same Hessian) times the stress change
    def s(x):
        return c @ _core.pipe_strains(data, fp, fq, x)
    h = 1e-4
    H = np.zeros((12, 12))
    E = np.eye(12) * h
    for i in range(12):
        for j in range(12):
            H[i, j] = (s(q + E[i] + E[j]) - s(q + E[i] - E[j]) - s(q - E[i] + E[j]) + s(q - E[i] - E[j])) / (4 * h * h)
    assert_close(J1 - J0, H, 1e-6)
