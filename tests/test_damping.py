"""Structural damping of the elements: Kelvin-Voigt internal damping (eta_bending,
eta_torsion, eta_axial [s]) and external viscous damping (c_ext [N s/m^2]) of the 3D pipe
element and the planar ANCF beam: tangents, the critical flow of the damped cantilever
against the continuous beam (pipeflex.references.continuous_pipe, no pipeflex
finite-element code), the energy they dissipate, and zero coefficients."""
import numpy as np
import pytest

import pipeflex as pf
from pipeflex import _core
from pipeflex.references import continuous_pipe as cp
from pipeflex.state import as_core

from helpers import assert_close_ulps, residual_columns
from helpers import assembled_matrix as matrix, assembled_residual as residual, moving_state as moving

DAMPING = dict(eta_bending=0.03, eta_torsion=0.02, eta_axial=0.01, c_ext=0.7)


def section(**damping):
    return pf.PipeSection(EI=7.0, EIz=11.0, EA=3e3, GJ=5.0, pipe_mass=1.3, fluid_mass=0.7, kv=1.1,
                          rotary_inertia=(0.02, 0.01, 0.015), **damping)


def arc(mass_flow=1.5, **damping):
    """A clamped quarter arc of three pipe elements."""
    b = pf.ModelBuilder()
    n0 = b.add_node((0.1, -0.2, 0.3))
    b.add_arc(n0, center=(0.1, 0.8, 0.3), angle=np.pi / 2, normal=(0, 0, 1), n_elements=3, section=section(**damping))
    b.clamp(n0)
    return b.build(mass_flow=mass_flow)


# ---------------------------------------------------------------------------------------
# the sections' coefficients

@pytest.mark.parametrize("name", ["eta_bending", "eta_torsion", "eta_axial", "c_ext"])
@pytest.mark.parametrize("bad", [-1e-3, np.nan, np.inf, "0.1"])
def test_bad_coefficients_are_refused_by_name(name, bad):
    with pytest.raises(ValueError, match=name):
        pf.PipeSection(EI=1.0, pipe_mass=1.0, **{name: bad})


def test_formulations_without_the_damping_refuse_it_by_name():
    from pipeflex.multibody import flexible_body
    with pytest.raises(ValueError, match="eta_bending"):
        flexible_body(length=1.0, n_elements=2, section=pf.PipeSection(EI=1.0, pipe_mass=1.0, eta_bending=0.01))
    b = pf.ModelBuilder()
    with pytest.raises(ValueError, match="eta_torsion"):
        b.add_ancf_beam((0, 0, 0), (1, 0, 0), 2, pf.PipeSection(EI=1.0, pipe_mass=1.0, eta_torsion=0.01))
    assert not pf.PipeSection(EI=1.0, pipe_mass=1.0).damped
    assert pf.PipeSection(EI=1.0, pipe_mass=1.0, c_ext=0.1).damped


# ---------------------------------------------------------------------------------------
# tangents

def test_pipe_tangents_match_differences_of_the_residual():
    """K (the damping forces' dependence on the positions at non-zero rates) and C against
    central differences of the assembled residual, with flow, on a moving curved arc."""
    model = arc(**DAMPING)
    s = moving(model)
    K, C = matrix(model, s, 1.0, 0.0), matrix(model, s, 0.0, 1.0)
    Kd = residual_columns(model, s, model.load_state(), "q", 1e-6)
    Cd = residual_columns(model, s, model.load_state(), "v", 1e-3)
    col = np.abs(K).max(axis=0)
    assert (np.abs(K - Kd).max(axis=0) / col).max() < 1e-6
    assert np.abs(C - Cd).max() <= 1e-8 * np.abs(C).max()
    # the differences can tell: the damping's own terms are far above that tolerance
    undamped = arc()
    dK, dC = K - matrix(undamped, s, 1.0, 0.0), C - matrix(undamped, s, 0.0, 1.0)
    assert (np.abs(dK).max(axis=0) / col).max() > 1e-3
    assert np.abs(dC).max() > 1e-2 * np.abs(C).max()


