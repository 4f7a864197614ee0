"""One linearisation for constrained systems (pipeflex.analysis.constrained): bodies and
coupled element + body models, from the core's linear_matrices on the equations
interface: one null-space linearisation."""
import numpy as np
import pytest

import pipeflex as pf
from pipeflex.multibody import MultibodyBuilder, flexible_body, static_equilibrium

SEC = pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0, EA=1e5, rotary_inertia=(1e-3, 1e-3, 1e-3))


def arm(clamped, mass_flow, tip_force=0.0):
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    nodes = b.add_line(n0, (1.0, 0.0, 0.0), 8, SEC)
    if tip_force:
        b.add_load(nodes[-1], force=(0.0, tip_force, 0.0))
    if clamped:
        b.clamp(n0)
    return b.build(mass_flow=mass_flow, floating=not clamped), n0


def on_stiff_hub(mass_flow, stiffness=1e6, tip_force=0.0):
    """The arm rigidly joined to a short stiff body clamped to the ground (the body's EI
    ``stiffness`` times that of a body as compliant as the arm)."""
    floating, n0 = arm(False, mass_flow, tip_force)
    mb = MultibodyBuilder()
    mu = 3 * 10.0 / 0.2**3
    hub = pf.PipeSection(EI=stiffness * mu, pipe_mass=mu, rotary_inertia=(1.0, 1.0, 1.0))
    j = mb.add_body(flexible_body(length=0.2, n_elements=2, section=hub), position=(-0.1, 0.0, 0.0))
    mb.fix(j, "start")
    cs = pf.CoupledSystem(floating, mb.build())
    cs.rigid(n0, j, "end")
    return cs


def lowest(eig, k):
    v = np.asarray(eig.values)
    v = v[v.imag > 0]
    return v[np.argsort(v.imag)][:k]


@pytest.mark.parametrize("mass_flow", [10.0, 25.0])
def test_cantilever_on_a_stiff_clamped_hub_has_the_clamped_cantilevers_eigenvalues(mass_flow):
    """The arm on a stiff hub body (itself clamped) vibrates, with the flow's damping, as
    the arm clamped to the ground: the four lowest eigenvalues agree to 1e-8 (2.4e-9: the
    hub's compliance, 1e-6 of the arm's; 8e-7 with a basis orthonormal in q, its
    round-off)."""
    alone, _ = arm(True, mass_flow)
    expected = lowest(pf.eigenvalues(pf.linearize(alone, pf.static_equilibrium(alone).state)), 4)
    cs = on_stiff_hub(mass_flow)
    lin = pf.linearize(cs)
    assert isinstance(lin, pf.coupled.CoupledLinearization)
    assert lin.K.shape == (cs.n_coordinates - cs.n_constraints,) * 2
    assert np.abs(cs.core_couplings()[0][4] - np.eye(3)).max() < 1e-12
    got = lowest(pf.eigenvalues(lin), 4)
    assert np.allclose(got, expected, rtol=1e-8, atol=0)


def test_null_space_basis_eliminates_in_the_stiffness_metric():
    """null_space_basis(C_q, K): a sparse T (CSC) with C_q T = 0, the rank that of C_q
    although the tied stiff coordinate's column is 1e-10 of the others in the metric; a
    joint tying a 1e20 N/m coordinate to a 1 N/m one leaves a reduced stiffness of the
    soft coordinates' scale, regular (an orthonormal basis in q gave a mix that is
    singular to round-off)."""
    from pipeflex.analysis.constrained import null_space_basis
    import scipy.sparse as sp

    k = np.array([1e20, 1.0, 2.0, 1.0])
    K = sp.csc_matrix(np.diag(k) + np.diag([0.0, -0.5, -0.5], 1) + np.diag([0.0, -0.5, -0.5], -1))
    Cq = np.array([[1.0, -1.0, 0.0, 0.0]])  # coordinate 1 moves with the stiff 0
    T = null_space_basis(sp.csc_matrix(Cq), K)
    assert sp.isspmatrix_csc(T) and T.shape == (4, 3)
    T = T.toarray()
    assert np.abs(Cq @ T).max() <= 1e-15
    Kr = T.T @ (K @ T)
    assert np.linalg.cond(Kr) < 1e3
    assert np.array_equal(null_space_basis(np.zeros((0, 3))).toarray(), np.eye(3))


