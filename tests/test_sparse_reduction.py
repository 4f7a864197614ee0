"""The sparse reduction of constrained linearisations (pipeflex.analysis.constrained): the
null-space basis T of C_q by elimination of dependent coordinates, sparse, from the
columns the constraints touch only; T^T X T by sparse products. No dense SVD and no
N x N array: a coupled arm linearises in O(N)."""
import tracemalloc

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse as sp

import pipeflex as pf
from helpers import on_clamped_hub
from pipeflex.analysis import constrained
from pipeflex.analysis.constrained import ConstrainedLinearization, null_space_basis, reduce
from pipeflex.analysis.eigen import stiffness_conditioning

EPS = np.finfo(float).eps
SEC = pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0, EA=1e5, rotary_inertia=(1e-3, 1e-3, 1e-3))


def floating_arm(n, *, mass_flow=10.0, clamped=False):
    """The 1 m arm of SEC (seed 000's cantilever) with n elements: (model, root node)."""
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    b.add_line(n0, (1.0, 0.0, 0.0), n, SEC)
    if clamped:
        b.clamp(n0)
    return b.build(mass_flow=mass_flow, floating=not clamped), n0


def coupled_arm(n, *, stiffness_ratio=1e4, mass_flow=10.0):
    arm, root = floating_arm(n, mass_flow=mass_flow)
    return on_clamped_hub(arm, root, stiffness_ratio=stiffness_ratio)


def core_matrices(system, state=None, **options):
    """pf.linearize(system, state, **options) and the (K, C, M, C_q) of the core's
    linear_matrices that it reduced."""
    seen = {}
    original = constrained.linearization

    def grab(cls, out, mass_flow, st):
        seen["out"] = out
        return original(cls, out, mass_flow, st)
    constrained.linearization = grab
    try:
        lin = pf.linearize(system, state, **options)
    finally:
        constrained.linearization = original
    return lin, constrained.from_core(seen["out"])


def dense_reference_basis(Cq, K):
    """The dense reference: the null space of C_q D^-1 by a full SVD (D = |diag K|^1/2,
    zeros by the median), rank from C_q's own singular values (1e-10 of the largest), then
    one least-squares projection onto C_q T = 0 (the metric's 1/d of a coordinate with a
    round-off stiffness, e.g. a frame's rotation, scales the SVD's round-off up)."""
    C = Cq.toarray()
    k = np.abs(K.diagonal())
    d = np.sqrt(np.where(k > 0.0, k, np.median(k[k > 0.0])))
    sv = np.linalg.svd(C, compute_uv=False)
    rank = int(np.sum(sv > 1e-10 * sv[0]))
    T = np.linalg.svd(C / d[None, :])[2][rank:].T / d[:, None]
    return T - np.linalg.lstsq(C, C @ T, rcond=1e-10)[0]


def assert_same_eigenvalues(a, b, what):
    """Eigenvalues of congruent pencils (two bases of one null space): each within its
    own round-off bound (EigenResult.noise), so the two within the sum of the bounds
    (and 1e-12 |lambda| for the eigen-solver's backward error of the reduced matrices)."""
    assert len(a.values) == len(b.values), what
    used = np.zeros(len(b.values), bool)
    for lam, noise in zip(a.values, a.noise):
        gap = np.where(used, np.inf, np.abs(b.values - lam))
        j = int(np.argmin(gap))
        assert gap[j] <= noise + b.noise[j] + 1e-12 * abs(lam), (what, lam, b.values[j], noise, b.noise[j])
        used[j] = True


def test_basis_is_sparse_and_spans_the_null_space(rng):
    """A sparse C_q touching 40 of 400 columns (random, scaled over 8 decades in the
    metric, with two redundant rows): T is CSC, C_q T = 0 to round-off, of full column
    rank N - rank(C_q) (the rank of C_q itself), and the 360 untouched coordinates keep
    their own columns 1/d e_j (nothing else)."""
    n, touched = 400, rng.choice(400, 40, replace=False)
    rows = rng.standard_normal((10, 40)) * (rng.random((10, 40)) < 0.4)
    rows = np.vstack([rows, rows[0] + 2.0 * rows[3], rows[5] - rows[7]])  # redundant
    C = np.zeros((12, n))
    C[:, touched] = rows
    k = 10.0 ** rng.uniform(-2, 6, n)
    K = sp.diags(k, format="csc")
    T = null_space_basis(sp.csr_matrix(C), K)
    assert sp.isspmatrix_csc(T)
    rank = np.linalg.matrix_rank(C)
    assert rank == 10 and T.shape == (n, n - rank)
    assert np.abs(C @ T).max() <= 1e3 * EPS * np.abs(C).max() * np.abs(T).max()
    DT = (sp.diags(np.sqrt(k)) @ T).toarray()
    sv = np.linalg.svd(DT, compute_uv=False)
    assert sv[-1] > 1e-3 * sv[0]  # full column rank, well conditioned in the metric
    untouched = np.setdiff1d(np.arange(n), touched)
    sub = T[untouched].tocoo()
    assert sub.nnz == len(untouched)
    np.testing.assert_array_equal(sub.data, 1.0 / np.sqrt(k[untouched[sub.row]]))
    assert np.all(np.diff(T[untouched].tocsr().indices) > 0)  # their columns in their order
    assert T.nnz <= (n - rank) + rank * (40 - rank)