def test_pipe_hand_tangent_equals_forward_ad_of_the_residual():
    """The kernel's tangent (its damping part by forward AD in the virtual displacements)
    against forward AD of the templated residual, on a rotated and moving element."""
    model = arc(**DAMPING)
    d = model.core.pipe(1)
    rng = np.random.default_rng(3)
    x = model.positions
    q = np.concatenate([x[1] + 0.02 * rng.standard_normal(3), 0.3 * rng.standard_normal(3),
                        x[2] + 0.02 * rng.standard_normal(3), 0.3 * rng.standard_normal(3)])
    v, a = rng.standard_normal(12), rng.standard_normal(12)
    ld = _core.LoadState()
    ld.mass_flow = 1.5
    frames = model.initial_state().frames
    for w in ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.3, 0.7, 0.2)):
        r, J = _core.pipe_tangent(d, frames[1], frames[2], ld, q, v, a, *w)
        r_ad, J_ad = _core.pipe_tangent_ad(d, frames[1], frames[2], ld, q, v, a, *w)
        assert_close_ulps(r, r_ad, ulps=64, scale=np.abs(r).max(), what="residual")
        assert_close_ulps(J, J_ad, ulps=256, scale=np.abs(J).max(), what=f"tangent {w}")


@pytest.mark.parametrize("elastic", ["A", "0"])
def test_ancf_tangents_match_differences(elastic):
    sec = pf.PipeSection(EI=2.0, EA=4e3, pipe_mass=0.8, eta_axial=0.02, eta_bending=0.05, c_ext=0.4)
    b = pf.ModelBuilder()
    nodes = b.add_ancf_beam((0, 0, 0), (1.2, 0.3, 0), 3, sec, elastic=elastic)
    b.fix(nodes[0], ["ux", "uy"])
    model = b.build()
    s = moving(model, seed=5)
    K, C = matrix(model, s, 1.0, 0.0), matrix(model, s, 0.0, 1.0)
    Kd = residual_columns(model, s, model.load_state(), "q", 1e-6)
    Cd = residual_columns(model, s, model.load_state(), "v", 1e-3)
    assert np.abs(K - Kd).max() <= 1e-6 * np.abs(K).max()
    assert np.abs(C - Cd).max() <= 1e-8 * np.abs(C).max()
    assert np.abs(C).max() > 1.0  # the damping is there (no flow, no frame: C is all damping)


def test_linearize_sees_the_damping_and_the_modes_get_eta_omega_over_two():
    """Equal Kelvin-Voigt times on an unloaded beam: C = eta K at the reference, so every
    mode of angular frequency omega has the damping ratio eta omega / 2."""
    eta = 2e-3
    b = pf.ModelBuilder()
    n0 = b.add_node((0, 0, 0))
    b.add_line(n0, (1, 0.5, 0), 6, pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0, EA=1e4, GJ=8.0,
                                                  eta_bending=eta, eta_torsion=eta, eta_axial=eta))
    b.clamp(n0)
    lin = pf.linearize(b.build())
    K, C = (X.toarray() if hasattr(X, "toarray") else np.asarray(X) for X in (lin.K, lin.C))
    assert np.abs(C - eta * K).max() <= 1e-13 * np.abs(K).max()
    lam = pf.eigenvalues(lin).values
    lam = lam[lam.imag > 0]
    omega = np.abs(lam)
    np.testing.assert_allclose(-lam.real / omega, eta * omega / 2, rtol=1e-8)


def test_rayleigh_damping_is_alpha_m_plus_beta_k():
    """ModelBuilder.rayleigh_damping on pipe elements (no rotary inertia): C = alpha M +
    beta K at the reference, each mode's damping ratio alpha / (2 omega) + beta omega / 2,
    and a pickled model keeps it."""
    import pickle
    alpha, beta = 0.3, 1e-3
    b = pf.ModelBuilder()
    n0 = b.add_node((0, 0, 0))
    b.add_line(n0, (1, 0.5, 0), 6, pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0, EA=1e4, GJ=8.0))
    b.clamp(n0)
    b.rayleigh_damping(alpha=alpha, beta=beta)
    model = b.build()
    lin = pf.linearize(model)
    M, K, C = (X.toarray() if hasattr(X, "toarray") else np.asarray(X) for X in (lin.M, lin.K, lin.C))
    assert np.abs(C - (alpha * M + beta * K)).max() <= 1e-13 * np.abs(C).max()
    lam = pf.eigenvalues(lin).values
    lam = lam[lam.imag > 0]
    omega = np.abs(lam)
    np.testing.assert_allclose(-lam.real / omega, alpha / (2 * omega) + beta * omega / 2, rtol=1e-8)
    C2 = pf.linearize(pickle.loads(pickle.dumps(model))).C
    assert np.array_equal(C2.toarray() if hasattr(C2, "toarray") else C2, C)
    with pytest.raises(ValueError, match="beta"):
        b.rayleigh_damping(beta=-1.0)