def test_coupled_linearization_is_regular_and_symmetric_without_flow():
    """The cantilever on a stiff clamped hub: the reduced stiffness is as well conditioned as
    the clamped cantilever's (no false mechanism: pf.stability answers)."""
    from pipeflex.analysis.eigen import stiffness_conditioning

    cs = on_stiff_hub(10.0)
    lin = pf.linearize(cs)
    alone, _ = arm(True, 10.0)
    clamped = pf.eigenvalues(pf.linearize(alone, pf.static_equilibrium(alone).state))
    assert stiffness_conditioning(pf.eigenvalues(lin)) > 0.5 * stiffness_conditioning(clamped)  # 6.5e-5, both
    # symmetric mass, and without flow a symmetric stiffness and no damping
    assert abs(lin.M - lin.M.T).max() <= 1e-12 * abs(lin.M).max()
    still = pf.linearize(cs, mass_flow=0.0)
    assert abs(still.K - still.K.T).max() <= 1e-9 * abs(still.K).max()
    assert abs(still.C).max() <= 1e-12 * abs(still.K).max()
    assert pf.stability(pf.eigenvalues(still)) == "stable"


def test_bodies_linearization_equals_the_dense_evaluation():
    """pipeflex.multibody.linearize (the core's sparse linear_matrices) equals the reduction
    of the system's dense tangent evaluations (the route it replaced) to round-off."""
    system = pf.scenes.ffrf_cantilever_pipe(n_bodies=4, elements_per_body=4, tip_force=1.5)
    st = static_equilibrium(system, mass_flow=20.0).state
    lin = pf.linearize(system, st, mass_flow=20.0)
    T = lin.basis
    _, _, J, K = system.evaluate(st, mass_flow=20.0, wK=1.0)
    C = system.evaluate(st, mass_flow=20.0, wK=0.0, wC=1.0)[3]
    M = system.evaluate(st, mass_flow=20.0, wK=0.0, wM=1.0)[3]
    assert np.abs(J @ T).max() <= 1e-10 * np.abs(J).max()
    for dense, reduced in ((M, lin.M), (C, lin.C), (K, lin.K)):
        R = reduced.toarray()
        assert np.abs(T.T @ dense @ T - R).max() <= 1e-12 * np.abs(R).max()


def test_bad_state_is_refused():
    cs = on_stiff_hub(10.0)
    with pytest.raises(TypeError, match="CoupledStatic"):
        pf.linearize(cs, object())


def test_coupled_static_warm_start_from_another_flow():
    """static_equilibrium(system, state=...) starts from a CoupledStatic (both parts and the
    multipliers): from the equilibrium at 10 kg/s to 12 kg/s it reaches the cold start's
    equilibrium (1.5 N tip force); from its own equilibrium it stops at once."""
    cs = on_stiff_hub(10.0, 1e4, tip_force=1.5)
    ten = pf.static_equilibrium(cs, mass_flow=10.0)
    cold = pf.static_equilibrium(cs, mass_flow=12.0)
    warm = pf.static_equilibrium(cs, state=ten, mass_flow=12.0)
    assert np.allclose(warm.state.q, cold.state.q, rtol=0, atol=1e-9)
    assert np.allclose(warm.body_state.lam, cold.body_state.lam, rtol=1e-7, atol=1e-9)
    again = pf.static_equilibrium(cs, state=cold, mass_flow=12.0)
    assert again.iterations <= 1
    with pytest.raises(TypeError, match="CoupledStatic"):
        pf.static_equilibrium(cs, state=cold.state)


