"""Spring-dampers on floating-frame bodies: ``MultibodyBuilder.add_spring`` (axial, between
two body nodes) and ``add_ground_spring`` (to the ground), the element models' spring
kernels (cpp/src/axial_spring.cpp, cpp/src/ground_spring.cpp) acting through the bodies'
node maps (cpp/src/multibody.cpp, MultibodySystemCore::spring_forces)."""
import numpy as np
import pytest

import pipeflex as pf
from pipeflex.multibody import MultibodyBuilder, flexible_body, static_equilibrium
from pipeflex.rotation import rotation_exp

from helpers import moving_body_state, part_of

G = 9.81  # [m/s^2]


def body(length=1.0, *, EI=50.0, EA=2e4, mu=2.0, n_elements=4, internal_modes=0, **section):
    return flexible_body(length=length, n_elements=n_elements, internal_modes=internal_modes,
                         section=pf.PipeSection(EI=EI, EA=EA, pipe_mass=mu, **section))


def two_bodies(springs=True):
    """Two bodies, the first clamped at its start; between them an axial spring-damper
    (across a gap), and ground spring-dampers (translation and rotation) on the second."""
    b = MultibodyBuilder()
    j0 = b.add_body(body(), position=(0.5, 0.0, 0.0))
    j1 = b.add_body(body(0.8), position=(1.6, 0.3, 0.1), rotation=rotation_exp([0.2, -0.3, 0.4]))
    b.fix(j0, "start")
    if springs:
        b.add_spring(j0, "end", j1, "start", stiffness=300.0, damping=4.0)
        b.add_spring(j0, "center", j1, "end", stiffness=120.0)
        b.add_ground_spring(j1, "center", stiffness=(50.0, 80.0, 20.0), damping=(1.0, 2.0, 3.0),
                            rotational_stiffness=(7.0, 3.0, 5.0), rotational_damping=(0.5, 0.2, 0.3))
        b.add_ground_spring(j1, "end", stiffness=(10.0, 0.0, 40.0), anchor=(2.3, 0.2, 0.0))
    return b.build()


@pytest.fixture(scope="module")
def systems():
    return two_bodies(True), two_bodies(False)


def test_stiffness_matches_central_differences(systems):
    sys1, sys0 = systems
    st = moving_body_state(sys1)
    _, K = part_of(sys1, sys0, st, wK=1.0, wC=0.0)
    h = 1e-6
    D = np.empty_like(K)
    for k in range(K.shape[1]):
        dq = np.zeros(K.shape[1])
        dq[k] = h
        plus, minus = st.copy(), st.copy()
        sys1.increment(plus, dq)
        sys1.increment(minus, -dq)
        D[:, k] = (part_of(sys1, sys0, plus, tangent=False)[0] -
                   part_of(sys1, sys0, minus, tangent=False)[0]) / (2 * h)
    scale = np.abs(K).max()
    assert scale > 10.0  # the springs are there
    assert np.abs(K - D).max() <= 1e-6 * scale
    # the velocity's dependence on the configuration (the dampers) is part of it
    st.v[:] = 0.0
    K_rest = part_of(sys1, sys0, st, wK=1.0, wC=0.0)[1]
    assert np.abs(K - K_rest).max() > 1e-3 * scale


def test_damping_matches_central_differences_in_the_velocities(systems):
    sys1, sys0 = systems
    st = moving_body_state(sys1, seed=5)
    _, C = part_of(sys1, sys0, st, wK=0.0, wC=1.0)
    h = 1e-6
    D = np.empty_like(C)
    for k in range(C.shape[1]):
        plus, minus = st.copy(), st.copy()
        plus.v[k] += h
        minus.v[k] -= h
        D[:, k] = (part_of(sys1, sys0, plus, tangent=False)[0] -
                   part_of(sys1, sys0, minus, tangent=False)[0]) / (2 * h)
    assert np.abs(C).max() > 1.0
    assert np.abs(C - D).max() <= 1e-7 * np.abs(C).max()


