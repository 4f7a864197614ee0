"""Reliability: a state of another model, vectors of the wrong size and bad indices are
refused at the C++ boundary (ValueError naming the parameter); singular or non-finite
problems are named instead of answered; work is bounded (size and step limits, Ctrl-C)."""
import json

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
    """st.q = np.zeros(3) on a 4-element cantilever is refused when set, naming the size
    (the C++ core would abort on it in simulate)."""
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
    lambda m, s: _core.element_system(m.core, s, m.load_state()),
], ids=["assemble", "external_forces", "gravity_potential", "system"])
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
    a = core.add_node(np.zeros(3))
    core.add_node(np.array([1.0, 0.0, 0.0]))
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
        _core.body_system(core, st.r, st.R, st.eta[:-1], st.v, st.a, st.lam, 0.0)
    with pytest.raises(ValueError, match="times must be strictly increasing"):
        _core.integrate(ffrf.system(st), _core.TimeTable(), _core.TimeTable(), [0.0, 0.01, 0.01],
                        _core.TransientOptions())
    nan = st.eta.copy()
    nan[0] = np.nan
    with pytest.raises(ValueError, match="state: all its numbers must be finite"):
        _core.body_system(core, st.r, st.R, nan, st.v, st.a, st.lam, 0.0)
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
    with pytest.raises(ValueError, match="max_steps = 10000000"):  # 1e7 s in 1 us steps: 1e13 steps
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
            simulate(ffrf, 100.0, step=1e-4, n_outputs=2)
    finally:
        timer.cancel()
    assert time.perf_counter() - t0 < 0.3 + 0.5


# -- 2. no silent garbage ----------------------------------------------------------------

SEC = pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0)


def _beam(n=4, **build):
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    nodes = b.add_line(n0, (1.0, 0.0, 0.0), n, SEC)
    return b, nodes


def test_mechanism_is_named_not_called_divergence():
    """Only ux fixed: a mechanism, named as such, not "divergence" from a round-off
    eigenvalue."""
    b, nodes = _beam()
    b.fix(nodes[0], ("ux",))
    lin = pf.linearize(b.build())
    eig = pf.eigenvalues(lin)  # the eigenvalues themselves are still available (a free hinge has them)
    with pytest.raises(ValueError, match=r"stiffness is singular, a mechanism \(free: nodes 0..4: uy uz rx ry rz\)"):
        pf.stability(eig)


def test_mechanism_named_by_static_equilibrium():
    b, nodes = _beam()
    b.fix(nodes[0], "ux")
    b.add_load(nodes[-1], force=(0.0, 1.0, 0.0))
    with pytest.raises(pf.SingularMatrixError, match=r"tangent is singular .*nodes 0..4: uy uz rx ry rz"):
        pf.static_equilibrium(b.build())


def test_unsupported_part_is_refused():
    b, nodes = _beam(2)
    b.clamp(nodes[0])
    n5 = b.add_node((0.0, 1.0, 0.0))
    b.add_line(n5, (1.0, 1.0, 0.0), 2, SEC)
    with pytest.raises(ValueError, match=r"nodes 3..5 \(3 nodes\) form a part with no supports"):
        b.build()


def test_arc_of_more_than_a_turn_is_refused():
    b = pf.ModelBuilder()
    n0 = b.add_node((1.0, 0.0, 0.0))
    with pytest.raises(ValueError, match=r"angle must be in \[-2 pi, 2 pi\] rad"):
        b.add_arc(n0, center=(0, 0, 0), angle=1e6, normal=(0, 0, 1), n_elements=4, section=SEC)


def test_gravity_that_overflows_is_refused():
    """gravity 1e300 "converged" in 0 iterations with residual inf (inf <= tol inf)."""
    b, nodes = _beam()
    with pytest.raises(ValueError, match=r"gravity must have components of at most 1e\+06 m/s\^2"):
        b.set_gravity((0.0, 0.0, -1e300))


def test_non_finite_force_level_is_refused(m4):
    with pytest.raises(ValueError, match="the model's force level overflows"):
        pf.static_equilibrium(m4, mass_flow=1e200)
    b, nodes = _beam()
    b.clamp(nodes[0])
    b.add_load(nodes[-1], force=(1e308, 1e308, 0.0))
    b.add_load(nodes[-2], force=(1e308, 1e308, 0.0))
    with pytest.raises(pf.ConvergenceError, match="the residual is not finite"):  # not "converged"
        pf.static_equilibrium(b.build(), max_bisections=0)


