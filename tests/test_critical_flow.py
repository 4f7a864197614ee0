"""Critical mass flows: seed 000 Tables 1 and 2, and the analytic divergence flow."""
import numpy as np
import pytest

import pipeflex as pf
from helpers import u_tube
from pipeflex.convergence import observed_order, richardson
from pipeflex.seeds.seed000 import references as ref000, validation


@pytest.mark.parametrize("n", sorted(ref000.TABLE1))
def test_table1_simply_supported(n):
    """Seed 000, Table 1 (1, 2, 4, 8, 16 elements): 8 significant digits."""
    r = pf.critical_mass_flow(pf.scenes.simply_supported_pipe(n_elements=n))
    assert r.kind == "divergence"
    assert r.frequency == 0.0
    assert r.mass_flow == pytest.approx(ref000.TABLE1[n], rel=validation.TOL_TABLE1)


def test_table1_one_element_is_sqrt3():
    """One element: P = 12 EI / L^2 exactly, i.e. mdot = sqrt(3) for the seed's data."""
    r = pf.critical_mass_flow(pf.scenes.simply_supported_pipe(n_elements=1), tol=1e-12)
    assert r.mass_flow == pytest.approx(np.sqrt(3.0), rel=1e-12)


@pytest.mark.parametrize("n", sorted(ref000.TABLE2))
def test_table2_cantilever(n):
    """Seed 000, Table 2 (2..32 elements): within 2e-7; flutter (Hopf)."""
    r = pf.critical_mass_flow(pf.scenes.cantilever_pipe(n_elements=n))
    assert r.kind == "flutter"
    assert r.frequency > 0
    assert abs(r.eigenvalue.real) < 1e-8 * abs(r.eigenvalue)
    assert r.mass_flow == pytest.approx(ref000.TABLE2[n], rel=validation.TOL_TABLE2)


def test_table2_extrapolated_and_order_four():
    """Seed 000, Table 2 'extrapolated' 25.005520 within 2e-6; observed order ~4."""
    n = [4, 8, 16, 32]
    f = [pf.critical_mass_flow(pf.scenes.cantilever_pipe(n_elements=k)).mass_flow for k in n]
    ext = richardson(f[-2], f[-1])
    assert ext == pytest.approx(ref000.TABLE2_EXTRAPOLATED, rel=validation.TOL_TABLE2_EXTRAPOLATED)
    order = observed_order(n[:-1], np.abs(np.array(f[:-1]) - ext))
    assert order[-1] == pytest.approx(4.0, abs=0.5)


def test_divergence_flow_converges_to_euler_column_with_order_four():
    """Other data: mdot_cr = (pi/L) sqrt(rho_f A_f EI / k_v) as the mesh is refined."""
    L, EI, mf, kv = 2.0, 3.0, 0.5, 4.0 / 3.0
    exact = np.pi / L * np.sqrt(mf * EI / kv)
    n = [2, 4, 8, 16]
    f = np.array([pf.critical_mass_flow(pf.scenes.simply_supported_pipe(
        n_elements=k, length=L, EI=EI, pipe_mass=1.5, fluid_mass=mf, kv=kv)).mass_flow for k in n])
    err = np.abs(f - exact) / exact
    assert np.all(np.diff(err) < 0)
    assert err[-1] < 2e-6
    assert np.all(np.abs(observed_order(n, err) - 4.0) < 0.3)


def test_critical_flow_meets_rtol():
    m = pf.scenes.cantilever_pipe(n_elements=4)
    a = pf.critical_mass_flow(m, tol=1e-6).mass_flow
    b = pf.critical_mass_flow(m, tol=1e-12).mass_flow
    assert abs(a - b) <= 1e-6 * b
    # just below stable, just above flutter
    lo = pf.eigenvalues(pf.linearize(m, mass_flow=b * (1 - 1e-7)))
    hi = pf.eigenvalues(pf.linearize(m, mass_flow=b * (1 + 1e-7)))
    assert pf.stability(lo) == "stable"
    assert pf.stability(hi) == "flutter"


def test_no_instability_in_range_is_reported():
    m = pf.scenes.cantilever_pipe(n_elements=2)
    with pytest.raises(pf.ConvergenceError, match="no instability"):
        pf.critical_mass_flow(m, mass_flow_max=10.0)


