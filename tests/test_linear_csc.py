"""The linearisation in compressed columns (``_core.linear_matrices``): K, C, M (n x n, one
pattern) and C_q (nc x n) of an element model, bodies and a coupled system, equal to the
parts' own assemblies; the pattern is built once per system and kept, the values follow
the state, and a change of what the tangent holds (a coupling's reactions appearing)
rebuilds it."""
import numpy as np
import scipy.sparse as sp

import pipeflex as pf
from pipeflex import _core
from pipeflex.analysis import constrained
from pipeflex.analysis._assembly import KCM, tangents
from pipeflex.multibody import MultibodyState
from pipeflex.state import as_core

from helpers import assert_close_ulps, on_clamped_hub

SEC = pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0, EA=1e5, GJ=8.0, rotary_inertia=(1e-3, 1e-3, 1e-3))
MDOT = 3.0


def arm(n=6, *, clamped):
    b = pf.ModelBuilder()
    root = b.add_node((0.0, 0.0, 0.0))
    b.add_line(root, (1.0, 0.2, 0.1), n, SEC)
    b.reservoir_inlet(root)
    b.add_load(n, force=(0.0, 0.0, -3.0))
    if clamped:
        b.clamp(root)
    return b.build(mass_flow=MDOT, floating=not clamped), root


def matrices(out):
    """(K, C, M, C_q) as CSC, checked canonical: rows sorted and unique in each column."""
    mats = constrained.from_core(out)
    for A in mats:
        col = np.repeat(np.arange(A.shape[1]), np.diff(A.indptr))
        assert np.all(np.diff(col.astype(np.int64) * A.shape[0] + A.indices) > 0)
    K, C, M, _ = mats
    assert np.array_equal(K.indptr, M.indptr) and np.array_equal(K.indices, C.indices)  # one pattern
    assert K.indices is not C.indices  # each its own arrays
    return mats


def assert_same(A, B, what):
    """A and B (sparse or dense) equal to a few ulps of the matrix's largest entry."""
    A, B = (X.toarray() if sp.issparse(X) else np.asarray(X) for X in (A, B))
    assert_close_ulps(A, B, ulps=8, scale=np.abs(B).max(initial=0.0), what=what)


def element_reference(model, state):
    """K, C, M by the element model's own assembly (_core.assemble_csc) at ``state``."""
    return tangents(model, state, model.load_state(mass_flow=MDOT), KCM)


def body_reference(bodies, st):
    """K, C, M and C_q of the bodies by their own evaluation at ``st``."""
    S = [bodies.evaluate(st, mass_flow=MDOT, wK=w[0], wC=w[1], wM=w[2])[3] for w in KCM]
    return (*S, bodies.constraints(st, sparse=True)[1])


def test_an_element_model_is_its_assembly():
    model, _ = arm(clamped=True)
    st = pf.static_equilibrium(model).state
    s = as_core(model, st)
    out = _core.linear_matrices(model.system(s, mass_flow=MDOT), MDOT)
    K, C, M, Cq = matrices(out)
    assert Cq.shape == (0, model.n_dofs)
    for X, R, name in zip((K, C, M), element_reference(model, s), "KCM"):
        assert_same(X, R, name)


def test_bodies_are_their_evaluation():
    system = pf.scenes.ffrf_cantilever_pipe(n_bodies=3, elements_per_body=4, tip_force=1.5)
    st = pf.multibody.static_equilibrium(system, mass_flow=MDOT).state
    K, C, M, Cq = matrices(_core.linear_matrices(system.system(st), MDOT))
    assert np.abs(st.lam).max() > 0.0  # the joints' reactions in K
    for X, R, name in zip((K, C, M, Cq), body_reference(system, st), ("K", "C", "M", "C_q")):
        assert_same(X, R, name)


def coupled_arm():
    floating, root = arm(clamped=False)
    return on_clamped_hub(floating, root, stiffness_ratio=1e2)


def test_a_coupled_system_is_its_parts_and_its_couplings():
    """C and M (no reactions in them) and, at zero multipliers, K are the element model's
    and the bodies' blocks; C_q's body rows the bodies' joints; K at the equilibrium
    against central differences of the residual (the tests' oracle)."""
    system = coupled_arm()
    eq = pf.static_equilibrium(system, mass_flow=MDOT)
    model, bodies = system.model, system.bodies
    n1, nc2 = model.n_dofs, bodies.n_constraints
    s = as_core(model, eq.state)
    bs = eq.body_state
    zero = MultibodyState(bs.r, bs.R, bs.eta, bs.v, bs.a, 0.0 * bs.lam, bs.t)
    out0 = _core.linear_matrices(system.system(as_core(model, s), zero, 0.0 * np.asarray(eq.coupling_forces),
                                               mass_flow=MDOT), MDOT)
    K0, C, M, Cq = matrices(out0)
    ref_el = element_reference(model, as_core(model, s))
    ref_b = body_reference(bodies, zero)
    for X, name, k in ((K0, "K", 0), (C, "C", 1), (M, "M", 2)):
        assert_same(X[:n1, :n1], ref_el[k], name + " (elements)")
        assert_same(X[n1:, n1:], ref_b[k], name + " (bodies)")
        assert X[:n1, n1:].nnz == 0 and X[n1:, :n1].nnz == 0  # no reactions: no geometric stiffness
    assert_same(Cq[:nc2, n1:], ref_b[3], "C_q (bodies)")
    assert Cq[:nc2, :n1].nnz == 0
    assert Cq.shape == (system.n_constraints, system.n_coordinates)
    out = _core.linear_matrices(system.system(as_core(model, s), bs, eq.coupling_forces, mass_flow=MDOT), MDOT, 1e-6)
    K, _, _, Cq = matrices(out)
    J, D = sp.vstack([K, Cq]).toarray(), out["differences"]
    col = np.abs(J).max(axis=0)
    assert (np.abs(J - D).max(axis=0) / np.maximum(col, 1e-6 * np.median(col))).max() < 1e-5


