"""Assembled linearisation: mass, symmetry of K, skew-symmetry of the gyroscopic matrix."""
import numpy as np
import pytest

import pipeflex as pf
from pipeflex.analysis.eigen import split_blocks


def test_assembled_mass_sums_to_total_mass():
    sec = pf.PipeSection(EI=2.0, pipe_mass=0.6, fluid_mass=0.9)
    b = pf.ModelBuilder()
    n0 = b.add_node((0, 0, 0))
    nodes = b.add_line(n0, (1.0, 0.5, 0.0), 3, sec)
    b.add_arc(nodes[-1], center=(1.0, 1.5, 0.0), angle=2.0, normal=(0, 0, -1), n_elements=5, section=sec)
    b.add_point_mass(nodes[1], 0.25)
    b.fix(n0, ["rx", "ry", "rz"])  # translations free: a rigid translation is admissible
    model = b.build()
    lin = pf.linearize(model)
    M = lin.M.toarray()
    for comp in ("ux", "uy", "uz"):
        u = np.array([1.0 if lab[1] == comp else 0.0 for lab in model.dof_labels])
        assert u @ M @ u == pytest.approx(model.total_mass + 0.25, rel=1e-13)


def test_stiffness_symmetric_and_gyroscopic_skew_where_theory_says():
    # Simply supported: the jet force acts along the fixed axis, so K stays symmetric and
    # the Coriolis matrix of each bending plane is skew-symmetric (no net energy input).
    model = pf.scenes.simply_supported_pipe(n_elements=6)
    lin = pf.linearize(model, mass_flow=1.2)
    K = lin.K.toarray()
    assert np.allclose(K, K.T, atol=1e-12 * np.abs(K).max())
    for b in split_blocks(lin.K, lin.C, lin.M):
        comps = {model.dof_labels[i][1] for i in b.dofs}
        if not comps & {"uy", "uz"}:
            continue  # axial (the jet's momentum damps the sliding outlet) and torsion
        assert np.allclose(b.C, -b.C.T, atol=1e-13 * max(1.0, np.abs(b.C).max()))
        assert np.abs(b.C).max() > 0.1  # and it is there
    # No flow, at rest: no damping at all.
    assert np.abs(pf.linearize(model, mass_flow=0.0).C.toarray()).max() == 0.0


def test_cantilever_follower_jet_makes_stiffness_nonsymmetric():
    model = pf.scenes.cantilever_pipe(n_elements=4)
    K0 = pf.linearize(model, mass_flow=0.0).K.toarray()
    assert np.allclose(K0, K0.T, atol=1e-12 * np.abs(K0).max())
    K = pf.linearize(model, mass_flow=10.0).K.toarray()
    assert np.abs(K - K.T).max() > 1.0  # P = 50 N follower force at the free end


def test_bending_planes_decouple_and_match():
    lin = pf.linearize(pf.scenes.cantilever_pipe(n_elements=4), mass_flow=5.0)
    sizes = sorted(len(b.dofs) for b in split_blocks(lin.K, lin.C, lin.M))
    assert sizes == [4, 4, 8, 8]  # torsion, axial, two bending planes
    ev = pf.eigenvalues(lin).values
    bending = ev[np.abs(ev.imag) < 1e3]
    # every bending eigenvalue appears twice (the two planes)
    for lam in bending:
        assert np.sum(np.abs(bending - lam) < 1e-9 * abs(lam)) == 2


def test_free_vibration_of_cantilever_without_flow():
    """Euler-Bernoulli cantilever: omega_1 = 1.875104^2 sqrt(EI / (m L^4))."""
    lin = pf.linearize(pf.scenes.cantilever_pipe(n_elements=16), mass_flow=0.0)
    w = np.sort(pf.eigenvalues(lin).frequencies)
    exact = 1.8751040687**2 * np.sqrt(10.0 / 10.0)
    assert w[0] == pytest.approx(exact, rel=1e-6)  # discretisation error ~1e-7 at 16 elements
    assert pf.stability(pf.eigenvalues(lin)) == "stable"


