"""The geometric stiffness of the fluid acceleration's axial force in a floating-frame body.

A body's linear elasticity has no geometric stiffness of its own; the fluid's acceleration
(mdot' [kg/s^2]) loads the pipe with an axial force N(s) = mu_f sddot (s - s0) (N' = mdot'
along the flow, s0 where the pipe may slide axially), and the kernel adds its energy
1/2 int N (u_y'^2 + u_z'^2) ds on the elastic coordinates (Gs0, Gs1) and the moment of the
load on the deformed lever arm (Ua). The tongue it makes right: tests/test_parametric_bodies.py.
"""
import numpy as np
import pytest
import scipy.linalg as sla

import pipeflex as pf
from pipeflex.analysis import parametric
from pipeflex.multibody import MultibodyBuilder, flexible_body
from pipeflex.rotation import rotation_exp

EPS = np.finfo(float).eps
SECTION = pf.PipeSection(EI=10.0, EA=2.5e4, GJ=8.0, pipe_mass=8.0, fluid_mass=2.0, rotary_inertia=(1e-3, 0.0, 0.0))


def _motion(body, rng, sddot):
    n = body.n_coordinates
    return dict(R=rotation_exp(0.3 * rng.standard_normal(3)), omega=rng.standard_normal(3),
                a=rng.standard_normal(n), eta=0.05 * rng.standard_normal(n - 6),
                eta_dot=rng.standard_normal(n - 6), sdot=1.5, sddot=sddot, gravity=np.zeros(3))


def test_slope_integrals_are_the_lateral_slopes_energy():
    body = flexible_body(length=1.0, n_elements=8, section=SECTION, reduction="full")
    # a lateral shape u_y = a s^2 / 2 (nodal u_y, theta_z = u_y'), u_z = b s^3 / 3 (theta_y =
    # -u_z'), both still at the centre node (the frame's)
    s = body.nodes_s
    u = np.zeros(6 * len(s))
    a, b = 0.3, -0.2
    u[1::6], u[5::6] = 0.5 * a * s ** 2, a * s
    u[2::6], u[4::6] = b * s ** 3 / 3, -b * s ** 2
    c = body.n_elements // 2
    eta = np.delete(u, np.r_[6 * c:6 * c + 6])  # the full basis: every node but the centre
    # int (u_y'^2 + u_z'^2) ds and int s (...) ds over s in [-1/2, 1/2] (cubic Hermite: exact)
    assert eta @ body.data.Gs0 @ eta == pytest.approx(a ** 2 / 12 + b ** 2 / 80, rel=1e-12)
    assert eta @ body.data.Gs1 @ eta == pytest.approx(0.0, abs=1e-14)
    g0, g1 = pf._core.beam_slope_integrals(0.5)
    w = np.zeros(12)
    w[1], w[5], w[7], w[11] = 0.0, 1.0, 0.5, 1.0  # u_y = s on [0, 0.5]
    assert w @ g0 @ w == pytest.approx(0.5, rel=1e-12) and w @ g1 @ w == pytest.approx(0.125, rel=1e-12)


@pytest.mark.parametrize("curvature", [0.0, 1.2])
def test_rate_terms_tangent_matches_finite_differences(rng, curvature):
    body = flexible_body(length=0.8, n_elements=6, section=SECTION, internal_modes=3, curvature=curvature)
    mo = _motion(body, rng, sddot=2.5)
    n, h = body.n_coordinates, 1e-6
    d = body.data

    def rate_part(**changes):
        """The residual's part proportional to sddot (the rest cancels exactly)."""
        m = dict(mo, **changes)
        r1 = d.forces(**m, rate_force_zero=0.35, tangent=False)[0]
        r0 = d.forces(**dict(m, sddot=0.0), rate_force_zero=0.35, tangent=False)[0]
        return r1 - r0

    T = d.forces(**mo, rate_force_zero=0.35)[1] - d.forces(**dict(mo, sddot=0.0), rate_force_zero=0.35)[1]
    fd = np.zeros((n, n))
    for k in range(3):  # frame rotation on the group: R <- exp(dpi~) R
        e = np.zeros(3)
        e[k] = h
        fd[:, 3 + k] = (rate_part(R=rotation_exp(e) @ mo["R"]) - rate_part(R=rotation_exp(-e) @ mo["R"])) / (2 * h)
    for k in range(n - 6):
        e = np.zeros(n - 6)
        e[k] = h
        fd[:, 6 + k] = (rate_part(eta=mo["eta"] + e) - rate_part(eta=mo["eta"] - e)) / (2 * h)
    scale = np.abs(T).max()
    np.testing.assert_allclose(T[:, 3:], fd[:, 3:], rtol=0, atol=1e-7 * scale)
    # the rate's geometric stiffness is there (the elastic block changes with s0)
    T2 = d.forces(**mo, rate_force_zero=-0.35)[1] - d.forces(**dict(mo, sddot=0.0), rate_force_zero=-0.35)[1]
    np.testing.assert_allclose((T2 - T)[6:, 6:], 2.5 * SECTION.fluid_mass * 0.7 * d.Gs0,
                               rtol=0, atol=64 * EPS * scale)


