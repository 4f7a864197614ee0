"""Sensors on floating-frame bodies and coupled systems, and custom (callable) sensors:
each checked against the Python-side evaluation of the recorded states."""
from __future__ import annotations

import numpy as np
import pytest

import pipeflex as pf
from pipeflex import sensor
from pipeflex.coupled import CoupledSystem
from pipeflex.multibody import MultibodyBuilder, MultibodyState, flexible_body
from pipeflex.rotation import rotation_log

SECTION = pf.PipeSection(EI=20.0, pipe_mass=1.0)
STEP = 1e-3
RUN = dict(integrator="generalized_alpha", step=STEP, progress=False)


def double_pendulum():
    """Two flexible bodies hinged about z (ground - body 0 - body 1) under gravity -y, a
    ground spring-damper at body 1's end (y) and an axial spring-damper from body 0's
    centre to body 1's end: it swings from the assembly configuration."""
    b = MultibodyBuilder()
    j0 = b.add_body(flexible_body(length=0.5, n_elements=4, section=SECTION), position=(0.25, 0.0, 0.0))
    j1 = b.add_body(flexible_body(length=0.4, n_elements=4, section=SECTION), position=(0.7, 0.0, 0.0))
    b.hinge(j0, "start", (0.0, 0.0, 1.0))
    b.hinge(j0, "end", (0.0, 0.0, 1.0), j1, "start")
    b.set_gravity((0.0, -9.81, 0.0))
    b.add_ground_spring(j1, "end", stiffness=(0.0, 50.0, 0.0), damping=(0.0, 0.5, 0.0))
    b.add_spring(j0, "center", j1, "end", stiffness=30.0, damping=0.2)
    return b.build()


def at_outputs(t_sensor, values, t_out):
    """The sensor's values at the output times (whole steps: they are recorded steps)."""
    k = np.searchsorted(t_sensor, t_out - 1e-9 * STEP)
    np.testing.assert_allclose(t_sensor[k], t_out, rtol=0, atol=1e-12)
    return values[k]


