"""Bushings: linear 6-DOF spring-dampers between two nodes (``ModelBuilder.add_bushing``,
``MultibodyBuilder.add_bushing``, ``CoupledSystem.add_bushing``; cpp/src/bushing.cpp),
translational and rotational stiffness and damping about the global axes, the nodes
allowed to coincide: exact tangents, the physics of a stiff joint and of an elastic hinge,
energy and damping work in transients."""
import numpy as np
import pytest

import pipeflex as pf
from pipeflex import _core
from pipeflex.analysis import constrained
from pipeflex.rotation import rotation_exp
from pipeflex.state import as_core

from helpers import moving_body_state, part_of, residual_columns

L, EI, N_EL = 2.0, 40.0, 4  # cantilever length [m], bending stiffness [N m^2], elements
SECTION = pf.PipeSection(EI=EI, EA=4e5, GJ=30.0, pipe_mass=1.5, fluid_mass=0.5, rotary_inertia=(1e-3, 1e-3, 1e-3))
K3, C3 = (300.0, 500.0, 200.0), (3.0, 5.0, 2.0)  # [N/m], [N s/m]
KR3, CR3 = (20.0, 35.0, 50.0), (0.5, 0.8, 1.1)  # [N m/rad], [N m s/rad]


def joined_model():
    """A cantilever whose tip carries a node D at the same position (a point mass with
    inertia) joined to it by a bushing with all stiffnesses and dampers, and a node E away
    from it joined to D by a translational bushing (a reference offset); gravity, a load."""
    b = pf.ModelBuilder()
    root = b.add_node((0.0, 0.0, 0.0))
    tip = b.add_line(root, (L, 0.0, 0.0), N_EL, SECTION)[-1]
    d = b.add_node((L, 0.0, 0.0))
    e = b.add_node((L + 0.3, 0.2, -0.1))
    b.clamp(root)
    b.add_point_mass(d, 0.4, (2e-3, 3e-3, 4e-3))
    b.add_point_mass(e, 0.2, (1e-3, 1e-3, 1e-3))
    b.fix(e, ["rx", "ry", "rz"])
    assert b.add_bushing(tip, d, stiffness=K3, damping=C3, rotational_stiffness=KR3, rotational_damping=CR3) == 0
    assert b.add_bushing(d, e, stiffness=(80.0, 120.0, 60.0), damping=(1.0, 0.0, 2.0)) == 1
    b.add_load(tip, force=(0.0, 2.0, -1.0))
    b.set_gravity((0.0, 0.0, -9.81))
    return b.build(), tip, d


def moving_state(model, tip, d):
    """Displaced and moving; the tip's and D's frames re-based to different rotations of
    about 1 rad (their relative rotation then through the logarithm of R_d R_tip^T)."""
    rng = np.random.default_rng(7)
    s = model.initial_state()
    frames = np.array(s.frames)
    frames[tip] = rotation_exp(np.array([0.7, -0.9, 0.6]))
    frames[d] = rotation_exp(np.array([0.3, -0.5, 1.1]))
    s.frames = frames
    _core.add_increment(model.core, s, 0.05 * rng.standard_normal(model.n_dofs), "q")
    _core.add_increment(model.core, s, 0.5 * rng.standard_normal(model.n_dofs), "v")
    return s


def test_element_stiffness_matches_the_differences_oracle():
    """K (the rotational moments' exact derivatives through the logarithm, the dampers'
    through T(phi)) against the core's central differences of the residual."""
    model, tip, d = joined_model()
    out = _core.linear_matrices(model.system(as_core(model, moving_state(model, tip, d))), 0.0, 1e-6)
    Kc = constrained.from_core(out)[0].toarray()
    D = out["differences"]
    col = np.abs(Kc).max(axis=0)
    assert (np.abs(Kc - D).max(axis=0) / col).max() < 1e-7
    # the oracle can fail: without the rotations' rates (the dampers' T(phi) dependence) D differs
    still = model.initial_state()
    still.q, still.frames = moving_state(model, tip, d).q, moving_state(model, tip, d).frames
    K0 = constrained.from_core(_core.linear_matrices(model.system(as_core(model, still)), 0.0, 1e-6))[0].toarray()
    assert (np.abs(K0 - D).max(axis=0) / col).max() > 1e-4


