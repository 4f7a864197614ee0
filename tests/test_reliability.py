"""Reliability (issue "Reliability", items 1-3): a state of another model, vectors of the
wrong size and bad indices are refused at the C++ boundary (ValueError naming the
parameter); singular or non-finite problems are named instead of answered; work is
bounded (size and step limits, Ctrl-C)."""
import numpy as np
import pytest

import pipeflex as pf
from pipeflex import _core, scenes


@pytest.fixture(scope="module")
def m2():
    return scenes.cantilever_pipe(n_elements=2, polar_inertia=1e-3)


@pytest.fixture(scope="module")
def m4():
    return scenes.cantilever_pipe(n_elements=4, polar_inertia=1e-3)


@pytest.fixture(scope="module")
def m8():
    return scenes.cantilever_pipe(n_elements=8, polar_inertia=1e-3)


# -- 1. checks at the boundary ---------------------------------------------------------

@pytest.mark.parametrize("analysis", [
    lambda m, s: pf.static_equilibrium(m, state=s),
    lambda m, s: pf.linearize(m, s),
    lambda m, s: pf.simulate(m, 0.01, state=s, progress=False),
], ids=["static_equilibrium", "linearize", "simulate"])
def test_state_of_another_model_is_refused(analysis, m2, m8):
    with pytest.raises(ValueError, match="the state has 18 coordinates, the model 54"):
        analysis(m8, m2.initial_state())


def test_short_q_is_refused_when_set(m4):
    """The issue's SIGABRT: st.q = np.zeros(3) then simulate on a 4-element cantilever."""
    st = m4.initial_state()
    with pytest.raises(ValueError, match=r"State.q must have 6 entries per node \(30 for 5 nodes\), got 3"):
        st.q = np.zeros(3)
    with pytest.raises(ValueError, match="State.v must have 6 entries per node"):
        st.v = np.zeros(31)
    assert pf.simulate(m4, 0.01, state=st, progress=False, n_outputs=2).t[-1] == pytest.approx(0.01)


@pytest.mark.parametrize("call", [
    lambda m, s: _core.assemble(m.core, s, m.load_state(), 1.0, 1.0, 0.0, 0.0, True),
    lambda m, s: _core.external_forces(m.core, s),
    lambda m, s: _core.gravity_potential(m.core, s, m.load_state()),
    lambda m, s: _core.integrate_generalized_alpha(m.core, s, m.load_state(), _core.TimeTable(), _core.TimeTable(),
                                                   [0.0, 0.01], _core.TransientOptions(), None),
    lambda m, s: _core.integrate_ida(m.core, s, m.load_state(), _core.TimeTable(), _core.TimeTable(),
                                     [0.0, 0.01], _core.TransientOptions(), None),
], ids=["assemble", "external_forces", "gravity_potential", "generalized_alpha", "ida"])
def test_core_entry_points_check_the_state(call, m2, m8):
    """The C++ entry points themselves refuse a state of another model (they read
    6 coordinates per node of the model: past the end of a shorter state)."""
    with pytest.raises(ValueError, match="the state has 3 nodes, the model 9: a state of another model"):
        call(m8, m2.initial_state())


def test_core_vectors_and_indices_are_checked(m4):
    st = m4.initial_state()
    with pytest.raises(ValueError, match="increment must have n_dofs = 24 entries, got 3"):
        _core.add_increment(m4.core, st, np.zeros(3), "q")
    with pytest.raises(ValueError, match="vector to reduce must have 6 entries per node"):
        _core.reduce(m4.core, np.zeros(7))
    with pytest.raises(ValueError, match=r"node must be in \[0, 5\), got 99"):
        st.frame(99)
    with pytest.raises(ValueError, match=r"node must be in \[0, 5\), got -1"):
        st.rotation(-1)
    with pytest.raises(ValueError, match=r"pipe element index must be in \[0, 4\)"):
        m4.core.pipe(4)


