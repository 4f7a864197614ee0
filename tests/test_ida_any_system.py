"""IDA on every system: floating-frame bodies with joints and coupled systems integrated
in the stabilised index-2 form (cpp/include/pipeflex/solvers/ida.hpp), against
generalised-alpha at a small step; the joints hold at position and velocity level, the
energy is kept, frames spin through re-bases."""
import numpy as np
import pytest

import pipeflex as pf
from pipeflex.coupled import CoupledSystem
from pipeflex.multibody import MultibodyBuilder, flexible_body

G = (0.0, 0.0, -9.81)
# soft axially (EA): IDA resolves the undamped axial modes, so stiff ones would cost steps
SEC = pf.PipeSection(EI=50.0, EA=1e4, GJ=40.0, pipe_mass=1.0, rotary_inertia=(1e-3, 5e-4, 5e-4))


def double_pendulum():
    """Two flexible bodies (0.5 m each), hinged to the ground and to each other about y,
    released horizontally under gravity, without flow."""
    body = flexible_body(length=0.5, n_elements=4, section=SEC)
    mb = MultibodyBuilder()
    j0 = mb.add_body(body, position=(0.25, 0.0, 0.0))
    j1 = mb.add_body(body, position=(0.75, 0.0, 0.0))
    mb.hinge(j0, "start", (0.0, 1.0, 0.0))
    mb.hinge(j0, "end", (0.0, 1.0, 0.0), j1, "start")
    mb.set_gravity(G)
    return mb.build()


def arm_on_hub():
    """Elements rigidly joined to a hub body hinged about y (tests/test_coupled.py's
    pendulum, softer)."""
    hub_sec = pf.PipeSection(EI=1e3, EA=1e4, GJ=1e3, pipe_mass=5.0, rotary_inertia=(1e-2, 5e-3, 5e-3))
    mb = MultibodyBuilder()
    j = mb.add_body(flexible_body(length=0.2, n_elements=2, section=hub_sec), position=(-0.1, 0.0, 0.0))
    mb.hinge(j, "end", (0.0, 1.0, 0.0))
    mb.set_gravity(G)
    hub = mb.build()
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    b.add_line(n0, (0.6, 0.0, 0.0), 4, SEC)
    b.set_gravity(G)
    cs = CoupledSystem(b.build(floating=True), hub)
    cs.rigid(n0, j, "end")
    return cs, hub, n0, j


def run(system, t_end, integrator, **options):
    return pf.simulate(system, t_end, integrator=integrator, n_outputs=11, progress=False, mass_flow=0.0, **options)


def test_bodies_ida_agrees_with_generalized_alpha_and_keeps_joints_and_energy():
    s = double_pendulum()
    ida = run(s, 0.5, "ida", rtol=1e-8, atol=1e-10)
    ga = run(s, 0.5, "generalized_alpha", step=1e-4, rho_inf=0.95)
    assert ida.metadata["integrator"] == "ida" and ida.stats["steps"] > 0 and ida.stats["jacobians"] > 0
    tip_ida, tip_ga = ida.bodies.node_position(1, "end"), ga.bodies.node_position(1, "end")
    assert np.abs(tip_ida[:, 2]).max() > 0.3  # it swung
    assert np.abs(tip_ida - tip_ga).max() < 1e-5
    # the joints hold: positions (hinges at the origin and between the bodies) and velocities
    assert np.abs(ida.bodies.node_position(0, "start")).max() < 1e-9
    gap = ida.bodies.node_position(0, "end") - ida.bodies.node_position(1, "start")
    assert np.abs(gap).max() < 1e-9
    assert ida.bodies.drift.max() < 1e-9  # 4e-11 measured; generalised-alpha's 4e-6
    # MultibodySystem.energy's own error dominates: 2.7e-4 J at rtol 1e-6 and 1e-8 alike,
    # generalised-alpha's 2.9e-4 J at h = 1e-4 and 2e-4 s
    E = np.array([s.energy(ida.bodies.state(k)) for k in range(len(ida.t))])
    released = 2.0 * 9.81 * 0.25 + 1.0 * 9.81 * 0.25  # the bodies' weight [N] times their centres' drop [m]
    assert np.abs(E - E[0]).max() < 1e-4 * released


