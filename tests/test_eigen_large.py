"""A few eigenvalues of large models: the sparse shift-invert path of pf.eigenvalues."""
import numpy as np
import pytest
import scipy.sparse as sp

import pipeflex as pf
from pipeflex.analysis.eigen import SPARSE_MIN_DOFS

#: beta_n L of a clamped-free Euler-Bernoulli beam: roots of 1 + cos(x) cosh(x) = 0.
BETA_L = np.array([1.8751040687119611, 4.694091132974175])


def _lowest(eig, k):
    """The k smallest distinct angular frequencies [rad/s] (the planes repeat them)."""
    w = np.unique(np.round(np.sort(eig.frequencies), 9))
    return w[:k]


def _compare(lin, k, sigma=None):
    sparse = pf.eigenvalues(lin, n_modes=k, sigma=sigma, method="sparse")
    dense = pf.eigenvalues(lin, n_modes=k, sigma=sigma, method="dense")
    assert len(sparse.values) == len(dense.values) >= k
    for lam in sparse.values:  # the order within a conjugate pair is arbitrary
        assert np.min(np.abs(dense.values - lam)) <= 1e-9 * abs(lam)
    for lam in dense.values:
        assert np.min(np.abs(sparse.values - lam)) <= 1e-9 * abs(lam)
    return sparse, dense


def test_sparse_equals_dense_with_flow():
    """Cantilever with flow (damped, gyroscopic C; massless torsion block): 24 elements,
    so that the bending blocks (48 coordinates) go through ARPACK, not the dense fallback."""
    lin = pf.linearize(pf.scenes.cantilever_pipe(n_elements=24), mass_flow=20.0)
    sparse, dense = _compare(lin, 8)
    assert sparse.static_negative == dense.static_negative == 0
    # the nearest to a complex target (e.g. the flutter eigenvalue being tracked)
    _compare(lin, 3, sigma=-0.5 + 14.0j)


def test_sparse_equals_dense_regular_mass():
    """Rotary inertia about the axis: every block's mass matrix is regular."""
    m = pf.scenes.cantilever_pipe(n_elements=24, polar_inertia=1e-3)
    lin = pf.linearize(m, mass_flow=10.0)
    assert np.linalg.matrix_rank(lin.M.toarray()) == m.n_dofs
    _compare(lin, 10)


@pytest.mark.parametrize("mass_flow", [0.0, 15.0])
def test_sparse_equals_dense_singular_mass(mass_flow):
    """Lumped translational mass, massless rotations: M singular inside the bending
    blocks. Dense: condensation (no flow, C = 0) or QZ (flow, C acts on rotations);
    sparse: the pencil (A - sigma B)^-1 B needs only T(sigma) regular."""
    lin = pf.linearize(pf.scenes.cantilever_pipe(n_elements=24), mass_flow=mass_flow)
    n = lin.M.shape[0]
    lumped = np.zeros(n)
    trans = np.arange(n) % 6 < 3
    lumped[trans] = np.asarray(lin.M.sum(axis=1)).ravel()[trans]
    lin = pf.Linearization(sp.diags(lumped).tocsc(), lin.C, lin.K, lin.mass_flow, lin.state)
    sparse, dense = _compare(lin, 6)
    assert np.all(np.isfinite(sparse.values))


def test_small_model_default_unchanged():
    """Nothing set: all eigenvalues by the dense method; n_modes on a small model selects
    from the same dense result (exact: the same LAPACK call on the same matrices)."""
    lin = pf.linearize(pf.scenes.cantilever_pipe(n_elements=8), mass_flow=20.0)
    full = pf.eigenvalues(lin)
    assert len(full.values) == 2 * 2 * 16 + 2 * 8  # two bending planes + axial
    few = pf.eigenvalues(lin, n_modes=4)
    near = full.values[np.argsort(np.abs(full.values))[:4]]
    np.testing.assert_array_equal(np.sort_complex(few.values), np.sort_complex(near))


