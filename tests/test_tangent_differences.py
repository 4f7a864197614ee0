"""The tangent of every element, body, joint and coupling against central differences of
the residual. One route for all: the core's linear_matrices on the equations interface gives
[K; C_q] at a state, residual_differences the (n + nc) x n central differences of
[R + C_q^T lambda; c] over the same coordinates (step 1e-6), at loaded, deformed states
with non-zero multipliers."""
from dataclasses import replace

import numpy as np
import pytest
import scipy.sparse as sp

import pipeflex as pf
from pipeflex import _core
from pipeflex.analysis import constrained
from pipeflex.multibody import MultibodyBuilder, flexible_body, static_equilibrium as mb_static
from pipeflex.state import as_core

H = 1e-6
# central differences: h^2 truncation and eps/h round-off on the residual's scale
TOL = 1e-5
# the bodies' joints, couplings, driving torques and loads: analytic, as exact as the
# differences (observed below 1e-9; the central differences they replace: up to 1e-8)
TOL_JOINTS = 5e-9

SEC = pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0, EA=1e5, GJ=8.0, rotary_inertia=(1e-3, 1e-3, 1e-3))
HUB = pf.PipeSection(EI=1e5, pipe_mass=5.0, rotary_inertia=(1e-2, 1e-2, 1e-2))


def error(out, unloaded=None):
    """The largest error of a column of [K; C_q] against the differences, relative to the
    column's scale. With unloaded (the same at zero multipliers): of the joints' and
    couplings' geometric stiffness d(C_q^T lambda)/dq alone, on its own scale (against the
    elements' and bodies' stiffness, its error would hide under their round-off), on the
    scale of its largest entry."""
    K, _, _, Cq = constrained.from_core(out)
    J = sp.vstack([K, Cq]).toarray()
    D = out["differences"]
    assert D.shape == J.shape
    if unloaded is not None:
        K0 = constrained.from_core(unloaded)[0].toarray()
        n = K0.shape[0]
        G = K.toarray() - K0
        return np.abs(G - (D[:n] - unloaded["differences"][:n])).max() / np.abs(G).max()
    # column by column, so that a soft coordinate's error is not hidden by a stiff one's
    # scale (axial 1e5 N against the joints' reaction stiffness of ~1 N); the floor for
    # columns without stiffness from the typical column, not the stiffest (a rigid hub's
    # 1e16 N/m axial stiffness would hide every other column's error)
    col = np.abs(J).max(axis=0)
    scale = np.maximum(col, 1e-6 * np.median(col))
    return (np.abs(J - D).max(axis=0) / scale).max()


def element_error(model, state, mass_flow):
    out = _core.linear_matrices(model.system(as_core(model, state), mass_flow=mass_flow), mass_flow, H)
    return error(out)


def test_pipe_elements_curved_spinning_with_flow():
    """The sprinkler turning steadily (velocities, centripetal and Coriolis forces of the
    structure and the flow), its hinge a support."""
    model = pf.scenes.sprinkler(EI=100.0)
    assert element_error(model, pf.steady_rotation(model).state, 10.0) < TOL


def test_pipe_elements_deflected_with_flow_and_a_tip_force():
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    nodes = b.add_line(n0, (1.0, 0.0, 0.0), 6, SEC)
    b.clamp(n0)
    b.add_load(nodes[-1], force=(0.0, 1.5, 0.5), moment=(0.1, 0.0, 0.0))
    b.set_gravity((0.0, 0.0, -9.81))
    model = b.build(mass_flow=10.0)
    assert element_error(model, pf.static_equilibrium(model).state, 10.0) < TOL


def test_ancf_elements_rotating():
    model = pf.scenes.rotating_cantilever(n_elements=4)
    state = pf.rotating_state(model, 3.0)
    assert element_error(model, state, 0.0) < TOL


def bodies_error(system, mass_flow):
    st = mb_static(system, mass_flow=mass_flow).state
    assert np.abs(st.lam).max() > 0.0

    def matrices(lam):
        return _core.linear_matrices(system.system(replace(st, lam=lam)), mass_flow, H)
    out = matrices(st.lam)
    return max(error(out), error(out, matrices(0.0 * st.lam)))


def test_bodies_with_rigid_joints_and_flow():
    assert bodies_error(pf.scenes.ffrf_cantilever_pipe(n_bodies=3, elements_per_body=4, tip_force=1.5),
                        20.0) < TOL_JOINTS


@pytest.mark.parametrize("joint", ["hinge", "spherical"])
def test_bodies_with_hinge_and_spherical_joints(joint):
    """A curved body and a straight one: clamped, then joined by a hinge (about the
    loaded z axis: its free rotation is unloaded) or a spherical joint (the second body
    clamped at its tip), under gravity and a tip load."""
    mb = MultibodyBuilder()
    a = mb.add_body(flexible_body(length=0.5, n_elements=4, section=SEC), position=(0.25, 0.0, 0.0))
    b = mb.add_body(flexible_body(length=0.5, n_elements=4, section=SEC), position=(0.75, 0.0, 0.0))
    mb.fix(a, "start")
    if joint == "hinge":
        mb.hinge(a, "end", (0.0, 0.0, 1.0), b, "start")
        mb.add_load(b, "end", force=(0.0, 0.0, -2.0))
    else:
        mb.spherical(a, "end", b, "start")
        mb.fix(b, "end")
        mb.add_load(b, "end", force=(0.0, 1.0, -2.0))
    mb.set_gravity((0.0, 0.0, -9.81))
    assert bodies_error(mb.build(mass_flow=5.0), 5.0) < TOL_JOINTS