def test_nan_state_is_refused(m4):
    st = m4.initial_state()
    q = np.array(st.q)
    q[7] = np.nan
    st.q = q
    for analysis in (lambda: pf.static_equilibrium(m4, state=st), lambda: pf.linearize(m4, st),
                     lambda: pf.simulate(m4, 0.01, state=st, progress=False)):
        with pytest.raises(ValueError, match=r"state.q must be finite, got nan at index 7 \(node 1"):
            analysis()


def test_nan_frame_is_refused(m4):
    st = pf.State.from_core(m4.initial_state(), m4)
    frames = st.frames.copy()
    frames[2, 0, 1] = np.inf
    bad = pf.State(st.q, st.v, st.a, frames, st.ancf)
    with pytest.raises(ValueError, match=r"state.frames\[2\] must be finite"):
        pf.static_equilibrium(m4, state=bad)


@pytest.fixture(scope="module")
def rotating():
    return scenes.rotating_cantilever(n_elements=4)


def test_rotating_strain_beyond_validity_is_refused(rotating):
    with pytest.raises(ValueError, match=r"gamma = 1e\+08 gives a first-order axial strain of 1.07e\+11"):
        pf.rotating_frequencies(rotating, gamma=1e8)


def test_resonance_of_a_mode_the_model_lacks(rotating):
    with pytest.raises(ValueError, match=r"mode = 100: the model has 8 transverse modes"):
        pf.resonance_speed(rotating, mode=100)
    with pytest.raises(ValueError, match=r"gamma_range must be \(low, high\) with low < high"):
        pf.resonance_speed(rotating, gamma_range=(5.0, 1.0))


def test_ball_jointed_pipe_under_gravity_is_not_converged():
    """A spherical joint leaves the pipe free to swing: its weight drives the mechanism.
    The static solve left that direction alone and "converged" with a residual of ~20 %
    of the weight."""
    from pipeflex.multibody import MultibodyBuilder, flexible_body, static_equilibrium

    b = MultibodyBuilder()
    j = b.add_body(flexible_body(length=0.5, n_elements=4, section=pf.PipeSection(EI=10.0, pipe_mass=8.0)),
                   position=(0.25, 0.0, 0.0))
    b.spherical(j, "start")
    b.set_gravity((0.0, 0.0, -9.81))
    with pytest.raises(pf.SingularMatrixError, match=r"residual .* of the applied force level .*mechanism"):
        static_equilibrium(b.build())


# -- 3. bounded work ---------------------------------------------------------------------

def test_element_count_is_bounded():
    with pytest.raises(ValueError, match="n_elements = 1000000000 would give the model 1000000000 elements; "
                                         "at most 100000"):
        scenes.cantilever_pipe(n_elements=10**9)


def test_simulate_step_count_is_bounded_before_it_starts(m4):
    with pytest.raises(ValueError, match=r"gives 1e\+13 steps .*max_steps = 10000000"):
        pf.simulate(m4, 1e7, step=1e-6, progress=False)
    with pytest.raises(ValueError, match=r"gives 200 steps .*max_steps = 10 "):
        pf.simulate(m4, 0.1, step=1e-3, max_steps=10, progress=False, integrator="generalized_alpha")


def test_output_count_is_bounded():
    m = scenes.cantilever_pipe(n_elements=2000)
    with pytest.raises(ValueError, match=r"n_outputs: 10000 output times of 36023 values each need 2.68392 GiB; "
                                         r"at most 2 GiB"):
        _core.integrate(m.system(), _core.TimeTable(), _core.TimeTable(), list(np.linspace(0.0, 1.0, 10**4)),
                        _core.TransientOptions())


def test_output_count_is_checked_before_the_times_are_laid_out():
    from pipeflex import _checks

    assert _checks.output_count("n_outputs", 201, 5) == 201
    with pytest.raises(ValueError, match=r"n_outputs = 1000000000000 output times of 5 nodes need 707805 GiB"):
        _checks.output_count("n_outputs", 10**12, 5)


def test_steady_state_far_outside_is_refused_at_once(rotating):
    """gamma = 1e4 with the steady-state linearisation searched for minutes."""
    import time

    t0 = time.perf_counter()
    with pytest.raises(ValueError, match=r"gamma = 10000 gives a first-order axial strain"):
        pf.rotating_frequencies(rotating, gamma=1e4, linearization="steady_state")
    assert time.perf_counter() - t0 < 2.0