def test_bad_options():
    lin = pf.linearize(pf.scenes.cantilever_pipe(n_elements=2))
    with pytest.raises(ValueError, match="n_modes"):
        pf.eigenvalues(lin, sigma=1.0)
    with pytest.raises(ValueError, match="n_modes"):
        pf.eigenvalues(lin, n_modes=0)
    with pytest.raises(ValueError, match="method"):
        pf.eigenvalues(lin, n_modes=2, method="arpack")


def test_large_clamped_free_beam_frequencies():
    """1024 elements (6144 coordinates, sparse by default): the two lowest bending
    frequencies of the beam without flow are omega = (beta L)^2 sqrt(EI / (m L^4)),
    m = pipe_mass + fluid_mass. The discretisation error is ~1e-15 at this size; what
    is left is round-off, ~N^4 eps (2.6e-6 for omega_1, 7e-9 for omega_2), and must lie
    within the reported round-off bound ``noise``."""
    L, EI, mp, mf = 1.5, 7.0, 3.0, 1.0
    m = pf.scenes.cantilever_pipe(n_elements=1024, length=L, EI=EI, pipe_mass=mp, fluid_mass=mf)
    assert m.n_dofs >= SPARSE_MIN_DOFS
    eig = pf.eigenvalues(pf.linearize(m, mass_flow=0.0), n_modes=8, vectors=True)
    assert len(eig.values) == 8 and np.all(np.isfinite(eig.values))
    assert np.all(np.abs(eig.values.real) <= eig.noise)  # undamped: on the imaginary axis
    exact = BETA_L**2 * np.sqrt(EI / ((mp + mf) * L**4))
    w = _lowest(eig, 2)
    assert np.all(np.abs(w / exact - 1) < 1e-5)
    for wk, ex in zip(w, exact):
        i = np.argmin(np.abs(eig.values - 1j * wk))
        assert abs(wk - ex) <= eig.noise[i]
    # mode shapes: the transverse displacement of the first mode grows monotonically to the tip
    v = eig.vectors[:, np.argmin(np.abs(eig.values - 1j * w[0]))]
    uy = v[1::6] if np.abs(v[1::6]).max() > np.abs(v[2::6]).max() else v[2::6]
    uy = np.abs(uy / uy[np.argmax(np.abs(uy))])
    assert np.all(np.diff(uy) > -1e-9) and uy[-1] == pytest.approx(1.0)


def test_critical_flow_1024_elements():
    """1024 elements: no ConvergenceError, flutter at the seed's flow within the
    round-off of this size (the crossing eigenvalue's real part is only determined to
    ~1e-4 1/s, the flow to ~1e-5 relative; see docs/performance.md)."""
    from pipeflex.seeds.seed000 import references as ref000

    r = pf.critical_mass_flow(pf.scenes.cantilever_pipe(n_elements=1024))
    assert r.kind == "flutter"
    assert r.frequency == pytest.approx(13.7147, rel=3e-5)
    assert r.mass_flow == pytest.approx(ref000.TABLE2_EXTRAPOLATED, rel=2e-5)


def test_many_eigenvalues_of_an_undamped_beam(monkeypatch):
    """40 eigenvalues of an 80-element ANCF beam (two undamped blocks, 320 coordinates
    each, frequencies 3.5 to 4000 rad/s): the shift-invert operator on the unscaled
    state [x; lambda x] stalled ARPACK here (7274 solves with T(sigma), 1.4 s; 52 000 at
    320 elements); on [x; mu x / tau] with tau ~ |mu_k| it takes a few per eigenvalue.
    The values are those of the dense path."""
    from pipeflex.analysis import eigen

    solves = [0]
    shift_factor = eigen._shift_factor

    def counted(T, sigma):
        Ts, lu = shift_factor(T, sigma)

        class Counted:
            def solve(self, b):
                solves[0] += 1
                return lu.solve(b)
        return Ts, Counted()

    monkeypatch.setattr(eigen, "_shift_factor", counted)
    beam = pf.scenes.rotating_cantilever(n_elements=80)
    lin = pf.linearize(beam, beam.initial_state())
    sparse = pf.eigenvalues(lin, n_modes=40, method="sparse")
    assert 0 < solves[0] <= 2 * 6 * 42  # two blocks, kk = 42 wanted each
    dense = pf.eigenvalues(lin, n_modes=40, method="dense")
    assert len(sparse.values) == len(dense.values) == 40
    for lam in sparse.values:
        assert np.min(np.abs(dense.values - lam)) <= 1e-9 * abs(lam)