def test_element_damping_matches_differences_in_the_velocities():
    model, tip, d = joined_model()
    s = moving_state(model, tip, d)
    load = model.load_state()
    n = model.n_dofs
    _, (i, j, v) = _core.assemble(model.core, s, load, 1.0, 0.0, 1.0, 0.0)
    Cm = np.zeros((n, n))
    np.add.at(Cm, (i, j), v)
    Cfd = residual_columns(model, s, load, "v", 1e-3)  # linear in v: central differences exact
    assert np.abs(Cm).max() > 1.0
    assert np.abs(Cm - Cfd).max() <= 1e-8 * np.abs(Cm).max()


def pair(*, k=K3, c=(0.0, 0.0, 0.0), k_phi=KR3, c_phi=(0.0, 0.0, 0.0), offset=(0.0, 0.0, 0.0)):
    """Node A (fixed) and node B (a point mass with inertia, free) joined by a bushing."""
    b = pf.ModelBuilder()
    a = b.add_node((0.1, -0.2, 0.3))
    nb = b.add_node(np.array((0.1, -0.2, 0.3)) + offset)
    b.clamp(a)
    b.add_point_mass(nb, 0.5, (2e-3, 3e-3, 4e-3))
    b.add_bushing(a, nb, stiffness=k, damping=c, rotational_stiffness=k_phi, rotational_damping=c_phi)
    return b.build()


def residual(model, s):
    return _core.assemble(model.core, s, model.load_state(), 1.0, 0.0, 0.0, 0.0, False)[0]


def test_no_force_under_rigid_motions_of_both_nodes():
    """The translational part vanishes when both nodes move by the same vector (any
    rotation), the rotational part when both turn by the same rotation; the energy too."""
    b = pf.ModelBuilder()
    a = b.add_node((0.0, 0.0, 0.0))
    c = b.add_node((0.5, 0.2, 0.0))  # an offset d0
    b.add_ground_spring(a, stiffness=(1.0, 1.0, 1.0), rotational_stiffness=(1.0, 1.0, 1.0))
    b.add_point_mass(c, 1.0, (1e-3, 1e-3, 1e-3))
    b.add_bushing(a, c, stiffness=K3, rotational_stiffness=KR3)
    with_b = b.build()
    b0 = pf.ModelBuilder()
    b0.add_node((0.0, 0.0, 0.0))
    c0 = b0.add_node((0.5, 0.2, 0.0))
    b0.add_ground_spring(0, stiffness=(1.0, 1.0, 1.0), rotational_stiffness=(1.0, 1.0, 1.0))
    b0.add_point_mass(c0, 1.0, (1e-3, 1e-3, 1e-3))
    b0.add_ground_spring(c0, damping=(1.0, 0.0, 0.0))  # at rest: no force; only to build
    without = b0.build()
    s = with_b.initial_state()
    q = np.array(s.q)
    q[0:3] += (0.3, -0.7, 0.2)
    q[6:9] += (0.3, -0.7, 0.2)
    s.q = q
    s.frames = np.array([rotation_exp([0.4, -1.2, 0.9])] * 2)
    r = residual(with_b, s) - residual(without, s)
    assert np.abs(r).max() <= 1e-12 * max(K3)
    # the oracle can fail: a relative rotation gives a moment, a relative shift a force
    s.frames = np.array([rotation_exp([0.4, -1.2, 0.9]), rotation_exp([0.4, -1.2, 0.95])])
    assert np.abs(residual(with_b, s) - residual(without, s)).max() > 0.1


def test_the_nodes_may_coincide_and_rotation_needs_frame_nodes():
    model = pair()
    assert model.springs[0].kind == "bushing" and model.springs[0].rotational_stiffness == KR3
    assert "bushing" in repr(model)
    b = pf.ModelBuilder()
    nodes = b.add_ancf_beam((0.0, 0.0, 0.0), (1.0, 0.0, 0.0), 2, pf.PipeSection(EI=1.0, EA=10.0, pipe_mass=1.0))
    other = b.add_ancf_beam((1.0, 0.0, 0.0), (2.0, 0.0, 0.0), 2, pf.PipeSection(EI=1.0, EA=10.0, pipe_mass=1.0))
    with pytest.raises(ValueError, match="ANCF node.*rotational_stiffness"):
        b.add_bushing(nodes[-1], other[0], stiffness=(1.0, 1.0, 1.0), rotational_stiffness=(0.0, 0.0, 1.0))
    b.add_bushing(nodes[-1], other[0], stiffness=(1e3, 1e3, 0.0))  # translation only: accepted
    b.clamp(nodes[0])
    b.build()


