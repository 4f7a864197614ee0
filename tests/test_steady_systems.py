"""pf.steady_rotation of systems with floating-frame bodies: a CoupledSystem (elements
joined to bodies) and a MultibodySystem (bodies alone), through the core's one static
Newton with omega as its border on the bordered KKT matrix (cpp/src/rotating_systems.cpp)."""
from dataclasses import replace

import numpy as np
import pytest

import pipeflex as pf
from pipeflex import scenes
from pipeflex.coupled import simulate
from pipeflex.multibody import MultibodyBuilder, flexible_body

from helpers import l_sprinkler


@pytest.fixture(scope="module")
def alone():
    return pf.steady_rotation(scenes.sprinkler(EI=100.0))


@pytest.mark.parametrize("hub_inertia", [0.01, 1.0])
def test_sprinkler_on_a_hub_body_turns_at_the_element_sprinklers_steady_speed(alone, hub_inertia):
    """The arm clamped to a hub body hinged to the ground turns as the element sprinkler
    hinged itself: the hub's inertia does not enter a steady rotation (measured: equal to
    1e-15 relative, the arm's shape to 1e-15 m, for both hubs)."""
    system, inlet, hub = scenes.sprinkler_on_hub(hub_inertia=hub_inertia)
    got = pf.steady_rotation(system)
    assert isinstance(got, pf.SystemSteadyRotation)
    assert got.omega == pytest.approx(alone.omega, rel=1e-8)
    assert got.hinge == "joint 0 (hinge: body 0 node 2 - ground)"
    np.testing.assert_allclose(got.axis, [0.0, 0.0, 1.0], atol=1e-15)
    # the same deformed arm (the hinge angle pinned at the start's) with the same rates
    np.testing.assert_allclose(got.state.q, alone.state.q, atol=1e-10)
    np.testing.assert_allclose(got.state.v, alone.state.v, atol=1e-8 * alone.omega)
    # the hub body turns with the arm: spatial angular velocity omega a, frame at (-0.1, 0, 0)
    np.testing.assert_allclose(got.body_state.v[3:6], [0.0, 0.0, got.omega], rtol=1e-14)
    np.testing.assert_allclose(got.body_state.v[:3], [0.0, -0.1 * got.omega, 0.0], atol=1e-12)
    assert got.iterations <= 2 * alone.iterations


def test_coupled_steady_rotation_is_a_steady_motion():
    """The residual at the result is round-off of the flow forces (P = mu_f sdot^2 =
    100 N), and generalised-alpha started there stays there: the hub's rate within the
    discrete steady state's O(h^2) offset (measured 1.0e-5; a start 1e-3 off stays
    2e-4 to 1e-3 off), the tip's radius within 1e-6 m (measured 4e-8 m)."""
    system, inlet, hub = scenes.sprinkler_on_hub(hub_inertia=0.01)
    got = pf.steady_rotation(system)
    assert got.residual < 1e-6 * 100.0
    run = simulate(system, 0.1, step=1e-3, n_outputs=6, state=got.state, body_state=got.body_state)
    w = run.bodies.angular_velocity(hub)[:, 2]
    assert np.abs(w / got.omega - 1.0).max() < 2e-5
    radius = np.linalg.norm(run.elements.x[:, -1], axis=1)
    assert np.abs(radius - np.linalg.norm(got.state.q[-6:-3])).max() < 1e-6


def test_bodies_alone_reach_the_rigid_sprinklers_speed_as_they_stiffen():
    """A rigid sprinkler's outflow leaves no moment about the hinge: mdot (r x (U t +
    omega a x r)) . a = 0 at the exit r, so omega = -U (r x t)_z / |r|^2 = -2 * 0.5 / 0.34
    rad/s. The bodies' steady rate tends to it as 1/EI (measured 1.9e-7 at EI = 1e4 and
    1.9e-9 at 1e6)."""
    rigid = -2.0 * 0.5 / 0.34
    errors = []
    for EI in (1e4, 1e6):
        got = pf.steady_rotation(l_sprinkler(EI))
        assert got.state is None and got.coupling_forces.shape == (0,)
        errors.append(abs(got.omega / rigid - 1.0))
    assert errors[1] < 1e-8
    assert errors[0] == pytest.approx(100 * errors[1], rel=0.05)