def _blocks(n_elements, mass_flow):
    from pipeflex.analysis.eigen import split_blocks

    model = pf.scenes.cantilever_pipe(n_elements=n_elements)
    lin = pf.linearize(model, pf.static_equilibrium(model, mass_flow=mass_flow).state, mass_flow=mass_flow)
    return split_blocks(lin.K, lin.C, lin.M, sparse=True)


def test_proved_stable_blocks_of_a_pipe_with_flow():
    """The energy proof (K, M positive definite, C's symmetric part semi-definite): every
    block with mass without flow (this pipe's torsion has none: no dynamics to prove);
    with flow the axial block (the outflow damps it: C_sym >= 0), not the bending blocks
    (the flow's follower terms make K unsymmetric). Where proved, the computed spectrum
    agrees: no eigenvalue grows beyond its round-off."""
    from pipeflex.analysis.eigen import block_eigenvalues, proved_stable

    assert [proved_stable(b) for b in _blocks(24, 0.0)] == [True, True, True, False]
    blocks = _blocks(24, 30.0)  # beyond the critical flow (~25 kg/s): bending flutters
    assert [proved_stable(b) for b in blocks] == [True, False, False, False]
    for b in blocks[:3]:
        p = proved_stable(b)
        dense = type(b)(b.dofs, *(X.toarray() for X in (b.K, b.C, b.M)))
        lam, noise, _, _ = block_eigenvalues(dense)
        assert p == bool(np.all(lam.real <= noise)), len(b.dofs)


def test_proved_stable_refuses_what_the_proof_does_not_cover():
    """Each condition can fail: negative damping (C_sym not semi-definite), a negative
    stiffness, an unsymmetric stiffness, a singular (not definite) mass."""
    from pipeflex.analysis.eigen import Block, proved_stable

    axial = next(b for b in _blocks(24, 10.0) if b.C.nnz and proved_stable(b))
    K, C, M = (sp.csc_matrix(X) for X in (axial.K, axial.C, axial.M))
    n = K.shape[0]
    e = sp.csc_matrix(([1.0], ([n - 1], [n - 1])), shape=(n, n))
    assert not proved_stable(Block(axial.dofs, K, C - 2.0 * abs(C).max() * e, M))
    assert not proved_stable(Block(axial.dofs, K - 2.0 * abs(K).max() * e, C, M))
    skew = sp.csc_matrix(([1e-3 * abs(K).max()], ([0], [1])), shape=(n, n))
    assert not proved_stable(Block(axial.dofs, K + skew, C, M))
    assert not proved_stable(Block(axial.dofs, K, C, M - M.diagonal()[-1] * e))


def test_critical_flow_scan_skips_only_proved_blocks():
    """The large-model scan leaves the proved-stable blocks out (no Arnoldi run on the
    axial block): the same flow as with every block analysed, to the tolerance."""
    import pipeflex.analysis.critical as critical
    from pipeflex.analysis import eigen

    model = pf.scenes.cantilever_pipe(n_elements=64)
    assert model.n_dofs >= SPARSE_MIN_DOFS
    fast = pf.critical_mass_flow(model)
    full = eigen.sparse_eigen_from_blocks

    def every_block(*args, unstable_only=False, **kw):
        return full(*args, unstable_only=False, **kw)

    critical.sparse_eigen_from_blocks = every_block
    try:
        slow = pf.critical_mass_flow(model)
    finally:
        critical.sparse_eigen_from_blocks = full
    assert fast.kind == slow.kind == "flutter"
    assert fast.mass_flow == pytest.approx(slow.mass_flow, rel=1e-12)
    assert fast.frequency == pytest.approx(slow.frequency, rel=1e-10)