def _u_tube(rotary):
    import dataclasses

    sec = pf.PipeSection.tube(outer_diameter=0.0508, inner_diameter=0.0472, E=208e9, G=80e9,
                              density=8027.0, fluid_density=1000.0)
    sec = dataclasses.replace(sec, rotary_inertia=rotary)
    b = pf.ModelBuilder()
    inlet = b.add_node((0.0, 0.0, 0.0))
    leg = b.add_line(inlet, (0.0, 0.45, 0.0), 2, sec)
    b.add_arc(leg[-1], center=(0.15, 0.45, 0.0), angle=-np.pi, normal=(0, 0, 1), n_elements=12, section=sec)
    b.clamp(inlet)
    return b.build(mass_flow=2.0)


def test_massless_coordinates_are_condensed_not_spurious():
    """Without rotary inertia a curved pipe's torsion-about-tangent coordinates carry no
    mass. They must not produce eigenvalues: the spectrum equals the limit of a model with
    tiny rotary inertia (which makes M regular)."""
    e0 = pf.eigenvalues(pf.linearize(_u_tube((0.0, 0.0, 0.0))))
    e1 = pf.eigenvalues(pf.linearize(_u_tube((1e-9, 1e-9, 1e-9))))
    assert pf.stability(e0) == "stable"
    assert len(e0.values) < len(e1.values)        # massless coordinates dropped
    w0, w1 = np.sort(e0.frequencies)[:6], np.sort(e1.frequencies)[:6]
    assert e0.frequencies.max() < 1e8  # axial modes reach 2.5e6 rad/s; spurious ones would be ~1e11
    assert np.allclose(w0, w1, rtol=1e-6)


def test_generalized_path_when_damping_acts_on_massless_coordinates():
    from pipeflex.analysis.eigen import Block, block_eigenvalues

    # x1 has mass, x2 none, and a damper acts on x2: lambda^2 m + ... reduces to one
    # first-order plus one second-order equation (3 finite eigenvalues).
    K = np.array([[3.0, -1.0], [-1.0, 2.0]])
    C = np.array([[0.0, 0.0], [0.0, 0.5]])
    M = np.array([[1.0, 0.0], [0.0, 0.0]])
    lam, noise, _, _ = block_eigenvalues(Block(np.arange(2), K, C, M))
    assert len(lam) == 3
    for l in lam:
        assert abs(np.linalg.det(l * l * M + l * C + K)) < 1e-9 * (1 + abs(l)) ** 3


def test_matrices_equal_the_summed_assembler_triplets_for_alternating_models():
    # linearize assembles into each model's cached CSC pattern: models taken in turn
    # must still give the plain COO sums of the assembler's triplets.
    import scipy.sparse as sp
    from pipeflex import _core

    models = [pf.scenes.cantilever_pipe(n_elements=5), pf.scenes.simply_supported_pipe(n_elements=7),
              pf.scenes.cantilever_pipe(n_elements=5, polar_inertia=1e-3)]
    for model in models + models:
        lin = pf.linearize(model, mass_flow=3.0)
        s = lin.state.to_core(model)
        load = model.load_state(mass_flow=3.0)
        for X, (lf, w) in zip((lin.K, lin.C, lin.M), ((1.0, (1, 0, 0)), (0.0, (0, 1, 0)), (0.0, (0, 0, 1)))):
            rows, cols, vals = _core.assemble(model.core, s, load, lf, *w, True)[1]
            ref = sp.csc_matrix((vals, (rows, cols)), shape=X.shape)
            assert abs(X - ref).max() <= 1e-14 * abs(ref).max()
            assert np.array_equal(X.indptr, ref.indptr) and np.array_equal(X.indices, ref.indices)


def test_sparse_blocks_equal_dense_blocks_for_alternating_models():
    # split_blocks(sparse=True) reuses the block layout of the last call
    mats = [pf.linearize(pf.scenes.cantilever_pipe(n_elements=6), mass_flow=2.0),
            pf.linearize(pf.scenes.simply_supported_pipe(n_elements=6), mass_flow=2.0)]
    for lin in mats + mats:
        sparse = split_blocks(lin.K, lin.C, lin.M, sparse=True)
        dense = split_blocks(lin.K, lin.C, lin.M)
        assert [list(b.dofs) for b in sparse] == [list(b.dofs) for b in dense]
        for a, b in zip(sparse, dense):
            for x, y in ((a.K, b.K), (a.C, b.C), (a.M, b.M)):
                assert np.array_equal(x.toarray(), y) and np.all(x.data != 0.0)