def test_table2_cantilever_128_elements_converges_with_order_four():
    """128 elements (768 coordinates: the sparse path). No ConvergenceError (Newton's
    tolerance follows the round-off level of the size), and order-4 convergence holds
    on 32, 64, 128: the differences shrink ~16-fold (observed 15.7), and the 128-element
    flow is within ~2.4e-8 of the seed's extrapolated 25.005520 (itself truncated, 2.2e-8
    low; the 64/128 Richardson value is 25.00552055)."""
    r = pf.critical_mass_flow(pf.scenes.cantilever_pipe(n_elements=128))
    assert r.kind == "flutter"
    assert abs(r.eigenvalue.real) < 1e-8 * abs(r.eigenvalue)
    assert r.mass_flow == pytest.approx(ref000.TABLE2_EXTRAPOLATED, rel=4e-8)
    f32 = pf.critical_mass_flow(pf.scenes.cantilever_pipe(n_elements=32)).mass_flow
    f64 = pf.critical_mass_flow(pf.scenes.cantilever_pipe(n_elements=64)).mass_flow
    order = np.log2((f32 - f64) / (f64 - r.mass_flow))
    assert order == pytest.approx(4.0, abs=0.1)
    ext = richardson(f64, r.mass_flow)
    assert abs(r.mass_flow - ext) < 1e-7  # kg/s: 128 elements are converged to ~2e-9 relative


def test_sparse_tracking_at_256_elements_agrees_with_128():
    """The crossing eigenpair followed by Newton on the sparse blocks (no Arnoldi per
    step), its residual compensated (refine_eigenpair): 256 elements give 128's flow to
    the discretisation error between them, ~2e-9 relative (order 4; without the
    compensated residual the crossing's round-off band at 256 elements is +-6e-8)."""
    r128 = pf.critical_mass_flow(pf.scenes.cantilever_pipe(n_elements=128))
    r256 = pf.critical_mass_flow(pf.scenes.cantilever_pipe(n_elements=256))
    assert r256.kind == "flutter"
    assert r256.mass_flow == pytest.approx(r128.mass_flow, rel=4e-9)
    assert r256.frequency == pytest.approx(r128.frequency, abs=1e-7)


def _crossing_block(n, mdot=25.2):
    """The bending block of the n-element cantilever holding its crossing eigenvalue."""
    from pipeflex.analysis.eigen import split_blocks

    lin = pf.linearize(pf.scenes.cantilever_pipe(n_elements=n), mass_flow=mdot)
    return max(split_blocks(lin.K, lin.C, lin.M, sparse=True), key=lambda b: len(b.dofs))


def _equivalent_copies(block, count, *, rescale, dense=False):
    """Copies of ``block`` with the same eigenvalues: symmetrically permuted and, with
    ``rescale``, congruent by a diagonal that is no power of two (every entry rounded)."""
    import scipy.sparse as sp
    from pipeflex.analysis.eigen import Block

    n = len(block.dofs)
    rng = np.random.default_rng(7)
    for _ in range(count):
        P = sp.eye(n, format="csc")[rng.permutation(n)]
        D = sp.diags(2.0 ** rng.uniform(-0.5, 0.5, n) if rescale else np.ones(n))
        mats = [sp.csc_matrix(P @ D @ X @ D @ P.T) for X in (block.K, block.C, block.M)]
        yield Block(block.dofs, *[X.toarray() for X in mats] if dense else mats)