def test_redundant_constraints_keep_the_rank_of_cq_itself():
    """Rows that repeat a constraint (a joint locking a motion twice), also through a
    stiff coordinate (1e20 N/m: a column of 1e-10 in the metric, which a cutoff in the
    metric would drop, freeing a motion the joint locks), leave the null space of C_q;
    without constraints T is D^-1 (the identity without K)."""
    k = np.array([1e20, 1.0, 2.0, 1.0, 5.0])
    K = sp.diags(k, format="csc")
    C = np.array([[1.0, -1.0, 0.0, 0.0, 0.0],   # the stiff 0 moves with 1
                  [0.0, 1.0, 0.0, -1.0, 0.0],   # 1 with 3
                  [1.0, 0.0, 0.0, -1.0, 0.0],   # so 0 with 3: redundant
                  [2.0, -2.0, 0.0, 0.0, 0.0]])  # the first again, scaled
    T = null_space_basis(C, K).toarray()
    assert T.shape == (5, 3)
    assert np.abs(C @ T).max() <= 1e-15
    assert np.linalg.matrix_rank(T) == 3
    assert np.linalg.cond((T.T @ K @ T)) < 1e3  # the soft coordinates' scale, not 1e20's
    np.testing.assert_array_equal(null_space_basis(np.zeros((0, 3))).toarray(), np.eye(3))
    np.testing.assert_array_equal(null_space_basis(sp.csr_matrix((2, 3)), sp.diags([4.0, 1.0, 0.0])).toarray(),
                                  np.diag([0.5, 1.0, 1.0 / np.sqrt(2.5)]))  # zero stiffness: the median's


def test_reduce_is_sparse_and_equals_the_dense_product(rng):
    """reduce(T, X...) gives CSC matrices in canonical format (sorted, no duplicates),
    equal to the dense T^T X T to round-off; a dense T is taken as sparse."""
    X = sp.random(60, 60, density=0.1, random_state=np.random.RandomState(3), format="csc")
    T = sp.random(60, 50, density=0.05, random_state=np.random.RandomState(4), format="csc") + sp.eye(60, 50)
    for basis in (T, T.toarray()):
        (R,) = reduce(basis, X)
        assert sp.isspmatrix_csc(R) and R.has_canonical_format
        dense = T.toarray().T @ X.toarray() @ T.toarray()
        assert np.abs(R.toarray() - dense).max() <= 1e2 * EPS * np.abs(dense).max()


@pytest.mark.parametrize("mass_flow", [10.0, 25.0])
def test_the_stiff_hub_keeps_its_stiffness_in_its_own_columns(mass_flow):
    """The cantilever on a hub body 1e6 times as stiff (clamped): the eliminated
    coordinates are the ones the metric pivots on, so no column carries the hub's 1e18
    N/m beside the arm's: the eigenvalues are the clamped cantilever's to 1e-8 (the hub's
    compliance: 1e-9 measured), both bending planes exactly equal, the reduced stiffness
    as well conditioned (pf.stability sees no mechanism), the reduction's bound ~5e-10
    1/s on the lowest mode."""
    alone, _ = floating_arm(8, mass_flow=mass_flow, clamped=True)
    clamped = pf.eigenvalues(pf.linearize(alone, pf.static_equilibrium(alone).state))
    lin = pf.linearize(coupled_arm(8, stiffness_ratio=1e6, mass_flow=mass_flow))
    assert sp.isspmatrix_csc(lin.basis) and sp.isspmatrix_csc(lin.K)
    eig = pf.eigenvalues(lin, vectors=True)

    def lowest(e):
        v = e.values[e.values.imag > 0]
        return v[np.argsort(v.imag)][:8]
    got, expected = lowest(eig), lowest(clamped)
    assert np.allclose(got, expected, rtol=1e-8, atol=0)
    np.testing.assert_array_equal(got[0::2], got[1::2])  # the two bending planes
    assert stiffness_conditioning(eig) > 0.5 * stiffness_conditioning(clamped)
    i = int(np.argmin(np.abs(eig.values)))
    assert lin.reduction_noise(eig.values[i], eig.vectors[:, i])[0] < 1e-8