@pytest.mark.parametrize("to", ["body", "ground"])
def test_bodies_with_a_driving_torque_and_a_nodal_moment(to):
    """A driven hinge about z turns the arm (body b) some 30 degrees against gravity along
    +x (its frame's rotation far from the assembly's); a dead force and moment at the
    arm's end twist and bend it out of the plane, so the hinge axis and the torque tilt.
    "body": the hinge at the end of a post clamped to the ground (the torque turns with
    the post's node); "ground": the hinge on the ground, a post rigidly on the arm's end
    and a roller holding the post's end out of the plane (body_b < 0 for a hinge, a roller
    and the torque)."""
    mb = MultibodyBuilder()
    a = mb.add_body(flexible_body(length=0.5, n_elements=4, section=SEC), position=(0.25, 0.0, 0.0))
    b = mb.add_body(flexible_body(length=0.5, n_elements=4, section=SEC), position=(0.75, 0.0, 0.0))
    if to == "body":
        mb.fix(a, "start")
        mb.hinge(b, "start", (0.0, 0.0, 1.0), a, "end", torque=8.0)
        mb.add_load(b, "end", force=(0.0, 0.0, -2.0), moment=(0.5, 0.3, 0.0))
    else:
        mb.hinge(a, "start", (0.0, 0.0, 1.0), torque=20.0)
        mb.rigid(a, "end", b, "start")
        mb.roller(b, "end", (0.0, 0.0, 1.0))
        mb.add_load(a, "end", force=(0.0, 0.0, -2.0), moment=(0.5, 0.3, 0.0))
    mb.set_gravity((9.81, 0.0, 0.0))
    system = mb.build()
    st = mb_static(system, mass_flow=0.0).state
    turned = st.R[b] if to == "body" else st.R[a]
    assert np.degrees(np.arccos(turned[0, 0])) > 10.0
    assert bodies_error(system, 0.0) < TOL_JOINTS


def coupled_error(cs, mass_flow, move=None):
    """The error at the static equilibrium, or at it with its element coordinates moved by
    move(q) (a state where the couplings' equations are not satisfied)."""
    st = pf.static_equilibrium(cs, mass_flow=mass_flow)
    model, b = cs.model, st.body_state
    state = as_core(model, st.state)
    if move is not None:
        q = np.array(state.q)
        move(q)
        state.q = q
    lam = np.asarray(st.coupling_forces, float)
    assert np.abs(lam).max() > 0.0

    def matrices(scale):
        return _core.linear_matrices(cs.system(state, replace(b, lam=scale * b.lam), scale * lam, mass_flow=mass_flow),
                                     mass_flow, H)
    out = matrices(1.0)
    return max(error(out), error(out, matrices(0.0)))


def arm(n=4, tip_force=(0.0, 1.5, -1.0)):
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    nodes = b.add_line(n0, (1.0, 0.0, 0.0), n, SEC)
    b.add_load(nodes[-1], force=tip_force)
    return b.build(mass_flow=10.0, floating=True), n0, nodes[-1]


@pytest.mark.parametrize("kind", ["rigid", "hinge", "spherical"])
def test_couplings_of_pipe_elements_to_bodies(kind):
    """An arm of pipe elements on a hub body clamped to the ground (rigid, or hinged about
    z with its tip held by a spherical coupling to a second clamped body; or spherical at
    both ends), under flow, gravity and a tip load."""
    model, root, tip = arm()
    mb = MultibodyBuilder()
    hub = mb.add_body(flexible_body(length=0.2, n_elements=2, section=HUB), position=(-0.1, 0.0, 0.0))
    mb.fix(hub, "start")
    post = None
    if kind != "rigid":
        post = mb.add_body(flexible_body(length=0.2, n_elements=2, section=HUB), position=(1.1, 0.0, 0.0))
        mb.fix(post, "end")
    mb.set_gravity((0.0, 0.0, -9.81))
    cs = pf.CoupledSystem(model, mb.build())
    if kind == "rigid":
        cs.rigid(root, hub, "end")
    elif kind == "hinge":
        cs.hinge(root, hub, "end", (0.0, 0.0, 1.0))
        cs.spherical(tip, post, "start")
    else:
        cs.spherical(root, hub, "end")
        cs.rigid(tip, post, "start")
    assert coupled_error(cs, 10.0) < TOL_JOINTS


def test_ancf_beam_clamped_to_a_hub_body():
    """A planar ANCF cantilever clamped to a hub body (3 coupling rows), the hub clamped
    to the ground, under in-plane gravity and a tip load: the clamp carries a force and a
    moment (seed 002's free beam on its hub carries none at rest)."""
    b = pf.ModelBuilder()
    nodes = b.add_ancf_beam((0.0, 0.0, 0.0), (1.0, 0.0, 0.0), 6, pf.PipeSection(EI=10.0, EA=1e4, pipe_mass=1.0))
    b.add_load(nodes[-1], force=(0.3, -0.5, 0.0))
    b.set_gravity((0.0, -9.81, 0.0))
    model = b.build(floating=True)
    mb = MultibodyBuilder()
    hub = mb.add_body(flexible_body(length=0.2, n_elements=2, section=HUB), position=(-0.1, 0.0, 0.0))
    mb.fix(hub, "start")
    mb.set_gravity((0.0, -9.81, 0.0))
    cs = pf.CoupledSystem(model, mb.build())
    cs.rigid(nodes[0], hub, "end")
    assert coupled_error(cs, 0.0) < TOL_JOINTS

    def turn_root_slope(q):
        # the slope out of the clamp's direction: its moment row's change with the hub's
        # rotation (lam2 (e x r') . d alpha, zero where the clamp holds) enters
        q[6 * nodes[0] + 3:6 * nodes[0] + 5] = (np.cos(0.1), np.sin(0.1))
    assert coupled_error(cs, 0.0, turn_root_slope) < TOL_JOINTS