def test_the_round_off_level_is_the_double_scatter_and_the_compensated_residual_removes_it():
    """docs/performance.md, "Critical flow at 8192 elements": the crossing eigenvalue of
    the 256-element cantilever refined in double (the dense iteration) from equivalent
    copies of its block scatters by about eigen_noise (measured 0.3 of it), not orders
    below, so that level is no pessimistic bound; the componentwise worst case is larger
    still. Refined with the compensated residual (the sparse iteration) the permuted
    copies agree to the last places of lambda."""
    from pipeflex.analysis.critical import refine_eigenpair
    from pipeflex.analysis.eigen import eigen_noise

    block = _crossing_block(256)
    lam, x = refine_eigenpair(block, 0.0977 + 13.6898j)
    noise = eigen_noise(block.K, block.C, block.M, lam, x)[0]
    eps = np.finfo(float).eps
    ax, al = np.abs(x), abs(lam)
    componentwise = eps * ax @ (al**2 * (abs(block.M) @ ax) + al * (abs(block.C) @ ax) + abs(block.K) @ ax) / abs(
        np.vdot(x, 2 * lam * (block.M @ x) + block.C @ x))
    double = [refine_eigenpair(b, lam * (1 + 1e-5))[0] for b in _equivalent_copies(block, 6, rescale=True, dense=True)]
    scatter = np.max(np.abs(np.array(double) - lam))
    assert 0.05 * noise < scatter < 3.0 * noise
    assert componentwise > noise
    compensated = [refine_eigenpair(b, lam * (1 + 1e-5))[0] for b in _equivalent_copies(block, 3, rescale=False)]
    spread = np.max(np.abs(np.array(compensated) - lam))
    assert spread < 1e-13 * abs(lam) and spread < 1e-5 * noise


def test_compensated_residual_is_rounded_once(monkeypatch):
    """QuadraticPencil.residual: K x of a stiff difference operator on a smooth vector
    (entries ~1e9 cancelling to ~100) and of one long row, against the exact sum of the
    stored numbers, by the vectorised Dot2 and by math.fsum (every row long); plain
    double loses ~1e-10 of it."""
    from fractions import Fraction
    import scipy.sparse as sp
    from pipeflex.analysis import eigen

    n = 80  # the long row: more than _DOT2_ROW entries
    D = sp.diags([np.ones(n - 1), -2 * np.ones(n), np.ones(n - 1)], [-1, 0, 1])
    K = ((D @ D) * (10.0 * n**4)).tolil()
    K[0, :] = np.linspace(1.0, 2.0, n) * 1e8
    K = K.tocsc()
    M, C = sp.eye(n, format="csc") / n, (sp.random(n, n, 0.05, random_state=2) * 0.1).tocsc()
    t = np.arange(n) / n
    x, s = np.sin(np.pi * t) * (1 + 0.3j) + 1e-3j * t, 0.1 + 13.7j
    rest = s * (C @ x) + s * s * (M @ x)
    Kd = K.toarray()

    def exact(part, small):
        return np.array([float(sum(Fraction(Kd[i, j]) * Fraction(part[j]) for j in range(n)) + Fraction(small[i]))
                         for i in range(n)])

    want = exact(x.real, rest.real) + 1j * exact(x.imag, rest.imag)
    eps = np.finfo(float).eps
    assert np.max(np.abs(K @ x + rest - want) / np.abs(want)) > 1e4 * eps
    for longest in (eigen._DOT2_ROW, 2):
        monkeypatch.setattr(eigen, "_DOT2_ROW", longest)
        pencil = eigen.QuadraticPencil(K, C, M)
        assert np.max(np.abs(pencil.residual(s, x) - want) / np.abs(want)) <= 4 * eps
        assert len(pencil._long) == (1 if longest > 5 else n)


def test_critical_flow_of_2048_elements_agrees_with_512():
    """With the compensated residual the crossing is located in the stored matrices to
    ~1e-14 1/s, so refining the mesh past 512 elements changes the flow only by the
    assembly's own round-off (measured 5e-11 relative from 512 to 4096; order-4
    discretisation error below 1e-12). In double the 2048-element flow was off by 2.7e-5."""
    f512 = pf.critical_mass_flow(pf.scenes.cantilever_pipe(n_elements=512)).mass_flow
    f2048 = pf.critical_mass_flow(pf.scenes.cantilever_pipe(n_elements=2048)).mass_flow
    assert f2048 == pytest.approx(f512, rel=2e-10)


def test_tracking_moves_a_lower_end_that_already_grows():
    """Large models: the scan judges its points by Arnoldi's eigenvalues in double
    (0.2-0.3 1/s at 8192 elements, ~0.5 kg/s of flow), so the bracket's lower end may
    already be unstable; the tracking checks it with the refined eigenvalue and steps it
    down instead of failing (here handed 25.5 kg/s, past the crossing at 25.0055)."""
    from pipeflex.analysis import critical

    ev = critical._Evaluator(pf.scenes.cantilever_pipe(n_elements=256), None)
    eig_lo, eig_hi = ev(25.5)[0], ev(28.1)[0]
    assert critical.classify(eig_lo) == "flutter"
    mc, _ = critical._track_root(ev, 25.5, 28.1, eig_hi, 1e-10, eig_lo)
    assert mc == pytest.approx(25.00552056, rel=1e-9)