# -- unclear messages ----------------------------------------------------------------------

@pytest.mark.parametrize("kwargs, match", [
    (dict(EI="10"), "EI must be a real number, got '10'"),
    (dict(EI=1e-300), r"EI must be in \[1e-20, 1e\+20\] N m\^2"),
    (dict(length=1e200), r"length must be in \[1e-06, 1e\+06\] m"),
])
def test_scene_magnitudes(kwargs, match):
    with pytest.raises(ValueError, match=match):
        scenes.cantilever_pipe(n_elements=4, **kwargs)


def test_fix_takes_one_component_name():
    b, nodes = _beam()
    b.fix(nodes[0], "ux")  # one name, not its letters ("unknown component 'u'")
    b.clamp(nodes[0])
    assert b.build().n_dofs == 24
    with pytest.raises(ValueError, match="unknown component 'ur'"):
        b.fix(nodes[0], "ur")


def test_integral_float_options_are_counts(m4):
    loaded = scenes.cantilever_pipe(n_elements=4, mass_flow=1.0)
    assert pf.static_equilibrium(loaded, max_iterations=25.0).iterations >= 0
    with pytest.raises(ValueError, match="max_iterations must be a positive integer, got 2.5"):
        pf.static_equilibrium(m4, max_iterations=2.5)


def test_wrong_argument_types_are_named(m4):
    with pytest.raises(TypeError, match="lin must be a Linearization"):
        pf.eigenvalues("K")
    with pytest.raises(TypeError, match="eig must be an EigenResult"):
        pf.stability(m4)
    for analysis in (pf.static_equilibrium, pf.linearize, pf.critical_mass_flow,
                     lambda m: pf.rotating_frequencies(m, gamma=1.0)):
        with pytest.raises(TypeError, match=r"model must be a pipeflex.Model .*got tuple \(a tuple: pass the state"):
            analysis((m4, m4.initial_state()))


# -- 4. Craig-Bampton determinism ------------------------------------------------------------

def test_canonical_modes_depend_on_the_subspace_only():
    """Any orthogonal mixture of a degenerate group gives the same canonical modes."""
    from pipeflex.multibody.body import canonical_modes

    rng = np.random.default_rng(1)
    V = np.linalg.qr(rng.standard_normal((12, 5)))[0]
    mu = np.array([3.0, 2.0, 2.0 * (1 + 1e-12), 2.0, 1.0])  # a group of three
    U = np.linalg.qr(rng.standard_normal((3, 3)))[0]
    mixed = V.copy()
    mixed[:, 1:4] = V[:, 1:4] @ U
    mixed[:, 0] *= -1.0
    a, b = canonical_modes(mu, V, 2), canonical_modes(mu, mixed, 2)  # count 2 cuts the group
    np.testing.assert_allclose(a, b, atol=1e-13)
    np.testing.assert_allclose(a.T @ a, np.eye(2), atol=1e-13)


def test_craig_bampton_basis_is_the_same_on_1_and_2_threads():
    """The two bending planes of a round section are a degenerate group whose LAPACK
    eigenvectors change with the number of BLAS threads (by O(1) without a canonical
    basis); internal_modes = 5 also cuts one such pair."""
    from threadpoolctl import threadpool_limits

    from pipeflex.multibody import flexible_body

    sec = pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0, rotary_inertia=(1e-3, 1e-4, 1e-4))
    bases = []
    for threads in (1, 2):
        with threadpool_limits(limits=threads):
            bases.append(np.array(flexible_body(length=1.0, n_elements=200, section=sec, internal_modes=5).basis))
    np.testing.assert_allclose(bases[0], bases[1], atol=1e-8)


def test_a_model_without_free_coordinates_is_not_integrated():
    """Was a segfault in IDA (a band matrix of size 0) and a false "singular mass matrix"
    in generalised-alpha (found by make fuzz)."""
    b = pf.ModelBuilder()
    n0 = b.add_node((0, 0, 0))
    a = b.add_line(n0, (1, 0, 0), 1, pf.PipeSection(EI=1.0, pipe_mass=1.0, rotary_inertia=(1e-3, 1e-3, 1e-3)))
    b.clamp(n0)
    b.clamp(a[-1])
    m = b.build()
    for integrator in ("ida", "generalized_alpha"):
        with pytest.raises(ValueError, match="no free coordinates"):
            pf.simulate(m, 0.01, integrator=integrator, progress=False)