def close(a, b, rel=1e-12, scale=None):
    """a equals b to rel times b's size, or scale (round-off of the two evaluations)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    scale = max(np.abs(b).max(), 1e-300) if scale is None else scale
    assert np.abs(a - b).max() <= rel * scale, (np.abs(a - b).max(), scale)


def body_state(res, system, k):
    """The k-th output state of the bodies (accelerations not recorded)."""
    return res.bodies.state(k)


def test_body_node_sensors_equal_the_node_maps_of_the_recorded_states():
    system = double_pendulum()
    tip = (1, "end")
    res = pf.simulate(system, 0.2, n_outputs=21, **RUN, sensors=[
        sensor.node_position(tip), sensor.node_velocity(tip), sensor.node_acceleration(tip),
        sensor.node_rotation((1, 2)), sensor.node_rotation((0, "center"), axis=(0.0, 0.0, 1.0), name="angle"),
        sensor.node_position((0, 4), "y", name="y0")])
    n_out = len(res.t)
    assert res.sensors["node_position[1,end]"][0].shape == (res.stats["steps"] + 1,)
    x = at_outputs(*res.sensors["node_position[1,end]"], res.t)
    close(x, res.bodies.node_position(1, "end"))
    close(at_outputs(*res.sensors["y0"], res.t), res.bodies.node_position(0, 4)[:, 1])
    v = at_outputs(*res.sensors["node_velocity[1,end]"], res.t)
    phi = at_outputs(*res.sensors["node_rotation[1,2]"], res.t)
    angle = at_outputs(*res.sensors["angle"], res.t)
    A0 = system.node_kinematics(system.initial_state(), 1, 2)[1]
    A0c = system.node_kinematics(system.initial_state(), 0, "center")[1]
    sl = system.body_slice(1)
    for k in range(n_out):
        st = body_state(res, system, k)
        _, _, Jp, _ = system.node_kinematics(st, 1, "end")
        close(v[k], Jp @ st.v[sl], rel=1e-12)
        _, A, _, _ = system.node_kinematics(st, 1, 2)
        close(phi[k], rotation_log(A @ A0.T))
        _, Ac, _, _ = system.node_kinematics(st, 0, "center")
        close(angle[k], rotation_log(Ac @ A0c.T)[2])
    assert np.abs(angle).max() > 0.1  # it swung
    # the acceleration at every step (a custom sensor evaluates the formula on the same
    # state): r_dd + alpha x y + w x (w x y) + 2 w x R Pu ed + R Pu edd
    o, e = sl.start, sl.stop
    Pu = system.bodies[1].basis[6 * 4:6 * 4 + 3]

    def acceleration(t, state):
        st = MultibodyState(state.r, state.R, state.eta, state.v, state.a, state.lam, t)
        y = system.node_position(st, 1, "end") - st.r[1]
        w, alpha, R = st.v[o + 3:o + 6], st.a[o + 3:o + 6], st.R[1]
        terms = [st.a[o:o + 3], np.cross(alpha, y), np.cross(w, np.cross(w, y)),
                 2.0 * np.cross(w, R @ Pu @ st.v[o + 6:e]), R @ Pu @ st.a[o + 6:e]]
        return np.concatenate([sum(terms), [max(np.abs(q).max() for q in terms)]])

    res2 = pf.simulate(system, 0.05, n_outputs=2, **RUN, sensors=[
        sensor.node_acceleration(tip), sensor.custom(acceleration, name="python", components=4)])
    acc = res2.sensors["node_acceleration[1,end]"][1]
    python = res2.sensors["python"][1]
    assert np.all(np.abs(acc - python[:, :3]).max(axis=1) <= 1e-12 * python[:, 3])
    assert np.abs(acc).max() > 1.0


def test_body_energy_and_spring_forces_equal_the_systems_own_evaluation():
    system = double_pendulum()
    res = pf.simulate(system, 0.2, n_outputs=11, **RUN,
                      sensors=[sensor.energy(), sensor.spring_force(0), sensor.spring_force(1, name="tension"),
                               sensor.joint_force(1, name="hinge")])
    E = at_outputs(*res.sensors["energy"], res.t)
    assert res.metadata["sensors"]["energy"]["components"] == ["kinetic", "elastic", "gravity_potential", "total"]
    close(E[:, 3], E[:, :3].sum(axis=1))
    total = [system.energy(body_state(res, system, k)) for k in range(len(res.t))]
    close(E[:, 3], total, rel=1e-12)
    assert E[-1, 0] > 0.05  # it moved: kinetic energy [J]
    # elastic part: the springs' energy and the bodies' strain energy
    spring_U = [system.spring_energy(body_state(res, system, k))[0] for k in range(len(res.t))]
    assert np.all(E[:, 1] >= np.array(spring_U) - 1e-15)
    # ground spring: -K (x - X) - C v on body 1's end; axial: k (l - L0) + c dl/dt
    F = at_outputs(*res.sensors["spring_force[0]"], res.t)
    T = at_outputs(*res.sensors["tension"], res.t)
    st0 = system.initial_state()
    X = system.node_position(st0, 1, "end")
    L0 = np.linalg.norm(X - system.node_position(st0, 0, "center"))
    for k in range(len(res.t)):
        st = body_state(res, system, k)
        pb, _, Jb, _ = system.node_kinematics(st, 1, "end")
        pa, _, Ja, _ = system.node_kinematics(st, 0, "center")
        vb, va = Jb @ st.v[system.body_slice(1)], Ja @ st.v[system.body_slice(0)]
        expected = -50.0 * (pb[1] - X[1]) - 0.5 * vb[1]
        close(F[k], [0.0, expected, 0.0], rel=1e-12, scale=max(abs(expected), 50.0 * 1e-3))  # at rest: 0
        d = pb - pa
        ell = np.linalg.norm(d)
        expected = 30.0 * (ell - L0) + 0.2 * d @ (vb - va) / ell
        close(T[k], expected, rel=1e-12, scale=max(abs(expected), 30.0 * 1e-3))
    assert np.abs(T).max() > 1e-3
    # the hinge's multipliers: the end state's
    t_h, lam = res.sensors["hinge"]
    rows = system.joint_rows
    assert lam.shape == (len(t_h), rows[2] - rows[1])
    np.testing.assert_array_equal(lam[-1], res.final_state.lam[rows[1]:rows[2]])


def test_crossings_on_body_node_and_custom_sensors_lie_in_the_steps_that_cross():
    system = double_pendulum()
    y = sensor.node_position((1, "end"), "y")

    def tip_y(t, state):
        st = MultibodyState(state.r, state.R, state.eta, state.v, state.a, state.lam, t)
        return system.node_position(st, 1, "end")[1]

    mine = sensor.custom(tip_y, name="tip y", unit="m")
    level = -0.05
    res = pf.simulate(system, 0.5, n_outputs=6, **RUN, sensors=[
        y, mine, sensor.crossing(y, level, name="up/down"), sensor.crossing(mine, level, name="custom up/down"),
        sensor.crossing(sensor.node_rotation((0, "end"), axis=(0, 0, 1)), -0.2, "down", name="angle down")])
    t, values = res.sensors["node_position[1,end].y"]
    tc, valc = res.sensors["tip y"]
    np.testing.assert_array_equal(tc, t)
    close(valc, values, rel=1e-13)  # the same state, evaluated in Python
    assert res.metadata["sensors"]["tip y"]["units"] == "m"
    s = np.sign(values - level)
    steps = np.flatnonzero(s[1:] != s[:-1])
    times, signs = res.sensors["up/down"]
    assert len(steps) >= 1 and len(times) == len(steps)
    assert np.all((t[steps] <= times) & (times <= t[steps + 1]))
    np.testing.assert_array_equal(signs, np.sign(values[steps + 1] - values[steps]))
    # the custom sensor has no rate: the parabola through three steps, close to the Hermite's
    times_c, signs_c = res.sensors["custom up/down"]
    np.testing.assert_array_equal(signs_c, signs)
    assert np.abs(times_c - times).max() < 0.05 * STEP
    assert len(res.sensors["angle down"][0]) >= 1 and np.all(res.sensors["angle down"][1] == -1)


def test_terminal_crossing_on_a_body_node_ends_the_run():
    system = double_pendulum()
    y = sensor.node_position((1, "end"), "y")
    res = pf.simulate(system, 0.5, n_outputs=6, **RUN, sensors=[sensor.crossing(y, -0.02, terminal=True)])
    stop = res.metadata["stopped_at"]
    assert 0.0 < stop < 0.5 and res.t[-1] == pytest.approx(stop, abs=STEP)
    assert system.node_position(res.final_state, 1, "end")[1] <= -0.02


# -- coupled systems ---------------------------------------------------------------------------

def pendulum_of_elements_and_a_body():
    """test_coupled's pendulum: an arm of 4 elements rigidly joined to a hub body hinged
    about y, swinging under gravity."""
    g = (0.0, 0.0, -9.81)
    sec = pf.PipeSection(EI=50.0, EA=1e6, GJ=40.0, pipe_mass=1.0, rotary_inertia=(1e-3, 5e-4, 5e-4))
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    b.add_line(n0, (0.6, 0.0, 0.0), 4, sec)
    b.set_gravity(g)
    b.add_ground_spring(4, stiffness=(0.0, 0.0, 20.0))
    arm = b.build(floating=True)
    mb = MultibodyBuilder()
    hub = pf.PipeSection(EI=1e5, pipe_mass=5.0, rotary_inertia=(1e-2, 0.0, 0.0))
    j = mb.add_body(flexible_body(length=0.2, n_elements=2, section=hub), position=(-0.1, 0.0, 0.0))
    mb.hinge(j, "end", (0.0, 1.0, 0.0))
    mb.set_gravity(g)
    mb.add_ground_spring(j, "start", stiffness=(0.0, 0.0, 10.0))
    cs = CoupledSystem(arm, mb.build())
    cs.rigid(n0, j, "end")
    cs.add_spring(2, j, "start", stiffness=15.0, damping=0.1)
    return cs, j


def test_coupled_sensors_read_the_element_part_the_bodies_and_the_couplings():
    cs, j = pendulum_of_elements_and_a_body()
    hub = cs.bodies

    def both(t, state):  # the element tip's z and the hub start's z, from the state's parts
        st = MultibodyState(state.body_state.r, state.body_state.R, state.body_state.eta, state.body_state.v,
                            state.body_state.a, state.body_state.lam, t)
        return [state.state.q[6 * 4 + 2], hub.node_position(st, j, "start")[2], state.coupling_forces[2]]

    res = pf.simulate(cs, 0.2, step=5e-4, n_outputs=11, rho_inf=0.95, mass_flow=0.0, progress=False, sensors=[
        sensor.node_position(4), sensor.node_position((j, "start"), name="hub"), sensor.energy(),
        sensor.joint_force(0, part="couplings", name="coupling"), sensor.joint_force(0, name="hinge"),
        sensor.spring_force(0, "z", name="arm spring"), sensor.spring_force(0, "z", part="bodies", name="hub spring"),
        sensor.spring_force(0, part="couplings", name="coupling spring"),
        sensor.strain(3, 0.5, "kappa_y"), sensor.custom(both, name="both", components=("tip", "hub", "fz")),
        sensor.crossing(sensor.node_position(4, "z"), -0.01, name="tip down")])
    close(at_outputs(*res.sensors["node_position[4]"], res.t), res.elements.x[:, 4])
    hub_x = at_outputs(*res.sensors["hub"], res.t)
    close(hub_x, res.bodies.node_position(j, "start"))
    assert np.abs(hub_x[:, 2]).max() > 1e-3  # the hub turned
    E = at_outputs(*res.sensors["energy"], res.t)
    total = res.elements.energy + np.array([hub.energy(res.bodies.state(k)) for k in range(len(res.t))])
    close(E[:, 3], total, rel=1e-12, scale=np.abs(E[:, :3]).max())  # the total stays near 0: its parts' size
    assert E[-1, 0] > 1e-3  # it swung: kinetic [J]
    np.testing.assert_array_equal(at_outputs(*res.sensors["coupling"], res.t), res.coupling_forces[:, :6])
    rows = hub.joint_rows
    np.testing.assert_array_equal(res.sensors["hinge"][1][-1], res.final_state.body_state.lam[rows[0]:rows[1]])
    close(at_outputs(*res.sensors["arm spring"], res.t), -20.0 * res.elements.x[:, 4, 2])
    close(at_outputs(*res.sensors["hub spring"], res.t), -10.0 * res.bodies.node_position(j, "start")[:, 2])
    # the coupling spring from element node 2 to the hub's start: k (l - L0) + c dl/dt
    T = at_outputs(*res.sensors["coupling spring"], res.t)
    L0 = np.linalg.norm(np.array(cs.model.positions[2]) - hub.node_position(hub.initial_state(), j, "start"))
    for k in range(len(res.t)):
        st = res.bodies.state(k)
        pb, _, Jb, _ = hub.node_kinematics(st, j, "start")
        d = pb - res.elements.x[k, 2]
        ell = np.linalg.norm(d)
        close(T[k], 15.0 * (ell - L0) + 0.1 * d @ (Jb @ st.v[hub.body_slice(j)] - res.elements.xd[k, 2]) / ell,
              rel=1e-10, scale=15.0 * abs(ell - L0) + 1e-6)
    assert np.abs(T).max() > 1e-5  # the arm's bending stretches it (the rigid swing does not)
    t, mine = res.sensors["both"]
    assert mine.shape == (len(t), 3) and res.metadata["sensors"]["both"]["components"] == ["tip", "hub", "fz"]
    close(mine[:, 0], res.sensors["node_position[4]"][1][:, 2], rel=0)
    close(mine[:, 1], res.sensors["hub"][1][:, 2], rel=1e-13)
    close(mine[:, 2], res.sensors["coupling"][1][:, 2], rel=0)
    assert len(res.sensors["tip down"][0]) == 1


# -- custom sensors ----------------------------------------------------------------------------

def cantilever():
    return pf.scenes.cantilever_pipe(n_elements=4, polar_inertia=1e-3)


def test_custom_sensor_on_an_element_model_reads_the_state_and_is_called_every_step():
    model = cantilever()
    calls = []

    def tip(t, state):
        calls.append(t)
        return state.q[6 * 4:6 * 4 + 3] + 0.0 * state.v[:3] + 0.0 * state.a[:3] + 0.0 * state.frames[4, 0]

    res = pf.simulate(model, 5e-3, n_outputs=3, **RUN, sensors=[
        sensor.custom(tip, name="tip", components=("x", "y", "z")), sensor.node_position(4)])
    t, values = res.sensors["tip"]
    np.testing.assert_array_equal(values, res.sensors["node_position[4]"][1])
    np.testing.assert_array_equal(np.array(calls), t)
    assert len(t) == res.stats["steps"] + 1


def test_custom_sensor_errors_end_the_run_naming_the_sensor_and_the_time():
    model = cantilever()

    def boom(t, state):
        if t > 2.5e-3:
            raise ZeroDivisionError("the user's bug")
        return 0.0

    with pytest.raises(RuntimeError, match=r"custom sensor 'boom' raised at t = 0\.00[0-9]+ s: ZeroDivisionError: "
                                           r"the user's bug"):
        pf.simulate(model, 5e-3, n_outputs=3, **RUN, sensors=[sensor.custom(boom, name="boom")])
    with pytest.raises(ValueError, match=r"custom sensor 'pair' at t = 0 s: must return 3 values"):
        pf.simulate(model, 5e-3, n_outputs=3, **RUN,
                    sensors=[sensor.custom(lambda t, s: (1.0, 2.0), name="pair", components=3)])
    with pytest.raises(ValueError, match=r"custom sensor 'nan' at t = .*not finite"):
        pf.simulate(model, 5e-3, n_outputs=3, **RUN, sensors=[sensor.custom(lambda t, s: np.nan, name="nan")])
    kept = []
    pf.simulate(model, 2e-3, n_outputs=2, **RUN, sensors=[sensor.custom(lambda t, s: kept.append(s) or 0.0,
                                                                         name="keeps")])
    with pytest.raises(RuntimeError, match="only during its call"):
        kept[0].q
    with pytest.raises(RuntimeError, match=r"AttributeError: a custom sensor's state has no 'r' here "
                                           r"\(an element model: q, v, a, frames\)"):
        pf.simulate(model, 2e-3, n_outputs=2, **RUN, sensors=[sensor.custom(lambda t, s: s.r[0, 0], name="r")])
    # the model is usable after a failed run
    assert pf.simulate(model, 2e-3, n_outputs=2, **RUN).t[-1] == pytest.approx(2e-3)


def test_custom_sensor_is_recorded_by_ida_and_with_error_control():
    model = cantilever()
    for run in (dict(integrator="ida", rtol=1e-5), dict(rtol=1e-4)):
        res = pf.simulate(model, 5e-3, n_outputs=3, progress=False, **run,
                          sensors=[sensor.custom(lambda t, s: s.q[6 * 4 + 1], name="y"), sensor.node_position(4, "y")])
        np.testing.assert_array_equal(res.sensors["y"][1], res.sensors["node_position[4].y"][1])


def test_bad_body_and_custom_sensors_are_refused_by_name():
    system = double_pendulum()
    run = dict(n_outputs=2, **RUN)
    with pytest.raises(ValueError, match=r"sensor 'node_position\[3\]'.*address a body node as \(body, node\)"):
        pf.simulate(system, 1e-3, sensors=[sensor.node_position(3)], **run)
    with pytest.raises(ValueError, match=r"sensor 'node_position\[1,9\]': node must be an index 0..4"):
        pf.simulate(system, 1e-3, sensors=[sensor.node_position((1, 9))], **run)
    with pytest.raises(ValueError, match=r"sensor 'node_position\[5,0\]': body must be in \[0, 2\)"):
        pf.simulate(system, 1e-3, sensors=[sensor.node_position((5, 0))], **run)
    with pytest.raises(ValueError, match=r"strain is recorded on pipe elements"):
        pf.simulate(system, 1e-3, sensors=[sensor.strain(0)], **run)
    with pytest.raises(ValueError, match=r"spring 2 is not in the model \(2 springs\)"):
        pf.simulate(system, 1e-3, sensors=[sensor.spring_force(2)], **run)
    with pytest.raises(ValueError, match=r"no couplings"):
        pf.simulate(system, 1e-3, sensors=[sensor.joint_force(0, part="couplings")], **run)
    with pytest.raises(ValueError, match=r"no couplings"):
        pf.simulate(system, 1e-3, sensors=[sensor.spring_force(0, part="couplings")], **run)
    cs, _ = pendulum_of_elements_and_a_body()
    with pytest.raises(ValueError, match=r"spring 1 is not in the couplings \(1 springs\)"):
        pf.simulate(cs, 1e-3, sensors=[sensor.spring_force(1, part="couplings")], **run)
    with pytest.raises(ValueError, match=r"has no bodies"):
        pf.simulate(cantilever(), 1e-3, sensors=[sensor.node_position((0, "end"))], **run)
    with pytest.raises(ValueError, match=r"a body node is addressed \(body, node\)"):
        sensor.node_position((0, 1, 2))
    with pytest.raises(ValueError, match=r"part must be one of"):
        sensor.spring_force(0, part="hub")
    with pytest.raises(ValueError, match=r"fn must be callable"):
        sensor.custom(3.0, name="x")
    with pytest.raises(ValueError, match=r"records 2 components: give a custom sensor of one value"):
        sensor.crossing(sensor.custom(lambda t, s: (0.0, 1.0), name="two", components=2))