def body_state_of(sys):
    r, R, eta, v, a, lam, t = sys.body_state
    return MultibodyState(np.array(r), np.array(R), np.array(eta), np.array(v), np.array(a), np.array(lam), t)


def test_the_pattern_is_kept_and_the_values_follow_the_state():
    """A second linearisation of the same system object (element model, coupled, bodies)
    after its state moved (a transient run from its equilibrium under more flow and load)
    builds no pattern and equals a fresh system's at the new state."""
    model, _ = arm(clamped=True)
    system = coupled_arm()
    cases = []
    s_el = as_core(model, pf.static_equilibrium(model).state)
    cases.append(("element", model.n_dofs, model.system(s_el, mass_flow=MDOT),
                  lambda sys: model.system(as_core(model, s_el), mass_flow=MDOT)))
    eq = pf.static_equilibrium(system, mass_flow=MDOT)
    s_cp = as_core(system.model, eq.state)
    cases.append(("coupled", system.model.n_dofs,
                  system.system(s_cp, eq.body_state, eq.coupling_forces, mass_flow=MDOT),
                  lambda sys: system.system(as_core(system.model, s_cp), body_state_of(sys),
                                            sys.coupling_multipliers, mass_flow=MDOT)))
    bodies = pf.scenes.ffrf_cantilever_pipe(n_bodies=3, elements_per_body=4, tip_force=1.5)
    cases.append(("bodies", bodies.n_coordinates,
                  bodies.system(pf.multibody.static_equilibrium(bodies, mass_flow=MDOT).state),
                  lambda sys: bodies.system(body_state_of(sys))))
    for name, n1, sys, fresh in cases:
        first = matrices(_core.linear_matrices(sys, MDOT))
        assert sys.linear_pattern_builds == 1
        opts = _core.TransientOptions()
        opts.step = 1e-3
        flow, loads = _core.TimeTable(), _core.TimeTable()  # off the equilibrium: more flow and load
        flow.t, flow.value = [0.0], [3.0 * MDOT]
        loads.t, loads.value = [0.0], [5.0]
        _core.integrate(sys, flow, loads, [0.0, 0.02], opts)
        again = matrices(_core.linear_matrices(sys, MDOT))
        assert sys.linear_pattern_builds == 1, name  # values only
        other = fresh(sys)
        ref = matrices(_core.linear_matrices(other, MDOT))
        assert other.linear_pattern_builds == 1
        for X, R, what in zip(again, ref, ("K", "C", "M", "C_q")):
            assert np.array_equal(X.indptr, R.indptr) and np.array_equal(X.indices, R.indices)
            assert_same(X, R, f"{name} {what}")
        # the state moved: the values did too (the arm's block: the stiff hub's entries would hide it)
        Ka, Kf = again[0][:n1, :n1], first[0][:n1, :n1]
        assert np.abs(Ka - Kf).max() > 1e-6 * np.abs(Kf).max()


def test_a_coupling_whose_reactions_appear_rebuilds_the_pattern():
    """At zero coupling multipliers the couplings add no geometric stiffness entries; after
    a static solve on the same system object they do: the pattern is rebuilt, the matrices
    equal a fresh system's, and the next call keeps the new pattern."""
    system = coupled_arm()
    s = system.model.initial_state()  # updated in place by the system's analyses
    sys = system.system(s, mass_flow=MDOT)
    before = matrices(_core.linear_matrices(sys, MDOT))
    assert sys.linear_pattern_builds == 1 and np.all(np.asarray(sys.coupling_multipliers) == 0.0)
    out = _core.static_equilibrium(sys, MDOT, 1.0, 1e-10, 25)
    assert out["converged"] and np.abs(sys.coupling_multipliers).max() > 0.0
    after = matrices(_core.linear_matrices(sys, MDOT))
    assert sys.linear_pattern_builds == 2
    assert after[0].nnz > before[0].nnz  # the couplings' geometric stiffness
    other = system.system(as_core(system.model, s), body_state_of(sys), sys.coupling_multipliers, mass_flow=MDOT)
    for X, R, what in zip(after, matrices(_core.linear_matrices(other, MDOT)), ("K", "C", "M", "C_q")):
        assert_same(X, R, what)
    again = matrices(_core.linear_matrices(sys, MDOT))
    assert sys.linear_pattern_builds == 2
    for X, R, what in zip(again, after, ("K", "C", "M", "C_q")):
        assert_same(X, R, what)