@pytest.mark.parametrize("n", [8, 64])
def test_final_check_refuses_a_flow_off_the_crossing(n, monkeypatch):
    """The final check refines the crossing eigenvalue at the returned flow and holds it
    to its own resolution (round-off, Brent's flow tolerance, the tracked scatter: ~1e-9
    1/s here): a flow 1e-6 relative past the crossing (Re lambda ~1e-5 1/s) is refused,
    on the dense (8 elements) and the sparse path (64). Formerly it passed anything below
    1e3 times the scan's round-off bound."""
    from pipeflex.analysis import critical

    model = pf.scenes.cantilever_pipe(n_elements=n)
    brentq = critical.brentq
    monkeypatch.setattr(critical, "brentq", lambda f, a, b, **kw: brentq(f, a, b, **kw) * (1 + 1e-6))
    with pytest.raises(pf.ConvergenceError, match="not on the imaginary axis"):
        pf.critical_mass_flow(model)
    monkeypatch.setattr(critical, "brentq", brentq)
    r = pf.critical_mass_flow(model)
    assert abs(r.eigenvalue.real) < 1e-9


def test_scan_reuses_unchanged_blocks_and_the_band_lu_solves_as_superlu():
    """The scan's sparse analyses (BlockSolutions): a block whose matrices did not change
    (the torsion, without flow terms) keeps its solution, the others start from the last
    scale; the eigenvalues agree with a fresh analysis to round-off. The band LU of the
    shift-invert (a beam numbered along the pipe) solves as SuperLU's."""
    import scipy.sparse.linalg as spla
    from pipeflex.analysis import eigen

    model = pf.scenes.cantilever_pipe(n_elements=64, polar_inertia=1e-4)
    lin = [pf.linearize(model, pf.static_equilibrium(model, mass_flow=m).state, mass_flow=m) for m in (10.0, 12.0)]
    blocks = [eigen.split_blocks(x.K, x.C, x.M, sparse=True) for x in lin]
    previous = eigen.BlockSolutions()
    eigen.sparse_eigen_from_blocks(blocks[0], model.n_dofs, 16, previous=previous)
    first = list(previous.solved)
    warm = eigen.sparse_eigen_from_blocks(blocks[1], model.n_dofs, 16, previous=previous)
    fresh = eigen.sparse_eigen_from_blocks(blocks[1], model.n_dofs, 16)
    assert np.all(np.abs(warm.values - fresh.values) <= warm.noise + fresh.noise)
    unchanged = [s for s in previous.solved if any(s[1] is f[1] for f in first)]
    assert len(unchanged) == 1 and len(unchanged[0][0].dofs) == 65 - 1  # the torsion: one per free node

    T = eigen.QuadraticPencil(blocks[1][1].K, blocks[1][1].C, blocks[1][1].M)(2.0 + 13.0j)
    band = eigen._BandLU.of(T)
    assert band is not None and band.kl <= 3 and band.ku <= 3
    rhs = np.random.default_rng(1).standard_normal(T.shape[0])
    want = spla.splu(T).solve(rhs.astype(complex))
    assert np.allclose(band.solve(rhs), want, rtol=1e-10, atol=1e-10 * np.abs(want).max())


@pytest.mark.slow
def test_critical_flow_of_8192_elements_agrees_with_4096():
    """A large model (49152 coordinates, ~15-20 s): the critical flow converges and agrees
    with 4096 elements' (an eigenvalue good to only 0.3 1/s at the crossing would put it
    12 % off)."""
    f4096 = pf.critical_mass_flow(pf.scenes.cantilever_pipe(n_elements=4096)).mass_flow
    r = pf.critical_mass_flow(pf.scenes.cantilever_pipe(n_elements=8192))
    assert r.kind == "flutter"
    assert r.mass_flow == pytest.approx(f4096, rel=2e-9)
    assert r.mass_flow == pytest.approx(ref000.TABLE2_EXTRAPOLATED, rel=4e-8)