def test_changed_core_model_must_be_finalized_again():
    core = _core.Model()
    a, b = core.add_node(np.zeros(3)), core.add_node(np.array([1.0, 0.0, 0.0]))
    with pytest.raises(ValueError, match=r"q must be a node index in \[0, 2\), got 5"):
        core.add_pipe(a, 5, _core.PipeElementData())
    st = _core.State(core)
    with pytest.raises(ValueError, match="the model is not finalized"):
        _core.external_forces(core, st)


@pytest.fixture(scope="module")
def ffrf():
    return scenes.ffrf_cantilever_pipe(n_bodies=2, elements_per_body=4)


def test_multibody_core_checks_sizes_and_indices(ffrf):
    st, core = ffrf.initial_state(), ffrf.core
    with pytest.raises(ValueError, match="eta, v and a must have"):
        core.integrate(st.r, st.R, st.eta[:-1], st.v, st.a, st.lam, 0.0, _core.TimeTable(), 0.01, [0, 1], 1e-3,
                       0.8, 1e-8, 12, 5)
    with pytest.raises(ValueError, match="out_steps must be increasing step numbers"):
        core.integrate(st.r, st.R, st.eta, st.v, st.a, st.lam, 0.0, _core.TimeTable(), 0.01, [0, 99], 1e-3,
                       0.8, 1e-8, 12, 5)
    nan = st.eta.copy()
    nan[0] = np.nan
    with pytest.raises(ValueError, match="state: all its numbers must be finite"):
        core.integrate(st.r, st.R, nan, st.v, st.a, st.lam, 0.0, _core.TimeTable(), 0.01, [0, 1], 1e-3,
                       0.8, 1e-8, 12, 5)
    with pytest.raises(ValueError, match="node must be in"):
        core.node(st.r, st.R, st.eta, 1, 99)


def test_ffrf_body_data_shapes_are_checked(ffrf):
    d = ffrf.bodies[0].data
    n = d.n
    good = dict(M=d.M, K=d.K, eta0=d.eta0, A=[np.zeros((n, 3))] * 3, Bk=[np.zeros((n, n - 6))] * 3,
                GPhi=[np.zeros((n, n - 6))] * 3, Gx=[np.zeros(n)] * 3, CPhi=np.zeros((n, n - 6)),
                HPhi=np.zeros((n, n - 6)), Cx=np.zeros(n), Hx=np.zeros(n), Ng=np.zeros((n, 3)))
    _core.FfrfBodyData(**good)
    with pytest.raises(ValueError, match=rf"FfrfBodyData: HPhi must be {n} x {n - 6}, got 3 x {n - 6}"):
        _core.FfrfBodyData(**{**good, "HPhi": np.zeros((3, n - 6))})
    with pytest.raises(ValueError, match=r"FfrfBodyData: Ng must be"):
        _core.FfrfBodyData(**{**good, "Ng": np.zeros((n, 2))})


def test_multibody_max_steps_is_honoured(ffrf):
    from pipeflex.multibody import simulate

    with pytest.raises(ValueError, match="gives 100 steps to t_end = 0.1 s; max_steps = 10"):
        simulate(ffrf, 0.1, step=1e-3, max_steps=10)
    with pytest.raises(ValueError, match="max_steps must be a positive integer"):
        simulate(ffrf, 0.1, step=1e-3, max_steps=2.5)
    with pytest.raises(ValueError, match="max_steps = 10000000"):  # the "1e7 s with 1 us steps"
        simulate(ffrf, 1e7, step=1e-6)


def _interrupt_after(seconds):
    import os
    import signal
    import threading

    timer = threading.Timer(seconds, lambda: os.kill(os.getpid(), signal.SIGINT))
    timer.start()
    return timer


def test_ctrl_c_stops_a_multibody_run(ffrf):
    """The multibody integrator polls for Ctrl-C: a run of hours stops within 0.5 s."""
    import time

    from pipeflex.multibody import simulate

    t0 = time.perf_counter()
    timer = _interrupt_after(0.3)
    try:
        with pytest.raises(KeyboardInterrupt):
            simulate(ffrf, 1e3, step=1e-4, n_outputs=2)
    finally:
        timer.cancel()
    assert time.perf_counter() - t0 < 0.3 + 0.5