def test_steady_rotation_of_bodies_needs_one_ground_hinge():
    with pytest.raises(ValueError, match=r"needs exactly one hinge \(a body hinged to the ground\); "
                                         r"this MultibodySystem has 0$"):
        pf.steady_rotation(pf.scenes.ffrf_cantilever_pipe(n_bodies=2, elements_per_body=2))
    sec = pf.PipeSection(EI=10.0, EA=1e4, GJ=8.0, pipe_mass=0.5, fluid_mass=1.0, rotary_inertia=(1e-4, 0.0, 0.0))
    b = MultibodyBuilder()
    j0 = b.add_body_between(flexible_body(length=0.5, n_elements=2, section=sec), (0, 0, 0), (0.5, 0, 0))
    b.hinge(j0, "start", (0, 0, 1))
    b.hinge(j0, "end", (0, 0, 1))
    with pytest.raises(ValueError, match=r"has 2: joint 0 \(hinge: body 0 node 0 - ground\), joint 1 "):
        pf.steady_rotation(b.build(mass_flow=1.0))


def test_a_hinge_between_two_bodies_is_refused_with_the_reason():
    """A rotor hinged to a standing flexible body has no steady rotation in general (the
    stand carries the turning reactions): the error names the hinge and says why."""
    sec = pf.PipeSection(EI=10.0, EA=1e4, GJ=8.0, pipe_mass=0.5, fluid_mass=1.0, rotary_inertia=(1e-4, 0.0, 0.0))
    b = MultibodyBuilder()
    stand = b.add_body_between(flexible_body(length=0.5, n_elements=2, section=sec), (0, 0, 0), (0, 0, 0.5))
    arm = b.add_body_between(flexible_body(length=0.5, n_elements=2, section=sec), (0, 0, 0.5), (0.5, 0, 0.5))
    b.fix(stand, "start")
    b.hinge(arm, "start", (0, 0, 1), stand, "end")
    with pytest.raises(ValueError, match=r"needs a hinge to the ground; this MultibodySystem's hinges join two "
                                         r"bodies \(joint 1 \(hinge: body 1 node 0 - body 0 node 2\)\): the standing"):
        pf.steady_rotation(b.build(mass_flow=1.0))


def test_bodies_steady_rotation_is_a_steady_motion():
    """Generalised-alpha started at the bodies' steady rotation (EI = 100 N m^2: they bend)
    stays there: the rate within 2e-5 (measured 5e-6, the discrete offset), the tip's
    radius within 1e-7 m (measured 2e-9 m; with the frames' centripetal accelerations left
    out of the rates: 5e-3 and 4e-4 m). Newton converges quadratically: 13 iterations
    over the 4 flow steps (16 without the frames' centrifugal stiffness omega^2 M Aa)."""
    system = l_sprinkler(100.0)
    got = pf.steady_rotation(system)
    assert got.iterations <= 14
    run = pf.multibody.simulate(system, 0.1, step=1e-3, state=got.body_state, n_outputs=6)
    assert np.abs(run.angular_velocity(0)[:, 2] / got.omega - 1.0).max() < 2e-5
    radius = np.linalg.norm(run.node_position(1, "end"), axis=1)
    assert np.abs(radius - radius[0]).max() < 1e-7


def mast_on_sprinkler():
    """The element sprinkler (hinged itself) carrying at its middle node a 0.2 m mast of two
    bodies (1 kg/m, no fluid) rigidly joined, clamped to the arm by a coupling."""
    arm = scenes.sprinkler(EI=100.0)
    sec = pf.PipeSection(EI=1e3, EA=1e6, GJ=800.0, pipe_mass=1.0, rotary_inertia=(1e-3, 0.0, 0.0))
    foot = np.asarray(arm.positions[4], float)
    b = MultibodyBuilder()
    up = np.array([0.0, 0.0, 0.1])
    j0 = b.add_body_between(flexible_body(length=0.1, n_elements=2, section=sec), foot, foot + up)
    j1 = b.add_body_between(flexible_body(length=0.1, n_elements=2, section=sec), foot + up, foot + 2 * up)
    b.rigid(j0, "end", j1, "start")
    system = pf.CoupledSystem(arm, b.build())
    system.rigid(4, j0, "start")
    return system