def test_a_mixing_basis_gives_garbage_that_its_noise_covers():
    """A basis that mixes a 1e20 N/m coordinate into the soft ones' columns (an orthonormal
    basis rotated in the null space) leaves the soft eigenvalues garbage (against 0.89j and
    1.49j: a spurious divergence, +-20.7 and +-18.2j on one CPU, 5.8 on another with AVX-512:
    the garbage is the CPU's rounding), within their noise (~eps 1e20 / omega), so
    classify() counts no growth; the stiffness-metric basis gives the right eigenvalues at
    round-off."""
    import scipy.linalg as sla
    import scipy.sparse as sp
    from pipeflex.analysis.constrained import ConstrainedLinearization, null_space_basis, reduce
    from pipeflex.analysis.eigen import classify

    k = np.array([1e20, 1e20, 2.0, 1.0])
    K = sp.csc_matrix(np.diag(k) + np.diag([0.0, -0.5, -0.5], 1) + np.diag([0.0, -0.5, -0.5], -1))
    M, C = sp.identity(4, format="csc"), sp.csc_matrix((4, 4))
    Cq = sp.csc_matrix(np.array([[1.0, -1.0, 0.0, 0.0]]))
    Q = sla.qr(np.random.default_rng(1).standard_normal((3, 3)))[0]

    def linearization(T):
        return ConstrainedLinearization(*reduce(T, M, C, K), 0.0, None, T, (abs(M), abs(C), abs(K)))

    mixed = linearization(sla.null_space(Cq.toarray()) @ Q)
    eig = pf.eigenvalues(mixed, vectors=True)
    i = int(np.argmax(eig.values.real))
    assert 1.0 < eig.values[i].real < eig.noise[i]  # the spurious divergence, within its noise
    assert mixed.reduction_noise(eig.values[i], eig.vectors[:, i])[0] > 1e2  # the reduction's bound sees it too
    assert classify(eig) == "stable"
    metric = pf.eigenvalues(linearization(null_space_basis(Cq, K)))
    assert np.allclose(np.sort(np.abs(metric.values)), [0.89044552, 0.89044552, 1.48563346, 1.48563346])
    assert np.all(metric.values.real == 0.0) and metric.noise.max() < 1e-12


def test_reduction_noise_of_the_cantilever_on_a_stiff_hub(monkeypatch):
    """The reduction's componentwise bound on the lowest eigenvalue (4.1 rad/s) of the
    cantilever on a stiff hub at 10 kg/s: ~1e-4 1/s with a basis orthonormal in q (it
    mixes the hub's 1e20 N/m into the arm's columns; the eigen-solver's own bound, 2e-11,
    does not see that), ~5e-10 in the stiffness metric."""
    import scipy.linalg as sla
    from pipeflex.analysis import constrained

    def lowest_bound():
        lin = pf.linearize(on_stiff_hub(10.0))
        eig = pf.eigenvalues(lin, vectors=True)
        i = int(np.argmin(np.abs(eig.values)))
        return lin.reduction_noise(eig.values[i], eig.vectors[:, i])[0], eig.noise[i]

    metric, solver = lowest_bound()
    assert metric < 1e-8 and solver < 1e-9
    monkeypatch.setattr(constrained, "null_space_basis", lambda Cq, K=None: sla.null_space(Cq.toarray(), rcond=1e-10))
    orthonormal, solver = lowest_bound()
    assert orthonormal > 1e-6 > 1e3 * solver


def test_the_reduction_bound_joins_the_noise_where_growth_is_judged():
    """with_reduction_noise: an eigenvalue growing beyond the eigen-solver's bound but
    within the reduction's (a 1e20 N/m coordinate in its basis column, 1e-5 of it) counts
    as zero; an element model's linearisation (no unreduced matrices) is left alone."""
    import scipy.sparse as sp
    from pipeflex.analysis.constrained import ConstrainedLinearization
    from pipeflex.analysis.eigen import EigenResult, classify, with_reduction_noise

    one = sp.csc_matrix(np.ones((1, 1)))
    T = np.array([[1.0], [1e-5]])
    lin = ConstrainedLinearization(one, 0 * one, one, 0.0, None, T,
                                   (sp.csc_matrix(np.eye(2)), sp.csc_matrix((2, 2)), sp.csc_matrix(np.diag([1.0, 1e20]))))
    eig = EigenResult(np.array([1e-7 + 1j, 1e-7 - 1j]), np.array([1e-12, 1e-12]), np.ones((1, 2), complex),
                      np.zeros(2, int))
    assert classify(eig) == "flutter"
    joined = with_reduction_noise(eig, lin, None)
    bound = 2 * np.finfo(float).eps * (1 + 1e20 * 1e-10 + 1.0) / 2  # N eps y^T(|lam|^2|M| + |K|)y / |2 lam|
    assert joined.noise == pytest.approx([bound, bound], rel=1e-12)
    assert classify(joined) == "stable"
    assert with_reduction_noise(eig, pf.linearize(pf.scenes.cantilever_pipe(n_elements=2)), None) is eig