def test_generalized_alpha_counts_failed_steps_against_max_steps():
    """Halved steps count: a run that keeps failing stops at max_steps, not after hours."""
    from helpers import fluttering_cantilever

    m, st = fluttering_cantilever()
    with pytest.raises(ValueError, match="max_steps = 30 steps"):
        pf.simulate(m, 0.25, state=st, integrator="generalized_alpha", step=0.01, max_newton=1,
                    newton_tol=1e-300, max_steps=30, n_outputs=2, progress=False)  # 25 planned; all fail


# A case from the fuzz run (make sanitize): a clamped line-arc-line pipe
# with a point mass of no rotary inertia, near-massless rotations (rotary inertia 5e-7),
# dead forces and moments, linearised at the reference configuration. No flow, no follower
# load: conservative but for a skew part of 8e-12 |K| (the dead moments). The companion
# form's round-off gives its high modes real parts up to 1.44 1/s, which must not be called flutter.
FUZZ_CONSERVATIVE = json.loads('{"sections": [{"EI": 1.0, "pipe_mass": 1.0000000000000004, "fluid_mass": 0.0, "GJ": 1.0, "rotary_inertia": [0.019999539488283265, 0.009999769744141632, 0.009999769744141632]}, {"EI": 0.999999999999892, "pipe_mass": 0.049999999999999996, "fluid_mass": 0.0, "EIz": 0.9998594712340544, "GJ": 0.999999999999892, "rotary_inertia": [1e-06, 5e-07, 5e-07]}], "segments": [{"kind": "line", "direction": [0.0, 0.99999, -5.844284049919781e-191], "length": 0.9999997255105045, "n": 1}, {"kind": "arc", "normal": [-0.9283641952950237, -0.5883199776877347, 1.192092896e-07], "radial": [0.99999, 0.0, 0.2886654263760818], "radius": 1.0, "angle": -5.283185307179586, "n": 2}, {"kind": "line", "direction": [0.0, -1.1125369292536007e-308, 0.3333333333333333], "length": 1.0, "n": 3}], "support": "clamp", "loads": [{"node": 6, "force": [1.175494351e-38, 6.103515625e-05, -5.960464477539063e-08], "moment": [0.40823822427678713, -6.103515625e-05, -1.1125369292536007e-308], "follower": false, "level": 0.4641588833612779}, {"node": 10, "force": [-0.9319007138477817, 2.225073858507e-311, 0.99999], "moment": [1.0, 2.225073858507203e-309, -2.225073858507e-311], "follower": false, "level": 0.4641588833612779}], "gravity": null, "point_masses": [{"node": 6, "mass": 1.0, "inertia": [0.0, 1.401298464324817e-45, 1.401298464324817e-45]}], "flow": 0.0}')


def test_a_nearly_conservative_undamped_model_is_not_called_flutter():
    import sys
    from pathlib import Path
    sys.path.insert(0, str(Path(__file__).parent / "fuzz"))
    import models

    model, mdot = models.build_pipe(FUZZ_CONSERVATIVE)
    lin = pf.linearize(model, mass_flow=mdot)
    K = lin.K.toarray()
    assert 0 < np.abs(K - K.T).max() <= 1e-9 * np.abs(K).max()  # the case still has its skew part
    eig = pf.eigenvalues(lin)
    assert pf.stability(eig) == "stable"
    assert np.abs(eig.values.real).max() == 0.0  # on the axis: the symmetric part's eigenvalues


def test_state_frames_copy_in_and_out_of_the_core(m4):
    """The core state's frames in one call (State.from_core/to_core) equal the node-by-node
    frame(i)/set_frame(i), bit for bit; a wrong shape is refused by name."""
    rng = np.random.default_rng(3)
    core = m4.initial_state()
    for i in range(m4.n_nodes):
        core.set_frame(i, pf.rotation.rotation_exp(rng.normal(size=3)))
    st = pf.State.from_core(core, m4)
    assert np.array_equal(st.frames, np.array([core.frame(i) for i in range(m4.n_nodes)]))
    back = st.to_core(m4)
    assert all(np.array_equal(back.frame(i), core.frame(i)) for i in range(m4.n_nodes))
    with pytest.raises(ValueError, match=r"frames must have shape \(5, 3, 3\)"):
        core.frames = np.zeros((4, 3, 3))