def test_rayleigh_damping_of_ancf_beams():
    alpha, beta = 0.2, 2e-3
    for elastic in ("A", "0"):
        b = pf.ModelBuilder()
        nodes = b.add_ancf_beam((0, 0, 0), (1.0, 0.0, 0), 4, pf.PipeSection(EI=2.0, EA=4e3, pipe_mass=0.8),
                                elastic=elastic)
        b.fix(nodes[0], ["ux", "uy", "dx", "dy"])
        b.rayleigh_damping(alpha=alpha, beta=beta)
        lin = pf.linearize(b.build())
        M, K, C = (X.toarray() if hasattr(X, "toarray") else np.asarray(X) for X in (lin.M, lin.K, lin.C))
        assert np.abs(C - (alpha * M + beta * K)).max() <= 1e-12 * np.abs(C).max(), elastic


# ---------------------------------------------------------------------------------------
# the damped cantilever against the continuous beam

def cantilever(beta, *, alpha=0.0, sigma=0.0, n_elements=32):
    """The dimensionless cantilever (L = 1 m, EI = 1 N m^2, M + m = 1 kg/m): its
    eta_bending [s] is alpha and its c_ext [N s/m^2] is sigma."""
    b = pf.ModelBuilder()
    root = b.add_node((0.0, 0.0, 0.0))
    b.add_line(root, (1.0, 0.0, 0.0), n_elements,
               pf.PipeSection(EI=1.0, pipe_mass=1.0 - beta, fluid_mass=beta, eta_bending=alpha, c_ext=sigma))
    b.clamp(root)
    return b.build()


def critical_u(beta, **damping):
    # 16 scan points per flow unit: at beta = 0.7, sigma = 0.5 the second mode is unstable
    # only for u in (11.02, ~11.5), which the default 4 step over
    r = pf.critical_mass_flow(cantilever(beta, **damping), tol=1e-10, steps_per_unit=16)
    return r.mass_flow / np.sqrt(beta), r.frequency


BETAS = [0.1, 0.3, 0.5, 0.7, 0.9]
ALPHA, SIGMA = 5e-3, 0.5


@pytest.fixture(scope="module")
def continuous():
    cases = [(b, 0.0, 0.0) for b in BETAS] + [(b, ALPHA, 0.0) for b in BETAS] + [(b, 0.0, SIGMA) for b in BETAS]
    return {c: cp.critical(c[0], alpha=c[1], sigma=c[2], du=0.1) for c in cases}


def test_continuous_solver_without_damping_is_unchanged():
    # the damping arguments at zero give the undamped determinant bit for bit
    w, u, beta = 14.0 + 1.0j, 6.0, 0.4
    assert cp.delta_roots(w, u, beta, alpha=0.0, sigma=0.0) == cp.delta_roots(w, u, beta)
    assert cp.delta_transfer(w, u, beta, 10.0, 8, alpha=0.0) == cp.delta_transfer(w, u, beta, 10.0, 8)
    # and damped, its two determinants still have the same roots
    w1 = cp.eigenvalue(lambda x: cp.delta_roots(x, u, beta, alpha=0.01, sigma=0.3), 14.0 + 1.0j)
    w2 = cp.eigenvalue(lambda x: cp.delta_transfer(x, u, beta, alpha=0.01, sigma=0.3), 14.0 + 1.0j)
    assert w1 == pytest.approx(w2, rel=1e-11)
    # without flow, viscous damping sigma shifts Im omega by sigma / 2 exactly
    w0 = cp.eigenvalue(lambda x: cp.delta_roots(x, 0.0, beta), 3.5)
    ws = cp.eigenvalue(lambda x: cp.delta_roots(x, 0.0, beta, sigma=0.4), 3.5 + 0.2j)
    assert ws.imag == pytest.approx(0.2, rel=1e-10) and abs(ws) == pytest.approx(abs(w0), rel=1e-10)
    with pytest.raises(ValueError, match="alpha"):
        cp.delta_roots(w, u, beta, alpha=-1.0)


@pytest.mark.parametrize("alpha,sigma", [(ALPHA, 0.0), (0.0, SIGMA)])
def test_damped_critical_flow_matches_the_continuous_beam(continuous, alpha, sigma):
    """32 elements: 6e-7 to 2.8e-5 relative (u_cr) and up to 6.3e-5 (omega_cr) measured."""
    for beta in BETAS:
        uc, wc = continuous[(beta, alpha, sigma)]
        u, w = critical_u(beta, alpha=alpha, sigma=sigma)
        assert u == pytest.approx(uc, rel=1e-4), beta
        assert w == pytest.approx(wc, rel=1e-4), beta