def test_coupled_system_turning_about_its_element_hinge(alone):
    """A coupled system whose hinge is an element node: the mast's mass slows the arm
    (measured 8.98895 against 9.00983 rad/s), and generalised-alpha started there stays
    there (the rate within 2e-5, measured 9e-6; the tip's radius within 1e-7 m)."""
    system = mast_on_sprinkler()
    got = pf.steady_rotation(system)
    assert got.hinge == "element node 0"
    assert 0.99 * alone.omega < got.omega < 0.999 * alone.omega
    run = simulate(system, 0.1, step=1e-3, n_outputs=6, state=got.state, body_state=got.body_state)
    assert np.abs(run.elements.omega[:, 0, 2] / got.omega - 1.0).max() < 2e-5
    radius = np.linalg.norm(run.elements.x[:, -1], axis=1)
    assert np.abs(radius - radius[0]).max() < 1e-7


def test_coupled_steady_rotation_names_every_hinge():
    """The sprinkler arm hinged itself and on a hub body hinged to the ground: two hinges."""
    arm = scenes.sprinkler(EI=100.0)
    hub, _, j = scenes.sprinkler_on_hub()
    system = pf.CoupledSystem(arm, hub.bodies)
    with pytest.raises(ValueError, match=r"needs exactly one hinge \(a body hinged to the ground, or an element node "
                                         r"with fixed position and one free rotation\); this CoupledSystem has 2: "
                                         r"joint 0 \(hinge: body 0 node 2 - ground\), element node 0$"):
        pf.steady_rotation(system)


def test_coupled_steady_rotation_options():
    """mass_flow drives the elements and the bodies (the element sprinkler's rate at 5 kg/s,
    measured equal to 1e-15); a start at the result converges at once (one iteration)."""
    system, _, _ = scenes.sprinkler_on_hub()
    slow = pf.steady_rotation(system, mass_flow=5.0)
    assert slow.omega == pytest.approx(pf.steady_rotation(scenes.sprinkler(EI=100.0), mass_flow=5.0).omega, rel=1e-8)
    again = pf.steady_rotation(system, state=slow, mass_flow=5.0, omega_guess=slow.omega, continuation_steps=1)
    assert again.omega == pytest.approx(slow.omega, rel=1e-12)
    assert again.iterations <= 2
    with pytest.raises(TypeError, match="CoupledStatic or a SystemSteadyRotation"):
        pf.steady_rotation(system, state=slow.body_state)


def test_bordered_newton_converges_only_with_the_joints_held():
    """The bordered Newton (omega the border) takes a small correction as convergence only
    where the constraints hold (as the plain Newton does): from the solution with body 1
    moved 1e-5 model sizes off its rigid joint, with a loose tol (1e-2), the first
    correction, made at the open joint, is not accepted; a second iteration confirms it at
    the closed one (the joint closed to 1e-17)."""
    system = l_sprinkler(1e4)
    got = pf.steady_rotation(system)
    r = np.array(got.body_state.r)
    r[1] += 1e-5 * system.length_scale * np.array([0.0, 0.0, 1.0])
    moved = replace(got.body_state, r=r)
    assert np.abs(system.constraints(moved)[0]).max() > 1e-6 * system.length_scale
    again = pf.steady_rotation(system, state=moved, omega_guess=got.omega, continuation_steps=1, tol=1e-2)
    assert again.iterations == 2
    assert np.abs(system.constraints(again.body_state)[0]).max() < 1e-12 * system.length_scale
    assert again.omega == pytest.approx(got.omega, rel=1e-12)