def test_bad_input_names_the_parameter():
    b = pf.ModelBuilder()
    a = b.add_node((0.0, 0.0, 0.0))
    c = b.add_node((0.0, 0.0, 0.0))
    for kw, match in ((dict(stiffness=(1.0, -1.0, 0.0)), r"stiffness\[1\]"),
                      (dict(damping=(1.0, 2.0)), "damping must be 3 numbers"),
                      (dict(rotational_stiffness=(np.nan, 0.0, 0.0)), r"rotational_stiffness\[0\]"),
                      (dict(rotational_damping="x"), "rotational_damping"),
                      (dict(), "needs a stiffness or a damping")):
        with pytest.raises(ValueError, match=match):
            b.add_bushing(a, c, **kw)
    with pytest.raises(ValueError, match="both node 0"):
        b.add_bushing(a, a, stiffness=(1.0, 1.0, 1.0))
    with pytest.raises(ValueError, match="node_b"):
        b.add_bushing(a, 7, stiffness=(1.0, 1.0, 1.0))


def frequencies(model, n):
    """The lowest n natural frequencies [rad/s] of an undamped model."""
    w = pf.eigenvalues(pf.linearize(model)).values.imag
    return np.sort(w[w > 1e-6])[:n]


def two_cantilevers(joint, n_el=6):
    """A cantilever of length L along x, continuous (joint None) or cut at L / 2 into two
    lines with a node each at the cut, joined by a bushing with the keyword arguments
    ``joint``; the tip's node."""
    b = pf.ModelBuilder()
    root = b.add_node((0.0, 0.0, 0.0))
    mid = b.add_line(root, (L / 2, 0.0, 0.0), n_el // 2, SECTION)[-1]
    start = mid if joint is None else b.add_node((L / 2, 0.0, 0.0))
    tip = b.add_line(start, (L, 0.0, 0.0), n_el // 2, SECTION)[-1]
    b.clamp(root)
    if joint is not None:
        b.add_bushing(mid, start, **joint)
    return b, tip


def test_a_stiff_bushing_joins_two_lines_into_the_continuous_beam():
    """A bushing of large stiffness between coinciding end nodes of two lines: the
    continuous beam's lowest frequencies (bending in both planes) to 1e-5
    (the joint's compliance relative to the beam's, k = 1e8 EI / L^3)."""
    k, kr = 1e8 * EI / L**3, 1e8 * EI / L
    stiff = two_cantilevers(dict(stiffness=(k, k, k), rotational_stiffness=(kr, kr, kr)))[0].build()
    whole = two_cantilevers(None)[0].build()
    w, w0 = frequencies(stiff, 6), frequencies(whole, 6)
    assert np.abs(w / w0 - 1.0).max() < 1e-5
    # a soft rotational stiffness about z: an elastic hinge, the bending in the x-y plane lower
    hinged = two_cantilevers(dict(stiffness=(k, k, k), rotational_stiffness=(kr, kr, 0.1 * EI / L)))[0].build()
    assert frequencies(hinged, 1)[0] < 0.5 * w0[0]


def test_an_elastic_hinge_bends_by_its_moment_over_k_phi():
    """Statics: a tip force P across the beam at L, the lines joined at a = L / 2 by a
    bushing of stiffness k across and k_phi about z: the tip deflects by P L^3 / (3 EI)
    (the beam) + P (L - a)^2 / k_phi (the hinge turning by its moment P (L - a) over
    k_phi, carried over the arm L - a) + P / k (the joint's shear), springs in series."""
    k, kr, k_phi, P = 1e3 * EI / L**3, 1e3 * EI / L, 30.0, 1e-4
    b, tip = two_cantilevers(dict(stiffness=(k, k, k), rotational_stiffness=(kr, kr, k_phi)))
    b.add_load(tip, force=(0.0, P, 0.0))
    u = pf.static_equilibrium(b.build()).state.q[6 * tip + 1]
    a = L / 2
    assert u == pytest.approx(P * L**3 / (3 * EI) + P * (L - a) ** 2 / k_phi + P / k, rel=1e-6)


def test_two_inertias_on_a_torsional_bushing_are_the_two_dof_oscillator():
    """Node A (inertia J_a about z) on a ground rotational spring k_g, node B (J_b) joined
    to it by a bushing k_phi about z, only the rotations about z free: the eigenvalues of
    [[k_g + k_phi, -k_phi], [-k_phi, k_phi]] x = w^2 diag(J_a, J_b) x."""
    J_a, J_b, k_g, k_phi = 0.02, 0.05, 7.0, 3.0
    b = pf.ModelBuilder()
    a = b.add_node((0.0, 0.0, 0.0))
    c = b.add_node((0.0, 0.0, 0.0))
    b.add_point_mass(a, 1.0, (1e-3, 1e-3, J_a))
    b.add_point_mass(c, 1.0, (1e-3, 1e-3, J_b))
    b.add_ground_spring(a, rotational_stiffness=(0.0, 0.0, k_g))
    b.add_bushing(a, c, rotational_stiffness=(0.0, 0.0, k_phi))
    for n in (a, c):
        b.fix(n, ["ux", "uy", "uz", "rx", "ry"])
    w = frequencies(b.build(), 2)
    Km = np.array([[k_g + k_phi, -k_phi], [-k_phi, k_phi]])
    w_exact = np.sqrt(np.sort(np.linalg.eigvals(np.linalg.solve(np.diag([J_a, J_b]), Km)).real))
    assert w == pytest.approx(w_exact, rel=1e-12)


def swinging_pair(model, w0=(3.0, -2.0, 4.0), v0=(0.5, -0.3, 0.2)):
    """Node B of :func:`pair` moving and turning (1 node, 6 coordinates after node A's)."""
    s = model.initial_state()
    v = np.array(s.v)
    v[6:9], v[9:12] = v0, w0
    s.v = v
    return s


def test_an_undamped_bushing_conserves_energy_through_large_rotations():
    """A body on a bushing, anisotropic in translation and rotation, swinging through
    relative rotations of about 1 rad: E = T + U constant to the integrator's accuracy
    (second order in the step), and U is the bushing's psi^T K_phi psi / 2 + u^T K u / 2."""
    model = pair(offset=(0.2, 0.0, 0.0))
    s = swinging_pair(model)
    runs = [pf.simulate(model, 1.0, state=s, integrator="generalized_alpha", step=h, rho_inf=1.0, n_outputs=21,
                        progress=False) for h in (2e-3, 1e-3)]
    E0 = runs[0].energy[0]
    assert E0 == pytest.approx(0.5 * 0.5 * np.dot((0.5, -0.3, 0.2), (0.5, -0.3, 0.2)) +
                               0.5 * (2e-3 * 9.0 + 3e-3 * 4.0 + 4e-3 * 16.0), rel=1e-12)
    assert runs[0].elastic.max() > 0.5 * E0  # it swings through its spring
    drift = [np.abs(r.energy - E0).max() / E0 for r in runs]
    assert drift[1] < 1e-4 and 3.0 < drift[0] / drift[1] < 5.0, drift


def test_a_damped_bushing_dissipates_exactly_its_damping_work():
    """E - E0 + D = 0 (D the dissipated energy, the dampers' power dv^T C dv +
    dw^T C_phi dw integrated) to second order in the step, the dampers taking most of E0."""
    model = pair(c=C3, c_phi=(0.01, 0.02, 0.015), offset=(0.2, 0.0, 0.0))
    runs = [pf.simulate(model, 1.0, state=swinging_pair(model), integrator="generalized_alpha", step=h,
                        rho_inf=1.0, n_outputs=51, progress=False) for h in (1e-3, 5e-4)]
    r = runs[0]
    D = r.dissipated
    assert np.all(np.diff(D) >= 0.0) and D[-1] > 0.5 * r.energy[0]
    without = np.abs(r.energy - r.energy[0]).max() / r.energy[0]
    errors = [np.abs(x.energy_balance()).max() / x.energy[0] for x in runs]
    assert errors[0] < 2e-3 * without and 3.0 < errors[0] / errors[1] < 5.0, errors


# -- bodies -------------------------------------------------------------------------------
def body(length=1.0, *, EI=50.0, EA=2e4, mu=2.0, n_elements=4, **section):
    from pipeflex.multibody import flexible_body

    return flexible_body(length=length, n_elements=n_elements, internal_modes=0,
                         section=pf.PipeSection(EI=EI, EA=EA, pipe_mass=mu, **section))


def two_bodies(bushings=True, gravity=None):
    """Two bodies, the first clamped at its start; a bushing (all six stiffnesses and
    dampers) between the first's end and the second's start, which coincide, and a
    translational one across a gap."""
    from pipeflex.multibody import MultibodyBuilder

    b = MultibodyBuilder()
    j0 = b.add_body(body(), position=(0.5, 0.0, 0.0))  # from x = 0 to 1 m
    R1 = rotation_exp([0.2, -0.3, 0.4])
    j1 = b.add_body(body(0.8), position=(1.0, 0.0, 0.0) + R1 @ (0.4, 0.0, 0.0), rotation=R1)  # start at 0's end
    b.fix(j0, "start")
    b.add_ground_spring(j1, "end", stiffness=(10.0, 20.0, 30.0))  # so that the system without bushings builds
    if bushings:
        assert b.add_bushing(j0, "end", j1, "start", stiffness=K3, damping=C3, rotational_stiffness=KR3,
                             rotational_damping=CR3) == 1
        b.add_bushing(j0, "center", j1, "end", stiffness=(50.0, 0.0, 70.0), damping=(0.0, 2.0, 0.0))
    if gravity is not None:
        b.set_gravity(gravity)
    return b.build()


@pytest.fixture(scope="module")
def body_systems():
    return two_bodies(True), two_bodies(False)


def test_body_bushing_stiffness_and_damping_match_central_differences(body_systems):
    sys1, sys0 = body_systems
    st = moving_body_state(sys1)
    _, K = part_of(sys1, sys0, st, wK=1.0, wC=0.0)
    _, C = part_of(sys1, sys0, st, wK=0.0, wC=1.0)
    h = 1e-6
    DK, DC = np.empty_like(K), np.empty_like(C)
    for k in range(K.shape[1]):
        dq = np.zeros(K.shape[1])
        dq[k] = h
        plus, minus = st.copy(), st.copy()
        sys1.increment(plus, dq)
        sys1.increment(minus, -dq)
        DK[:, k] = (part_of(sys1, sys0, plus, tangent=False)[0] -
                    part_of(sys1, sys0, minus, tangent=False)[0]) / (2 * h)
        plus, minus = st.copy(), st.copy()
        plus.v[k] += h
        minus.v[k] -= h
        DC[:, k] = (part_of(sys1, sys0, plus, tangent=False)[0] -
                    part_of(sys1, sys0, minus, tangent=False)[0]) / (2 * h)
    assert np.abs(K).max() > 100.0 and np.abs(C).max() > 1.0
    assert np.abs(K - DK).max() <= 1e-7 * np.abs(K).max()
    assert np.abs(C - DC).max() <= 1e-8 * np.abs(C).max()


def test_body_bushing_energy_is_zero_under_a_rigid_motion_of_both_bodies():
    """Two bodies joined end to start by a bushing (coinciding nodes): moved and turned
    together they store nothing; body 1 turned alone, its psi^T K_phi psi / 2."""
    from pipeflex.multibody import MultibodyBuilder

    b = MultibodyBuilder()
    j0 = b.add_body(body(), position=(0.5, 0.0, 0.0))  # from x = 0 to 1 m
    R1 = rotation_exp([0.2, -0.3, 0.4])
    j1 = b.add_body(body(0.8), position=(1.0, 0.0, 0.0) + R1 @ (0.4, 0.0, 0.0), rotation=R1)  # start at 0's end
    b.fix(j0, "start")
    b.add_bushing(j0, "end", j1, "start", stiffness=K3, rotational_stiffness=KR3)
    system = b.build()
    st = system.initial_state()
    assert np.abs(system.node_position(st, j0, "end") - system.node_position(st, j1, "start")).max() < 1e-15
    st = system.initial_state()
    A, t = rotation_exp([0.5, -0.8, 1.1]), np.array([0.3, 0.1, -0.2])
    for j in range(2):
        st.r[j] = A @ st.r[j] + t
        st.R[j] = A @ st.R[j]
    assert system.spring_energy(st)[0] <= 1e-28 * max(KR3)
    st = system.initial_state()
    p = system.node_position(st, j1, "start")
    psi = np.array([0.3, -0.2, 0.25])
    st.R[j1] = rotation_exp(psi) @ st.R[j1]
    st.r[j1] = p + rotation_exp(psi) @ (st.r[j1] - p)  # turned about the joint
    assert system.spring_energy(st)[0] == pytest.approx(0.5 * np.dot(KR3, psi**2), rel=1e-12)


# -- coupled systems ----------------------------------------------------------------------
def element_and_body(joint, *, ancf=False, gravity=None):
    """A pipe cantilever along x (clamped at x = 0, tip at x = 1 m) and a body from x = 1 m
    to 2 m, free, its start at the tip: ``joint`` "rigid" (a rigid coupling), None
    (nothing), or the keyword arguments of a bushing there."""
    from pipeflex.multibody import MultibodyBuilder

    sec = pf.PipeSection(EI=20.0, EA=1e3, GJ=15.0, pipe_mass=1.0, rotary_inertia=(1e-3, 1e-3, 1e-3))
    eb = pf.ModelBuilder()
    root = eb.add_node((0.0, 0.0, 0.0))
    tip = eb.add_line(root, (1.0, 0.0, 0.0), 4, sec)[-1]
    eb.clamp(root)
    bb = MultibodyBuilder()
    j = bb.add_body(body(EI=30.0, EA=1e3, GJ=20.0, rotary_inertia=(1e-3, 1e-3, 1e-3)), position=(1.5, 0.0, 0.0))
    bb.add_ground_spring(j, "end", stiffness=(5.0, 8.0, 3.0), rotational_stiffness=(1.0, 2.0, 3.0))
    if gravity is not None:
        eb.set_gravity(gravity)
        bb.set_gravity(gravity)
    cs = pf.CoupledSystem(eb.build(), bb.build())
    if joint == "rigid":
        cs.rigid(tip, j, "start")
    elif joint is not None:
        assert cs.add_bushing(tip, j, "start", **joint) == 0
    return cs, tip


def coupled_matrices(cs):
    """K (with the constraint rows) and C of the coupled system at a moving state, and the
    core's central differences of its residual in the positions."""
    rng = np.random.default_rng(4)
    s = as_core(cs.model, None)
    frames = np.array(s.frames)
    frames[4] = rotation_exp([0.4, -0.3, 0.6])  # the tip's frame re-based
    s.frames = frames
    _core.add_increment(cs.model.core, s, 0.02 * rng.standard_normal(cs.model.n_dofs), "q")
    _core.add_increment(cs.model.core, s, 0.5 * rng.standard_normal(cs.model.n_dofs), "v")
    bs = cs.bodies.initial_state()
    bs.r[0] += 0.02 * rng.standard_normal(3)
    bs.R[0] = rotation_exp(0.2 * rng.standard_normal(3)) @ bs.R[0]
    e = cs.bodies.eta(bs, 0)
    e += 1e-3 * rng.standard_normal(e.size)
    bs.v[:] = 0.5 * rng.standard_normal(bs.v.size)
    out = _core.linear_matrices(cs.system(s, bs), 0.0, 1e-6)
    K, C, _, Cq = constrained.from_core(out)
    return np.vstack([K.toarray(), Cq.toarray()]), C.toarray(), out["differences"]


def test_coupled_bushing_has_exact_tangents():
    """K of the coupled system (the element node's own rotation, the body node's stand-in
    frame: its maps turning, its velocity changing with the configuration) against the
    core's central differences."""
    J, C, D = coupled_matrices(element_and_body(dict(stiffness=K3, damping=C3, rotational_stiffness=KR3,
                                                     rotational_damping=CR3))[0])
    col = np.abs(J).max(axis=0)
    assert (np.abs(J - D).max(axis=0) / np.maximum(col, 1e-6 * np.median(col))).max() < 1e-6
    J0, C0, _ = coupled_matrices(element_and_body(None)[0])
    assert np.abs(J - J0).max() > 10.0 and np.abs(C - C0).max() > 0.5  # the bushing is in them


def test_a_stiff_coupled_bushing_is_a_rigid_coupling():
    """The lowest frequencies of the element model and the body joined by a rigid
    coupling, and by a bushing of large stiffness (k = 1e8 EI / L^3, k_phi = 1e8 EI / L)."""
    k, kr = 1e8 * 20.0, 1e8 * 20.0
    rigid = element_and_body("rigid")[0]
    stiff = element_and_body(dict(stiffness=(k, k, k), rotational_stiffness=(kr, kr, kr)))[0]
    w0, w = (pf.eigenvalues(pf.linearize(cs)).values.imag for cs in (rigid, stiff))
    w0, w = (np.sort(x[x > 1e-6])[:6] for x in (w0, w))
    assert np.abs(w / w0 - 1.0).max() < 1e-5


def test_coupled_bushing_input():
    cs, tip = element_and_body(None)
    with pytest.raises(ValueError, match=r"rotational_damping\[2\]"):
        cs.add_bushing(tip, 0, "start", rotational_damping=(0.0, 0.0, -1.0))
    with pytest.raises(ValueError, match="needs a stiffness or a damping"):
        cs.add_bushing(tip, 0, "start")
    with pytest.raises(ValueError, match="body_node"):
        cs.add_bushing(tip, 0, "nowhere", stiffness=(1.0, 1.0, 1.0))


def test_spring_force_sensor_of_a_bushing_is_the_force_on_node_b():
    """spring_force of a bushing: -K (x_b - x_a - d0) - C (v_b - v_a) on node b (node a
    clamped), recorded at every step, against the recorded positions and velocities."""
    from pipeflex import sensor

    model = pair(c=C3, offset=(0.2, 0.0, 0.0))
    res = pf.simulate(model, 0.05, state=swinging_pair(model), integrator="generalized_alpha", step=1e-3,
                      n_outputs=3, progress=False,
                      sensors=[sensor.spring_force(0), sensor.node_position(1), sensor.node_velocity(1)])
    f = res.sensors["spring_force[0]"][1]
    x0 = np.array(model.positions[1])
    u, v = res.sensors["node_position[1]"][1] - x0, res.sensors["node_velocity[1]"][1]
    expected = -np.array(K3) * u - np.array(C3) * v
    assert np.abs(expected).max() > 1.0
    np.testing.assert_allclose(f, expected, rtol=0, atol=1e-12 * np.abs(expected).max())


def test_linearize_sees_the_bushing_stiffness_and_damping():
    """At the reference state K and C of node b are diag(K, K_phi) and diag(C, C_phi)."""
    model = pair(c=C3, c_phi=CR3)
    lin = pf.linearize(model)
    K, C = (np.asarray(x.todense() if hasattr(x, "todense") else x) for x in (lin.K, lin.C))
    dofs = [model.dof_index(1, c) for c in ("ux", "uy", "uz", "rx", "ry", "rz")]
    np.testing.assert_allclose(K[np.ix_(dofs, dofs)], np.diag(K3 + KR3), rtol=1e-14, atol=1e-12)
    np.testing.assert_allclose(C[np.ix_(dofs, dofs)], np.diag(C3 + CR3), rtol=1e-14, atol=1e-12)


def test_a_relative_rotation_of_half_a_turn_is_refused_by_name():
    model = pair()
    s = model.initial_state()
    s.frames = np.array([np.eye(3), rotation_exp([0.0, 0.0, np.pi])])
    with pytest.raises(ValueError, match="bushing between nodes 0 and 1: their relative rotation has reached pi"):
        residual(model, s)
    s.frames = np.array([np.eye(3), rotation_exp([0.0, 0.0, np.pi - 1e-3])])
    assert np.isfinite(residual(model, s)).all()  # just below: exact


def test_spring_force_sensor_of_a_bushing_on_bodies_and_in_a_coupling():
    """spring_force of a bodies' bushing and of a coupling bushing is the force on its node
    b, -K (x_b - x_a) - C (v_b - v_a) for coincident nodes, against the recorded node
    sensors of the same steps."""
    from pipeflex import sensor

    def check(system, spring, a, b, part=None):
        sensors = [sensor.spring_force(spring, part=part, name="f"), sensor.node_position(a, name="xa"),
                   sensor.node_position(b, name="xb"), sensor.node_velocity(a, name="va"),
                   sensor.node_velocity(b, name="vb")]
        res = pf.simulate(system, 0.02, integrator="generalized_alpha", step=1e-3, n_outputs=2, progress=False,
                          sensors=sensors)
        got = {k: res.sensors[k][1] for k in ("f", "xa", "xb", "va", "vb")}
        expected = -np.array(K3) * (got["xb"] - got["xa"]) - np.array(C3) * (got["vb"] - got["va"])
        assert np.abs(expected).max() > 1e-3
        np.testing.assert_allclose(got["f"], expected, rtol=0, atol=1e-9 * np.abs(expected).max())

    check(two_bodies(True, gravity=(0.0, -9.81, 3.0)), 1, (0, "end"), (1, "start"))
    cs, tip = element_and_body(dict(stiffness=K3, damping=C3), gravity=(0.0, -9.81, 3.0))
    check(cs, 0, tip, (0, "start"), part="couplings")