def test_dissipation_destabilises_the_cantilever_where_the_continuous_beam_says(continuous):
    """Kelvin-Voigt damping alpha = 5e-3 lowers u_cr at beta >= 0.3 (by 20 % at 0.9) and
    raises it at 0.1; viscous damping sigma = 0.5 lowers it at beta = 0.7 (the second mode
    goes unstable before the undamped pipe's third), raises it elsewhere."""
    for (alpha, sigma), lower in (((ALPHA, 0.0), {0.3, 0.5, 0.7, 0.9}), ((0.0, SIGMA), {0.7, 0.9})):
        for beta in BETAS:
            damped, undamped = continuous[(beta, alpha, sigma)][0], continuous[(beta, 0.0, 0.0)][0]
            assert (damped < undamped) == (beta in lower), (alpha, sigma, beta, damped, undamped)
    # the element model shows it too
    assert critical_u(0.9, alpha=ALPHA)[0] < 0.85 * continuous[(0.9, 0.0, 0.0)][0]
    assert critical_u(0.7, sigma=SIGMA)[0] < 0.9 * continuous[(0.7, 0.0, 0.0)][0]


# ---------------------------------------------------------------------------------------
# energy

def damped_cantilever(**damping):
    b = pf.ModelBuilder()
    n0 = b.add_node((0, 0, 0))
    sec = pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0, EA=1e4, GJ=8.0,
                         rotary_inertia=(1e-2, 1e-3, 1e-3), **damping)
    nodes = b.add_line(n0, (1, 0, 0), 3, sec)
    b.clamp(n0)
    return b.build(), nodes[-1]


def test_dissipated_work_equals_the_energy_lost():
    """A large swing without flow: E(0) - E(t) equals the integral of the damping power
    v . f_d (f_d the damped minus the undamped residual at the same state), Simpson's rule
    on the states of 200 steps of 2.5 ms, to 1e-6 (measured: 7e-8)."""
    damping = dict(eta_bending=5e-3, eta_torsion=3e-3, eta_axial=2e-3, c_ext=0.5)
    model, tip = damped_cantilever(**damping)
    undamped, _ = damped_cantilever()
    # released with the lowest mode's velocity shape (large: 2 m/s at the tip), which
    # leaves the stiff modes, whose power the samples could not resolve, nearly at rest
    e = pf.eigenvalues(pf.linearize(undamped), vectors=True)
    x = e.vectors[:, np.argmin(np.abs(e.values - 1j * e.frequencies.min()))]
    shape = np.real(x / x[np.argmax(np.abs(x))])
    st = model.initial_state()
    st.v = model.basis @ (2.0 * shape / np.abs(shape).max())
    state, h, n = st, 2.5e-3, 200
    energy, power = [], []

    def sample(s, E):
        cs = as_core(model, s)
        energy.append(E)
        power.append((model.basis.T @ cs.v) @ (residual(model, cs) - residual(undamped, cs)))

    for k in range(n):
        r = pf.simulate(model, h, integrator="ida", state=state, rtol=1e-10, atol=1e-12, n_outputs=2,
                        progress=False)
        if k == 0:
            sample(st, r.energy[0])
        state = r.final_state
        sample(state, r.energy[-1])
    E, P = np.array(energy), np.array(power)
    work = h / 3 * (P[0] + 4 * P[1:-1:2].sum() + 2 * P[2:-1:2].sum() + P[-1])
    assert E[0] - E[-1] > 0.03 * E[0]  # it loses energy visibly (5 % measured)
    assert (E[0] - E[-1]) == pytest.approx(work, rel=1e-6)
    assert np.all(np.diff(E) < 0) and np.all(P > 0)


# ---------------------------------------------------------------------------------------
# zero coefficients