def test_static_flow_continuation_equals_hand_steps():
    """static_equilibrium(from_mass_flow=0) ramps flow and loads together from rest to
    375 kg/s (one solve from rest at 375 kg/s fails) and reaches the equilibrium of a
    by-hand sequence of 25 kg/s steps, to the Newton tolerance."""
    m = u_tube()
    with pytest.raises(pf.ConvergenceError):
        pf.static_equilibrium(m, mass_flow=375.0, max_bisections=2)
    r = pf.static_equilibrium(m, mass_flow=375.0, from_mass_flow=0.0)
    assert r.mass_flow == 375.0
    st = None
    for mdot in np.arange(25.0, 376.0, 25.0):
        st = pf.static_equilibrium(m, state=st, mass_flow=mdot).state
    assert np.abs(np.asarray(r.state.q) - np.asarray(st.q)).max() < 1e-9
    # from a converged state the loads stay applied and only the flow moves (a plain
    # warm-started solve fails on the step to 440 kg/s)
    with pytest.raises(pf.ConvergenceError):
        pf.static_equilibrium(m, state=st, mass_flow=440.0)
    r2 = pf.static_equilibrium(m, state=st, mass_flow=400.0, from_mass_flow=375.0)
    plain = pf.static_equilibrium(m, state=st, mass_flow=400.0).state
    st = pf.static_equilibrium(m, mass_flow=400.0, from_mass_flow=0.0).state
    assert np.abs(np.asarray(r2.state.q) - np.asarray(st.q)).max() < 1e-9
    assert np.abs(np.asarray(plain.q) - np.asarray(st.q)).max() < 1e-9
    # beyond the fold the ramp fails, naming the flow and the last equilibrium it reached
    with pytest.raises(pf.ConvergenceError, match="mdot = 46") as e:
        pf.static_equilibrium(m, state=r2.state, mass_flow=500.0, from_mass_flow=400.0, max_bisections=6)
    assert 460.0 < e.value.reached_mass_flow < 461.8 < e.value.mass_flow < 464.0  # steps of 100/64 kg/s
    assert e.value.reached_state is not None


def test_u_tube_static_path_ends_in_a_fold():
    """The scan follows the static path with the flow continuation (one static solve per
    quarter flow unit would stop at 296.84 kg/s) to its fold at ~461.7227 kg/s, where
    the tube's free end has swung round: the stiffness turns singular (k_min^2 linear in
    mdot), a real eigenvalue goes through 0 and there is no equilibrium beyond: a static
    instability, reported as divergence at the fold flow, independent of the scan step."""
    m = u_tube()
    r = pf.critical_mass_flow(m)
    assert r.kind == "divergence" and r.frequency == 0.0 and r.eigenvalue == 0
    assert r.mass_flow == pytest.approx(461.72265891, rel=1e-8)
    assert pf.critical_mass_flow(m, steps_per_unit=3).mass_flow == pytest.approx(r.mass_flow, rel=1e-9)
    below = 0.9999 * r.mass_flow
    st = pf.static_equilibrium(m, mass_flow=below, from_mass_flow=0.0).state
    eig = pf.eigenvalues(pf.linearize(m, st, mass_flow=below))
    assert pf.stability(eig) == "stable"
    assert eig.values.real.max() > -20.0 and abs(eig.values[np.argmax(eig.values.real)].imag) == 0.0
    with pytest.raises(pf.ConvergenceError):
        pf.static_equilibrium(m, state=st, mass_flow=1.0001 * r.mass_flow, from_mass_flow=below)


def test_round_off_damping_coupling_gives_no_infinite_eigenvalue():
    """Without rotary inertia (PipeSection.tube) the rotations are massless; on the
    deformed U-tube C's coupling to them is round-off (~1e-12 of |C|). The massless
    coordinates are condensed out, not sent to QZ, which would return infinite eigenvalues
    as finite (lambda ~ 9e11 at 420 kg/s: a spurious divergence)."""
    m = u_tube()
    st = pf.static_equilibrium(m, mass_flow=420.0, from_mass_flow=0.0).state
    eig = pf.eigenvalues(pf.linearize(m, st, mass_flow=420.0))
    assert pf.stability(eig) == "stable"
    assert np.abs(eig.values).max() < 1e8
    assert len(eig.values) == 2 * (m.n_dofs - 14)  # 14 massless rotations
