"""The one-pass CSC assembly (_core.assemble_csc, analysis._assembly.tangents): the same
matrices as the summed triplets of the assembler (the C++ integrators' route), on the
model's cached pattern, which a change of the model's structure replaces."""
import numpy as np
import pytest
import scipy.sparse as sp

import pipeflex as pf
from pipeflex import _core
from pipeflex.analysis._assembly import residual_and_tangent, tangents

WEIGHTS = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))


def loaded_frame():
    """Straight and curved pipe with flow, rotary inertia, a hinge (a basis that is not a
    selection), a follower and a dead load, a point mass with inertia and gravity."""
    sec = pf.PipeSection(EI=7.0, EIz=11.0, EA=3e3, GJ=5.0, pipe_mass=1.3, fluid_mass=0.7,
                         rotary_inertia=(0.02, 0.01, 0.015))
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    nodes = b.add_line(n0, (1.0, 0.0, 0.0), 3, sec)
    tip = b.add_arc(nodes[-1], center=(1.0, 0.5, 0.0), angle=np.pi / 2, normal=(0, 0, 1), n_elements=3,
                    section=sec)
    b.hinge(n0, (0.3, 0.0, 1.0))
    b.add_load(tip[-1], force=(0.0, 0.0, -2.0))
    b.add_load(tip[-1], force=(-3.0, 0.5, 0.0), moment=(0.0, 0.1, 0.0), follower=True)
    b.add_point_mass(nodes[1], 0.4, inertia=(0.01, 0.02, 0.03))
    b.set_gravity((0.0, 0.0, -9.81))
    return b.build(mass_flow=1.5)


def models():
    return {
        "loaded frame": loaded_frame(),
        "cantilever polar inertia": pf.scenes.cantilever_pipe(n_elements=5, polar_inertia=1e-3, mass_flow=4.0),
        "coriolis meter": pf.scenes.coriolis_meter(leg_length=0.3, mass_flow=2.0, drive_force=1.0),
        "ANCF tip mass on hub": pf.scenes.rotating_cantilever(n_elements=4, tip_mass_ratio=0.5, omega=3.0,
                                                              spin_up_time=1.0),
        "ANCF model 0": pf.scenes.rotating_cantilever(n_elements=3, elastic="0"),
    }


def moved_state(model, seed):
    """A deformed, moving state (all K, C and M terms non-trivial)."""
    rng = np.random.default_rng(seed)
    s = model.initial_state()
    n = model.n_dofs
    for which, scale in (("q", 0.05), ("v", 0.7), ("a", 3.0)):
        _core.add_increment(model.core, s, scale * rng.standard_normal(n), which)
    return s


@pytest.mark.parametrize("name", list(models()))
def test_csc_tangents_equal_the_summed_triplets(name):
    model = models()[name]
    s = moved_state(model, 1)
    load = model.load_state(mass_flow=1.2 * (model.mass_flow or 1.0))
    if model.ancf_nodes:  # the co-rotating frame's Coriolis and centrifugal terms
        load.frame_rate, load.frame_acceleration = 3.0, 0.5
    r, mats = tangents(model, s, load, WEIGHTS + ((0.7, -0.3, 0.2),), load_factor=0.8, residual=True)
    r_ref, _ = _core.assemble(model.core, s, load, 0.8, 0.0, 0.0, 0.0, False)
    # Two kernels (the residual-only one, each node's rotation kinematics shared by its
    # elements, and the hand tangent's, per element) in the same order of
    # operations: equal to round-off, not always bitwise, since the geometry's last bits
    # come from libm's sin/cos, whose variant (and rounding) glibc picks by CPU.
    r_ref = np.asarray(r_ref)
    assert np.abs(r - r_ref).max() <= 4 * np.finfo(float).eps * np.abs(r_ref).max(), name
    n = model.n_dofs
    refs = []
    for X, w in zip(mats, WEIGHTS + ((0.7, -0.3, 0.2),)):
        rows, cols, vals = _core.assemble(model.core, s, load, 0.8, *w, True)[1]
        ref = sp.csc_matrix((vals, (rows, cols)), shape=(n, n))
        refs.append(ref)
        assert isinstance(X, sp.csc_matrix) and X.has_canonical_format
        scale = abs(ref).max()
        assert scale > 0.0
        assert abs(X - ref).max() <= 1e-13 * scale, (name, w)
    # the weighted set is the weighted sum of K, C and M (one differentiation for all)
    K, C, M, S = mats
    assert abs(S - (0.7 * K - 0.3 * C + 0.2 * M)).max() <= 1e-13 * abs(S).max()
    # every matrix on the one pattern, sorted rows, no repeats
    for X in mats:
        assert np.array_equal(X.indptr, K.indptr) and np.array_equal(X.indices, K.indices)
        assert X is K or not np.shares_memory(X.indices, K.indices)  # own copies
    ref = refs[0].tocsc()
    ref.sum_duplicates()
    assert K.nnz >= ref.nnz


def test_linearize_matrices_equal_the_triplet_route():
    model = loaded_frame()
    lin = pf.linearize(model, moved_state(model, 2), mass_flow=2.0)
    s = lin.state.to_core(model)
    load = model.load_state(mass_flow=2.0)
    for X, (lf, w) in zip((lin.K, lin.C, lin.M), ((1.0, WEIGHTS[0]), (0.0, WEIGHTS[1]), (0.0, WEIGHTS[2]))):
        rows, cols, vals = _core.assemble(model.core, s, load, lf, *w, True)[1]
        ref = sp.csc_matrix((vals, (rows, cols)), shape=X.shape)
        assert abs(X - ref).max() <= 1e-13 * abs(ref).max()
    _, J = residual_and_tangent(model, s, load, wK=1.0, wC=0.5, wM=0.25)
    assert abs(J - (lin.K + 0.5 * lin.C + 0.25 * lin.M)).max() <= 1e-13 * abs(J).max()


def test_pattern_follows_a_change_of_the_model():
    data = pf.scenes.cantilever_pipe(n_elements=1).core.pipe(0)
    core = _core.Model()
    for x in range(3):
        core.add_node([0.5 * x, 0.0, 0.0])
    core.add_pipe(0, 1, data)
    core.finalize()
    load = _core.LoadState()

    def check(core):
        s = _core.State(core)
        _, data_, indices, indptr = _core.assemble_csc(core, s, load, 1.0, [(1.0, 0.0, 0.0)], False)
        rows, cols, vals = _core.assemble(core, s, load, 1.0, 1.0, 0.0, 0.0, True)[1]
        n = core.n_dofs
        ref = sp.csc_matrix((vals, (rows, cols)), shape=(n, n))
        X = sp.csc_matrix((data_[0], indices, indptr), shape=(n, n))
        assert abs(X - ref).max() <= 1e-13 * abs(ref).max()
        return len(indices)

    nnz1 = check(core)
    assert nnz1 == 144  # one element: nodes 0 and 1 coupled, node 2 free and alone
    core.add_pipe(1, 2, data)
    with pytest.raises(ValueError, match="not finalized"):
        _core.assemble_csc(core, _core.State(core), load, 1.0, [(1.0, 0.0, 0.0)], False)
    core.finalize()
    assert check(core) == 144 + 3 * 36


def test_state_of_another_model_is_refused():
    a = pf.scenes.cantilever_pipe(n_elements=3)
    b = pf.scenes.cantilever_pipe(n_elements=4)
    with pytest.raises(ValueError, match="another model"):
        _core.assemble_csc(a.core, b.initial_state(), a.load_state(), 1.0, [(1.0, 0.0, 0.0)], False)