def test_steady_flow_is_untouched(rng):
    body = flexible_body(length=0.8, n_elements=6, section=SECTION, internal_modes=3)
    mo = _motion(body, rng, sddot=0.0)
    r0, t0 = body.data.forces(**mo, rate_force_zero=0.0)
    r1, t1 = body.data.forces(**mo, rate_force_zero=0.4)
    np.testing.assert_array_equal(r0, r1)  # the rate's terms are skipped, not added as zeros
    np.testing.assert_array_equal(t0, t1)


def _chain(n_bodies, *, held_outlet=False, reverse=False, slide_outlet=False):
    L = 1.0 / n_bodies
    body = flexible_body(length=L, n_elements=4, section=SECTION)
    b = MultibodyBuilder()
    ids = [b.add_body(body, position=((k + 0.5) * L, 0.0, 0.0), flow_factor=-1.0 if reverse else 1.0)
           for k in range(n_bodies)]
    for j0, j1 in zip(ids, ids[1:]):
        b.rigid(j0, "end", j1, "start")
    inlet, outlet = (ids[-1], "end") if reverse else (ids[0], "start"), (ids[0], "start") if reverse else \
        (ids[-1], "end")
    b.fix(*inlet)
    if held_outlet:
        b.fix(*outlet)
    if slide_outlet:
        b.roller(*outlet, (0.0, 1.0, 0.0))  # held laterally only: the outlet slides
    return b


def test_the_builder_places_the_axial_force_zero_on_the_flow_path():
    L = 0.25
    # a cantilever: N vanishes at the free outlet, the last body's end (s0 = L/2 there)
    np.testing.assert_allclose(_chain(4)._rate_force_zeros(), [3.5 * L, 2.5 * L, 1.5 * L, 0.5 * L])
    np.testing.assert_allclose(_chain(4, slide_outlet=True)._rate_force_zeros(), [3.5 * L, 2.5 * L, 1.5 * L, 0.5 * L])
    # both ends held: at mid-path (one EA)
    np.testing.assert_allclose(_chain(4, held_outlet=True)._rate_force_zeros(), [1.5 * L, 0.5 * L, -0.5 * L, -1.5 * L],
                               atol=1e-15)
    # the flow from the last body's end to the first's start (flow_factor -1): the outlet is
    # body 0's start, s = -L/2
    np.testing.assert_allclose(_chain(4, reverse=True)._rate_force_zeros(), [-0.5 * L, -1.5 * L, -2.5 * L, -3.5 * L])


@pytest.mark.parametrize("n_bodies", [1, 4])
def test_the_rate_softens_a_cantilever_as_the_element_model(n_bodies):
    # the driver's linearisations about the equilibrium moved quasi-statically by the rate, at
    # mdot = 0: N = -mdot' (L - x) compresses the cantilever (Leipholz's column under a
    # tangential load q = mdot' per length, which flutters at q L^3 / EI = 40)
    if n_bodies == 1:
        chain = MultibodyBuilder()
        j = chain.add_body(flexible_body(length=1.0, n_elements=8, section=SECTION, internal_modes=6),
                           position=(0.5, 0.0, 0.0))
        chain.fix(j, "start")
    else:
        chain = _chain(n_bodies)
    eb = pf.ModelBuilder()
    root = eb.add_node((0.0, 0.0, 0.0))
    eb.add_line(root, (1.0, 0.0, 0.0), 16, SECTION)
    eb.clamp(root)
    rate = 100.0  # [kg/s^2]: q L^3 / EI = 10
    effect = {}
    for name, model in (("bodies", chain.build()), ("elements", eb.build())):
        flow = parametric._FlowModel(model, 0.0)
        w = []
        for r in (0.0, rate):
            M, _, K = flow.sample(0.0, r)
            lam = sla.eigvals(K, M)
            w.append(np.sqrt(np.sort(lam.real[np.isfinite(lam) & (lam.real > 1e-6)]))[0])
        effect[name] = w[1] / w[0] - 1.0
    # omega_1 rises towards its coalescence with omega_2 (measured: the elements +0.2008,
    # one body +0.2013, 4 bodies +0.2001)
    assert 0.1 < effect["elements"] < 0.3
    assert effect["bodies"] == pytest.approx(effect["elements"], rel=0.02)