def test_no_force_under_a_rigid_motion_of_two_bodies_moved_together():
    """An axial spring-damper between two free bodies (each held by a soft ground spring at
    its centre elsewhere): turning and translating both as one rigid body, and moving them
    with one rigid velocity field, leaves the axial spring unstretched and still."""
    def build(with_spring):
        b = MultibodyBuilder()
        a = b.add_body(body(), position=(0.0, 0.0, 0.0))
        c = b.add_body(body(0.6), position=(1.1, 0.4, -0.2), rotation=rotation_exp([0.0, 0.5, 0.3]))
        b.fix(a, "start")
        if with_spring:
            b.add_spring(a, "end", c, "start", stiffness=500.0, damping=7.0)
        b.fix(c, "end")
        return b.build()

    s1, s0 = build(True), build(False)
    st = s1.initial_state()
    rng = np.random.default_rng(1)
    for j in range(2):
        e = s1.eta(st, j)
        e += 0.01 * rng.standard_normal(e.size)  # deformed bodies (the nodes' positions move with them)
    Q, t = rotation_exp([0.7, -1.1, 0.4]), np.array([0.3, -2.0, 1.5])
    w, v0 = np.array([0.3, -0.8, 1.2]), np.array([0.5, 0.1, -0.4])
    moved = st.copy()
    for j in range(2):
        moved.r[j] = Q @ st.r[j] + t
        moved.R[j] = Q @ st.R[j]
        o = int(s1.offsets[j])
        moved.v[o:o + 3] = v0 + np.cross(w, moved.r[j])
        moved.v[o + 3:o + 6] = w
    F_rest = part_of(s1, s0, st, tangent=False)[0]
    F_moved = part_of(s1, s0, moved, tangent=False)[0]
    assert np.abs(F_rest).max() > 0.1  # the deformation stretches it: a force that can turn wrongly
    U0, U1 = s1.spring_energy(st)[0], s1.spring_energy(moved)[0]
    assert U1 == pytest.approx(U0, rel=1e-10)
    assert s1.spring_energy(moved)[1] <= 1e-20  # no dissipation: the distance does not change
    # the generalised forces turn with the frames: the same in the bodies' local axes
    for j in range(2):
        o = int(s1.offsets[j])
        f0, f1 = F_rest[o:o + 6], F_moved[o:o + 6]
        # translation rows are global forces; rotation rows moments about the frame origin
        assert np.allclose(Q @ f0[:3], f1[:3], atol=1e-10 * np.abs(F_rest).max())
        assert np.allclose(f0[6:], f1[6:], atol=1e-10 * np.abs(F_rest).max())


def test_rigid_motion_of_an_unstretched_spring_gives_no_force():
    def build(with_spring):
        b = MultibodyBuilder()
        a = b.add_body(body(), position=(0.0, 0.0, 0.0))
        c = b.add_body(body(0.6), position=(1.1, 0.4, -0.2))
        b.fix(a, "start")
        b.fix(c, "end")
        if with_spring:
            b.add_spring(a, "end", c, "start", stiffness=500.0, damping=7.0)
        return b.build()

    s1, s0 = build(True), build(False)
    st = s1.initial_state()
    Q, t, w = rotation_exp([0.7, -1.1, 0.4]), np.array([0.3, -2.0, 1.5]), np.array([0.3, -0.8, 1.2])
    for j in range(2):
        st.r[j] = Q @ st.r[j] + t
        st.R[j] = Q @ st.R[j]
        o = int(s1.offsets[j])
        st.v[o:o + 3] = np.cross(w, st.r[j]) + 0.2
        st.v[o + 3:o + 6] = w
    F = part_of(s1, s0, st, tangent=False)[0]
    assert np.abs(F).max() <= 1e-12 * 500.0
    assert s1.spring_energy(st)[0] <= 1e-24


def hanging(k, *, c=(0.0, 0.0, 0.0), gravity=True, EI=5e4):
    """One body held only by a ground spring at its centre (translation k [N/m] along every
    axis, rotation held by a rotational spring), under its weight along -z."""
    b = MultibodyBuilder()
    j = b.add_body(body(EI=EI, rotary_inertia=(2e-4, 1e-4, 1e-4)), position=(0.0, 0.0, 0.0))
    b.add_ground_spring(j, "center", stiffness=(k, k, k), damping=c, rotational_stiffness=(30.0, 30.0, 30.0))
    if gravity:
        b.set_gravity((0.0, 0.0, -G))
    return b.build()


def test_a_body_hanging_on_a_ground_spring_sinks_by_its_weight_over_k():
    k = 2000.0
    system = hanging(k)
    res = static_equilibrium(system)
    z = system.node_position(res.state, 0, "center")[2]
    W = system.total_mass * G
    assert z == pytest.approx(-W / k, rel=1e-9)
    U, _ = system.spring_energy(res.state)
    assert U == pytest.approx(0.5 * W**2 / k, rel=1e-8)  # part of the system's energy
    plain = system.energy(res.state) - U
    assert system.energy(res.state) == pytest.approx(plain + 0.5 * W**2 / k, rel=1e-12)