@pytest.mark.parametrize("stiffness_ratio", [1.0, 1e4])
def test_coupled_eigenvalues_equal_the_dense_references(stiffness_ratio):
    """The coupled arm (16 elements) on a clamped hub: the sparse basis's eigenvalues equal
    those of the dense SVD basis within their round-off bounds."""
    lin, (K, C, M, Cq) = core_matrices(coupled_arm(16, stiffness_ratio=stiffness_ratio))
    T = dense_reference_basis(Cq, K)
    assert T.shape == lin.basis.shape
    assert np.abs(Cq @ lin.basis).max() <= 1e-13
    ref = ConstrainedLinearization(*reduce(T, M, C, K), lin.mass_flow, None, sp.csc_matrix(T), (M, C, K))
    assert_same_eigenvalues(pf.eigenvalues(lin), pf.eigenvalues(ref), "coupled")


def test_bodies_eigenvalues_equal_the_dense_reference():
    """The floating-frame chain (4 bodies of 4 elements, 1.5 N tip force, 20 kg/s) about
    its equilibrium: the sparse basis's eigenvalues equal the dense SVD basis's within
    their round-off bounds."""
    system = pf.scenes.ffrf_cantilever_pipe(n_bodies=4, elements_per_body=4, tip_force=1.5)
    st = pf.static_equilibrium(system, mass_flow=20.0).state
    lin, (K, C, M, Cq) = core_matrices(system, st, mass_flow=20.0)
    T = dense_reference_basis(Cq, K)
    assert np.abs(Cq @ lin.basis).max() <= 1e-13 and lin.n_dofs == T.shape[1]
    ref = ConstrainedLinearization(*reduce(T, M, C, K), 20.0, None, sp.csc_matrix(T), (M, C, K))
    assert_same_eigenvalues(pf.eigenvalues(lin), pf.eigenvalues(ref), "bodies")


def test_no_dense_svd_and_no_n_by_n_array(monkeypatch):
    """pf.linearize of a coupled arm of 512 elements (N = 3096 coordinates): no SVD or
    QR of anything larger than 100 in a dimension (a dense SVD of the whole 12 x 3096 C_q
    would be one), and the peak of the memory allocated stays below a quarter of one
    dense N x N array (77 MB; 7.6 MB measured: the core's triplets and the CSC matrices)."""
    system = coupled_arm(512)
    st = pf.static_equilibrium(system)

    def small_only(f):
        def guarded(a, *args, **kwargs):
            assert max(np.shape(a)) <= 100, f"a dense factorisation of a {np.shape(a)} array"
            return f(a, *args, **kwargs)
        return guarded
    for module, name in ((np.linalg, "svd"), (np.linalg, "qr"), (sla, "svd"), (sla, "qr"), (sla, "null_space")):
        monkeypatch.setattr(module, name, small_only(getattr(module, name)))
    pf.linearize(system, st)  # warm
    tracemalloc.start()
    try:
        lin = pf.linearize(system, st)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    n = lin.basis.shape[0]
    assert n == 3096 and lin.n_dofs == n - 12
    assert peak < 0.25 * 8 * n * n, peak
    assert lin.basis.nnz <= n + 12 * 12  # identity columns, and the joint's few entries


def test_a_free_motion_stays_a_mechanism():
    """Seed 004's curved pipe turns freely on its hinge: the basis puts that rotation in
    one column, whose reduced stiffness is the core's round-off (~1e-40 in the metric,
    against ~1 of every other column) and is set to zero (stiffness_floor), so that
    pf.stability names the mechanism instead of scaling the round-off up to a stiffness."""
    system = pf.scenes.ffrf_curved_pipe(E=9.585e9, n_bodies=2, elements_per_body=4)
    st = pf.static_equilibrium(system, mass_flow=0.0).state
    lin = pf.linearize(system, st, mass_flow=0.0)
    free = np.flatnonzero(np.diff(lin.K.indptr) == 0)
    assert len(free) == 1 and np.abs(lin.M[:, free[0]]).max() > 0.0
    with pytest.raises(ValueError, match=f"mechanism \\(free: coordinates {free[0]}\\)"):
        pf.stability(pf.eigenvalues(lin))
    Kr = sp.csc_matrix(np.array([[1.0, 1e-17], [1e-17, 1e-40]]))
    floored = constrained.stiffness_floor(Kr, sp.identity(2, format="csc"), np.ones(2))
    np.testing.assert_array_equal(floored.toarray(), [[1.0, 0.0], [0.0, 0.0]])
