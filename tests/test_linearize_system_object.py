"""An element model's linearisation goes through the one system object (the core's
``linear_matrices``, as bodies' and coupled systems'): the same K, C, M as the element
assembler's own pass (``_core.assemble_csc``, the test reference), on a tangent pattern
the model keeps across calls (one system per concurrent caller, never pickled)."""
import pickle
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

import pipeflex as pf
from pipeflex import _core
from pipeflex.state import State, as_core

from helpers import assert_close_ulps

SEC = pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0, EA=1e5, GJ=8.0, rotary_inertia=(1e-3, 1e-3, 1e-3))


def arm(n=6, *, hub=False):
    b = pf.ModelBuilder()
    root = b.add_node((0.0, 0.0, 0.0))
    b.add_line(root, (1.0, 0.2, 0.1), n, SEC)
    b.reservoir_inlet(root)
    b.add_load(n, force=(0.0, 0.0, -3.0))
    if hub:
        b.rotating_hub(root, omega=2.0, spin_up_time=1.0)  # at rest at t = 0
    else:
        b.clamp(root)
    return b.build(mass_flow=3.0)


def reference(model, state, mass_flow):
    """K, C, M by the element assembler's one pass at ``state`` re-based (phi = 0)."""
    import scipy.sparse as sp

    s = as_core(model, state)
    s.rebase(0.0)
    _, data, indices, indptr = _core.assemble_csc(model.core, s, model.load_state(mass_flow=mass_flow), 1.0,
                                                  [(1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)], False)
    n = model.n_dofs
    return [sp.csc_matrix((d, indices, indptr), shape=(n, n)) for d in data], State.from_core(s, model)


def assert_same(lin, model, state, mass_flow):
    (K, C, M), s = reference(model, state, mass_flow)
    for X, R, name in zip((lin.K, lin.C, lin.M), (K, C, M), "KCM"):
        assert np.array_equal(X.indptr, R.indptr) and np.array_equal(X.indices, R.indices)
        assert_close_ulps(X.toarray(), R.toarray(), ulps=8, scale=np.abs(R).max(), what=name)
    assert_close_ulps(lin.state.q, s.q, ulps=4, scale=1.0, what="q")
    assert np.array_equal(lin.state.frames, s.frames)


@pytest.mark.parametrize("mass_flow", [3.0, 7.5])
def test_the_same_matrices_as_the_assembler(mass_flow):
    """At the loaded equilibrium (rotations to re-base) and at another flow than the
    model's; moving (velocities and accelerations of the free coordinates)."""
    model = arm()
    st = pf.static_equilibrium(model, mass_flow=mass_flow).state
    assert np.abs(st.q).max() > 1e-3
    assert_same(pf.linearize(model, st, mass_flow=mass_flow), model, st, mass_flow)
    rng = np.random.default_rng(5)
    B = model.basis
    moving = State(st.q, B @ rng.standard_normal(model.n_dofs), B @ rng.standard_normal(model.n_dofs),
                   st.frames, st.ancf)
    assert_same(pf.linearize(model, moving, mass_flow=mass_flow), model, moving, mass_flow)


def test_a_model_on_a_rotating_hub():
    model = arm(hub=True)
    st = State.from_core(model.initial_state(), model)
    assert_same(pf.linearize(model, st), model, st, model.mass_flow)


def test_the_pattern_is_built_once():
    """Repeated linearisations (a critical-flow scan) reuse one system and its pattern;
    the state passed is not modified."""
    model = arm()
    st = pf.static_equilibrium(model).state
    q = st.q.copy()
    for mdot in (1.0, 2.0, 3.0):
        pf.linearize(model, st, mass_flow=mdot)
    pf.critical_mass_flow(model)
    assert np.array_equal(st.q, q)
    assert len(model._linear_systems) == 1
    (_, system), = model._linear_systems
    assert system.linear_pattern_builds == 1


def test_threads_get_their_own_system():
    """Concurrent linearisations of one model: each thread's own system, the same numbers."""
    model = arm(40)
    st = pf.static_equilibrium(model).state
    one = pf.linearize(model, st)
    with ThreadPoolExecutor(4) as pool:
        lins = list(pool.map(lambda mdot: pf.linearize(model, st, mass_flow=mdot), [3.0] * 16))
    for lin in lins:
        for X, Y in zip((lin.K, lin.C, lin.M), (one.K, one.C, one.M)):
            assert_close_ulps(X.toarray(), Y.toarray(), ulps=4, scale=np.abs(Y).max())
    assert 1 <= len(model._linear_systems) <= 5


def test_pickling_leaves_the_systems_behind():
    model = arm()
    lin = pf.linearize(model)
    assert model._linear_systems
    again = pickle.loads(pickle.dumps(model))
    assert again._linear_systems == []
    lin2 = pf.linearize(again)
    for X, Y in zip((lin.K, lin.C, lin.M), (lin2.K, lin2.C, lin2.M)):
        assert np.array_equal(X.toarray(), Y.toarray())