def test_damped_body_spring_decays_at_its_damping_ratio():
    """The body's bounce on its spring-damper (the body stiff: its bending far above): the
    eigenvalue of the linearisation and the free decay of a transient."""
    k, c = 400.0, 6.0
    system = hanging(k, c=(c, c, c), gravity=False)
    m = system.total_mass
    zeta, wn = c / (2.0 * np.sqrt(k * m)), np.sqrt(k / m)
    lam = pf.eigenvalues(pf.linearize(system)).values
    near = lam[np.argmin(np.abs(lam - wn * (-zeta + 1j * np.sqrt(1 - zeta**2))))]
    assert -near.real / abs(near) == pytest.approx(zeta, rel=1e-4)
    assert abs(near) == pytest.approx(wn, rel=1e-4)
    st = system.initial_state()
    u0 = 0.01
    st.v[2] = u0 * wn  # a push along z
    res = pf.simulate(system, 2.0, state=st, integrator="generalized_alpha", step=2e-4, rho_inf=0.9,
                      n_outputs=201)
    z = res.bodies.node_position(0, "center")[:, 2]
    wd = wn * np.sqrt(1 - zeta**2)
    expected = u0 * wn / wd * np.exp(-zeta * wn * res.t) * np.sin(wd * res.t)
    assert np.abs(z - expected).max() <= 2e-3 * u0
    assert np.abs(z[-40:]).max() < 0.5 * u0  # it decays: the check can fail without the damper


def test_ground_springs_on_a_body_give_the_element_models_frequencies():
    """A free pipe on ground springs at its ends, as an element model and as one floating-
    frame body (Craig-Bampton): the first frequencies agree to the reduction's accuracy."""
    L, n = 2.0, 10
    sec = pf.PipeSection(EI=50.0, pipe_mass=1.5, GJ=40.0, rotary_inertia=(2e-3, 1e-3, 1e-3))
    k, kr = 200.0, (20.0, 0.0, 0.0)
    eb = pf.ModelBuilder()
    nodes = eb.add_line(eb.add_node((-L / 2, 0.0, 0.0)), (L / 2, 0.0, 0.0), n, sec)
    eb.add_ground_spring(nodes[0], stiffness=(k, k, k), rotational_stiffness=kr)
    eb.add_ground_spring(nodes[-1], stiffness=(k, k, k))
    model = eb.build()
    w_el = np.sort(np.abs(pf.eigenvalues(pf.linearize(model)).values.imag))[::2]

    def body_frequencies(**reduction):
        bb = MultibodyBuilder()
        j = bb.add_body(flexible_body(length=L, n_elements=n, section=sec, **reduction), position=(0.0, 0.0, 0.0))
        bb.add_ground_spring(j, "start", stiffness=(k, k, k), rotational_stiffness=kr)
        bb.add_ground_spring(j, "end", stiffness=(k, k, k))
        return np.sort(np.abs(pf.eigenvalues(pf.linearize(bb.build())).values.imag))[::2][:8]

    first = w_el[:8]
    assert first[0] > 1.0  # no free motion: the springs hold all six
    # the unreduced body is the element model
    assert np.allclose(body_frequencies(reduction="full"), first, rtol=1e-5)
    # Craig-Bampton converges to it with the internal modes
    errors = [np.abs(body_frequencies(internal_modes=m) / first - 1.0).max() for m in (6, 12)]
    assert errors[1] < 1e-3
    assert errors[1] < 0.2 * errors[0]


def test_bad_input_names_the_argument():
    b = MultibodyBuilder()
    j = b.add_body(body(), position=(0.0, 0.0, 0.0))
    k = b.add_body(body(), position=(1.0, 0.0, 0.0))  # its start at the end of j
    with pytest.raises(ValueError, match="body_b"):
        b.add_spring(j, "end", 5, "start", stiffness=1.0)
    with pytest.raises(ValueError, match="node_a"):
        b.add_spring(j, 17, k, "start", stiffness=1.0)
    with pytest.raises(ValueError, match="stiffness"):
        b.add_spring(j, "end", k, "start", stiffness=-1.0)
    with pytest.raises(ValueError, match="damping"):
        b.add_spring(j, "end", k, "start", stiffness=1.0, damping=float("nan"))
    with pytest.raises(ValueError, match="both node"):
        b.add_spring(j, "end", j, "end", stiffness=1.0)
    with pytest.raises(ValueError, match="body"):
        b.add_ground_spring(-1, "end", stiffness=(1.0, 1.0, 1.0))
    with pytest.raises(ValueError, match="node"):
        b.add_ground_spring(j, "middle", stiffness=(1.0, 1.0, 1.0))
    with pytest.raises(ValueError, match=r"rotational_stiffness\[1\]"):
        b.add_ground_spring(j, "end", rotational_stiffness=(1.0, -2.0, 0.0))
    with pytest.raises(ValueError, match="stiffness must be 3 numbers"):
        b.add_ground_spring(j, "end", stiffness=5.0)
    with pytest.raises(ValueError, match="all zero"):
        b.add_ground_spring(j, "end")
    with pytest.raises(ValueError, match="anchor"):
        b.add_ground_spring(j, "end", stiffness=(1.0, 1.0, 1.0), anchor=(0.0, np.inf, 0.0))
    # an axial spring across no gap has no axis: refused when the assembly is known
    b.add_spring(j, "end", k, "start", stiffness=1.0)
    with pytest.raises(ValueError, match="no joints and no ground springs"):
        b.build()
    b.fix(j, "start")
    with pytest.raises(ValueError, match="the nodes coincide"):
        b.build()