def test_zero_coefficients_give_the_undamped_numbers():
    """The kernels skip zero coefficients: the arrays of zeros give the residual and
    tangents of no damping arrays bit for bit; with damping, a state at rest has the
    undamped residual and K to a few ulps (the damping forces vanish with the rates)."""
    model = arc()
    s = moving(model)
    pipes = model.core  # the same model's elements, rebuilt with explicit zero coefficients
    b = pf.ModelBuilder()
    n0 = b.add_node((0.1, -0.2, 0.3))
    b.add_arc(n0, center=(0.1, 0.8, 0.3), angle=np.pi / 2, normal=(0, 0, 1), n_elements=3,
              section=section(eta_bending=0.0, eta_torsion=0.0, eta_axial=0.0, c_ext=0.0))
    b.clamp(n0)
    zero = b.build(mass_flow=1.5)
    assert np.array_equal(residual(model, s), residual(zero, s))
    assert np.array_equal(matrix(model, s, 0.3, 0.7, 0.2), matrix(zero, s, 0.3, 0.7, 0.2))
    assert pipes.pipe(0).eta_bending == 0.0 and pipes.pipe(0).c_ext == 0.0
    damped = arc(**DAMPING)
    rest = moving(model)
    rest.v = np.zeros_like(rest.v)
    r0 = residual(model, rest)
    assert_close_ulps(residual(damped, rest), r0, ulps=8, scale=np.abs(r0).max(), what="residual at rest")
    K0 = matrix(model, rest, 1.0, 0.0)
    assert_close_ulps(matrix(damped, rest, 1.0, 0.0), K0, ulps=8, scale=np.abs(K0).max(), what="K at rest")


def test_static_solution_is_not_changed_by_damping():
    x = []
    for damping in (DAMPING, {}):
        b = pf.ModelBuilder()
        n0 = b.add_node((0, 0, 0))
        nodes = b.add_line(n0, (1, 0, 0), 3, pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0, EA=1e4, GJ=8.0,
                                                            **damping))
        b.clamp(n0)
        b.add_load(nodes[-1], force=(0.0, -30.0, 10.0))
        x.append(np.asarray(pf.static_equilibrium(b.build()).state.q))
    assert_close_ulps(x[0], x[1], ulps=8, scale=1.0, what="static coordinates")


# ---------------------------------------------------------------------------------------
# modal damping of floating-frame bodies

def test_ffrf_body_modes_get_their_damping_ratios():
    """A body held at its centre (its floating frame): the system's modes are the body's
    frame-held modes, and each gets the ratio given (one for all, or one per mode)."""
    from pipeflex.multibody import MultibodyBuilder, flexible_body
    sec = pf.PipeSection(EI=10.0, EA=1e4, GJ=8.0, pipe_mass=1.0, fluid_mass=0.5, rotary_inertia=(1e-3, 1e-4, 1e-4))
    undamped = flexible_body(length=1.0, n_elements=8, section=sec, internal_modes=2)
    m = undamped.basis.shape[1]
    zetas = (0.02, np.linspace(0.0, 0.1, m))
    for zeta in zetas:
        body = flexible_body(length=1.0, n_elements=8, section=sec, internal_modes=2, modal_damping=zeta)
        mb = MultibodyBuilder()
        i = mb.add_body(body, position=(0.0, 0.0, 0.0))
        mb.fix(i, "center")
        e = pf.eigenvalues(pf.linearize(mb.build()))
        lam = e.values[np.isfinite(e.values) & (np.abs(e.values) > 1e-6)]
        lam = lam[lam.imag > 0]
        # the frame-held modes of (K_eta, M_eta), ascending, and the ratios in that order;
        # (frequency, ratio) pairs compared sorted (equal frequencies: the two bending planes)
        w = np.sqrt(sla_eigh(undamped.data.K, undamped.data.M[6:, 6:]))
        expected = np.full(m, zeta) if np.ndim(zeta) == 0 else np.asarray(zeta)
        got = sorted(zip(np.round(np.abs(lam), 6), -lam.real / np.abs(lam)))
        want = sorted(zip(np.round(w, 6), expected))
        assert len(got) == m
        np.testing.assert_allclose(np.array(got), np.array(want), rtol=1e-8, atol=1e-9)
    assert body.data.D.shape == (m, m) and undamped.data.D.size == 0
    # pickling keeps the damping
    import pickle
    assert np.array_equal(pickle.loads(pickle.dumps(body)).data.D, body.data.D)
    # without rotary inertia the torsion is massless: no damping for it, the rest finite
    light = flexible_body(length=1.0, n_elements=8, section=pf.PipeSection(EI=10.0, pipe_mass=1.0),
                          modal_damping=0.05)
    assert np.all(np.isfinite(light.data.D)) and np.abs(light.data.D).max() > 0.0
    with pytest.raises(ValueError, match="modal_damping"):
        flexible_body(length=1.0, n_elements=8, section=sec, modal_damping=-0.1)
    with pytest.raises(ValueError, match="modal_damping"):
        flexible_body(length=1.0, n_elements=8, section=sec, modal_damping=[0.1, 0.2])


def sla_eigh(K, M):
    import scipy.linalg as sla
    return sla.eigh(K, M, eigvals_only=True)