def test_coupled_ida_agrees_with_generalized_alpha_and_keeps_energy():
    cs, hub, n0, j = arm_on_hub()
    ida = run(cs, 0.25, "ida", rtol=1e-7, atol=1e-9)
    ga = run(cs, 0.25, "generalized_alpha", step=1e-4, rho_inf=0.95)
    assert ida.elements.kinetic.max() > 0.1  # it swung
    assert np.abs(ida.elements.x - ga.elements.x).max() < 2e-5  # 4.5e-6 measured: generalised-alpha's error
    assert np.abs(ida.bodies.r - ga.bodies.r).max() < 1e-5
    # the coupling holds: the arm's root stays on the hinge, turning with the hub's node
    assert np.abs(ida.elements.x[:, n0]).max() < 1e-9
    w_hub = ida.bodies.node_angular_velocity(j, "end")[:, 1]
    assert np.abs(ida.elements.omega[:, n0, 1] - w_hub).max() < 1e-7 * np.abs(w_hub).max()
    assert ida.bodies.drift.max() < 1e-8
    E = ida.elements.energy + np.array([hub.energy(ida.bodies.state(k)) for k in range(len(ida.t))])
    assert np.abs(E - E[0]).max() < 1e-4 * ida.elements.kinetic.max()  # 2e-5 measured (the hub's energy)


def test_a_spinning_body_is_re_based_and_keeps_its_rate():
    """A free-spinning body on a hinge about z turns 10 rad (10 rad/s over 1 s): IDA
    re-bases its frame past rebase_angle and restarts; the angle turned agrees with
    generalised-alpha's (7.6e-6 rad apart; the body stretches, so the rate is not
    constant), the hinge holds."""
    body = flexible_body(length=0.5, n_elements=4, section=SEC)
    mb = MultibodyBuilder()
    j = mb.add_body(body, position=(0.25, 0.0, 0.0))
    mb.hinge(j, "start", (0.0, 0.0, 1.0))
    s = mb.build()
    st = s.initial_state()
    w = 10.0
    st.v[:6] = (0.0, 0.25 * w, 0.0, 0.0, 0.0, w)
    r = pf.simulate(s, 1.0, integrator="ida", state=st, rtol=1e-7, atol=1e-9, n_outputs=21, progress=False,
                    rebase_angle=1.0)
    assert r.stats["rebases"] >= 9  # 10 rad, at most 1 rad per chart
    angle = np.unwrap(np.arctan2(r.bodies.R[:, 0, 1, 0], r.bodies.R[:, 0, 0, 0]))
    ga = pf.simulate(s, 1.0, integrator="generalized_alpha", state=st, step=1e-4, rho_inf=0.95, n_outputs=21,
                     progress=False)
    angle_ga = np.unwrap(np.arctan2(ga.bodies.R[:, 0, 1, 0], ga.bodies.R[:, 0, 0, 0]))
    assert angle[-1] > 9.9
    assert np.abs(angle - angle_ga).max() < 1e-4
    assert np.abs(r.bodies.node_position(0, "end") - ga.bodies.node_position(0, "end")).max() < 1e-4  # 1.6e-5
    assert np.abs(r.bodies.node_position(0, "start")).max() < 1e-9
    assert r.bodies.drift.max() < 1e-8


def test_bad_tolerances_still_raise():
    s = double_pendulum()
    for bad in (0.0, -1e-6):
        with pytest.raises(ValueError, match="rtol must be > 0"):
            run(s, 0.1, "ida", rtol=bad)
    with pytest.raises(ValueError, match="atol must be > 0"):
        run(s, 0.1, "ida", atol=-1.0)