def element_and_body(k, *, c=0.0, force=0.0, EA=1e3):
    """A pipe cantilever along x (clamped at x = 0, tip at x = 1 m) and a body from x = 1.5 m
    to 2.5 m fixed at its far end, the tip and the body's start joined by an axial
    spring-damper k [N/m], c [N s/m]; a force [N] along x at the tip."""
    sec = pf.PipeSection(EI=20.0, EA=EA, GJ=15.0, pipe_mass=1.0, rotary_inertia=(1e-3, 1e-3, 1e-3))
    eb = pf.ModelBuilder()
    root = eb.add_node((0.0, 0.0, 0.0))
    tip = eb.add_line(root, (1.0, 0.0, 0.0), 4, sec)[-1]
    eb.clamp(root)
    if force:
        eb.add_load(tip, force=(force, 0.0, 0.0))
    bb = MultibodyBuilder()
    j = bb.add_body(body(EA=1e9, rotary_inertia=(1e-3, 1e-3, 1e-3)), position=(2.0, 0.0, 0.0))
    bb.fix(j, "end")
    cs = pf.CoupledSystem(eb.build(), bb.build())
    if k is not None:
        cs.add_spring(tip, j, "start", stiffness=k, damping=c)
    return cs, tip


def test_spring_between_an_element_node_and_a_body_node_holds_statically():
    k, P, EA = 500.0, 1e-3, 1e3
    cs, tip = element_and_body(k, force=P, EA=EA)
    res = pf.static_equilibrium(cs)
    u = res.state.q[6 * tip] - 1.0
    assert u == pytest.approx(P / (EA / 1.0 + k), rel=1e-6)  # the tip's axial stiffness and the spring in parallel


def test_spring_between_an_element_node_and_a_body_node_has_exact_tangents():
    """K of the coupled system (the spring-damper moving: its direction and the body node's
    velocity change with the configuration) against the core's central differences."""
    from pipeflex import _core
    from pipeflex.analysis import constrained
    from pipeflex.state import as_core

    def linear(cs):
        rng = np.random.default_rng(4)
        s = as_core(cs.model, None)
        _core.add_increment(cs.model.core, s, 0.02 * rng.standard_normal(cs.model.n_dofs), "q")
        _core.add_increment(cs.model.core, s, 0.5 * rng.standard_normal(cs.model.n_dofs), "v")
        bs = cs.bodies.initial_state()
        e = cs.bodies.eta(bs, 0)
        e += 1e-3 * rng.standard_normal(e.size)
        bs.v[:] = 0.5 * rng.standard_normal(bs.v.size)
        out = _core.linear_matrices(cs.system(s, bs), 0.0, 1e-6)
        K, _, _, Cq = constrained.from_core(out)
        return np.vstack([K.toarray(), Cq.toarray()]), out["differences"]

    J, D = linear(element_and_body(800.0, c=30.0)[0])
    col = np.abs(J).max(axis=0)
    assert (np.abs(J - D).max(axis=0) / np.maximum(col, 1e-6 * np.median(col))).max() < 1e-5
    J0, _ = linear(element_and_body(None)[0])
    assert np.abs(J - J0).max() > 100.0  # the spring is in it


def test_springs_survive_pickles(systems):
    import pickle

    sys1, _ = systems
    st = moving_body_state(sys1)
    again = pickle.loads(pickle.dumps(sys1))
    F1, F2 = sys1.evaluate(st, mass_flow=0.0, tangent=False)[0], again.evaluate(st, mass_flow=0.0, tangent=False)[0]
    assert np.array_equal(F1, F2)
    assert again.spring_energy(st)[0] == sys1.spring_energy(st)[0] > 0.0
