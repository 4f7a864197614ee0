"""The tangent of every element, body, joint and coupling against central differences of
the residual (issue "One engine": tangent vs finite differences for every element and
joint). One route for all: the core's linear_matrices on the equations interface gives
[K; C_q] at a state, residual_differences the (n + nc) x n central differences of
[R + C_q^T lambda; c] over the same coordinates (step 1e-6), at loaded, deformed states
with non-zero multipliers."""
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

SEC = pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0, EA=1e5, GJ=8.0, rotary_inertia=(1e-3, 1e-3, 1e-3))
HUB = pf.PipeSection(EI=1e5, pipe_mass=5.0, rotary_inertia=(1e-2, 1e-2, 1e-2))


def error(out):
    K, _, _, Cq = constrained.from_core(out)
    J = sp.vstack([K, Cq]).toarray()
    D = out["differences"]
    assert D.shape == J.shape
    # column by column, so that a soft coordinate's error is not hidden by a stiff one's
    # scale (axial 1e5 N against the joints' reaction stiffness of ~1 N)
    scale = np.maximum(np.abs(J).max(axis=0), 1e-6 * np.abs(J).max())
    return (np.abs(J - D).max(axis=0) / scale).max()


def element_error(model, state, mass_flow):
    opt = _core.TransientOptions()
    opt.length_scale = 1.0
    out = _core.element_linear_matrices(model.core, as_core(model, state), model.load_state(mass_flow=mass_flow),
                                        opt, H)
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
    return error(system.core.linear_matrices(st.r, st.R, st.eta, st.v, st.a, st.lam, st.t, mass_flow,
                                             differences_step=H))


def test_bodies_with_rigid_joints_and_flow():
    assert bodies_error(pf.scenes.ffrf_cantilever_pipe(n_bodies=3, elements_per_body=4, tip_force=1.5), 20.0) < TOL


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
    assert bodies_error(mb.build(mass_flow=5.0), 5.0) < TOL


def coupled_error(cs, mass_flow):
    st = pf.static_equilibrium(cs, mass_flow=mass_flow)
    model, bodies, b = cs.model, cs.bodies, st.body_state
    opt = _core.TransientOptions()
    opt.length_scale = 1.0
    out = _core.coupled_linear_matrices(model.core, as_core(model, st.state), model.load_state(mass_flow=mass_flow),
                                        bodies.core, b.r, b.R, b.eta, b.v, b.a, b.lam, cs.core_couplings(),
                                        np.asarray(st.coupling_forces, float), opt, H)
    assert np.abs(st.coupling_forces).max() > 0.0
    return error(out)


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
    assert coupled_error(cs, 10.0) < TOL


def test_ancf_beam_clamped_to_a_hub_body():
    """Seed 002's planar ANCF cantilever clamped to a hub body (3 coupling rows), the hub
    clamped to the ground, under in-plane gravity."""
    cs, _, hub, _ = pf.scenes.beam_on_free_hub(hub_inertia=1.0)
    mb = MultibodyBuilder()
    body = cs.bodies.bodies[hub]
    j = mb.add_body(body, position=cs.bodies.initial_state().r[hub])
    mb.fix(j, "start")
    mb.set_gravity((0.0, -9.81, 0.0))
    fixed = pf.CoupledSystem(cs.model, mb.build())
    for c in cs.joints:
        fixed.rigid(c.node, j, c.body_node)
    assert coupled_error(fixed, 0.0) < TOL
