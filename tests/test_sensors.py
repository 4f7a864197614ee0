"""Sensors recorded at every accepted step (pipeflex.sensor) and crossing sensors."""
from __future__ import annotations

import numpy as np
import pytest

import pipeflex as pf
from pipeflex import sensor
from pipeflex.rotation import rotation_log

ULP = np.finfo(float).eps


def cantilever(n_elements=4, **options):
    return pf.scenes.cantilever_pipe(n_elements=n_elements, polar_inertia=1e-3, **options)


def released(model, tip_velocity=0.05):
    """The cantilever at rest but for a transverse tip velocity (a free vibration)."""
    st = model.initial_state()
    v = np.array(st.v)
    v[6 * (model.n_nodes - 1) + 1] = tip_velocity
    st.v = v
    return st


def oscillator(mass=2.0, stiffness=800.0):
    """A point mass on a ground spring along y (its rotations held): x = A sin(omega t)."""
    b = pf.ModelBuilder()
    n = b.add_node((0.0, 0.0, 0.0))
    b.fix(n, ("ux", "uz", "rx", "ry", "rz"))
    b.add_point_mass(n, mass)
    b.add_ground_spring(n, stiffness=(0.0, stiffness, 0.0))
    model = b.build()
    st = model.initial_state()
    v = np.array(st.v)
    v[1] = 0.1
    st.v = v
    return model, st, np.sqrt(stiffness / mass)


def test_sensor_values_at_output_times_equal_the_results_arrays_and_every_step_is_recorded():
    model = cantilever()
    tip = model.n_nodes - 1
    sensors = [sensor.node_position(tip), sensor.node_velocity(tip, "y"), sensor.node_rotation(tip),
               sensor.energy("total"), sensor.energy()]
    res = pf.simulate(model, 0.05, integrator="generalized_alpha", step=5e-4, n_outputs=11,
                      state=released(model), sensors=sensors, progress=False)
    t, x = res.sensors["node_position[%d]" % tip]
    assert len(t) == res.stats["steps"] + 1 == 101  # the start and every step
    assert x.shape == (101, 3)
    k = np.searchsorted(t, res.t)
    np.testing.assert_allclose(t[k], res.t, rtol=0, atol=100 * ULP * res.t[-1])
    scale = np.abs(res.x).max()
    np.testing.assert_allclose(x[k], res.x[:, tip], rtol=0, atol=4 * ULP * scale)
    vy = res.sensors["node_velocity[%d].y" % tip][1]
    np.testing.assert_allclose(vy[k], res.xd[:, tip, 1], rtol=0, atol=4 * ULP * np.abs(res.xd).max())
    rot = res.sensors["node_rotation[%d]" % tip][1]
    phi = np.array([rotation_log(R) for R in res.R[:, tip]])
    np.testing.assert_allclose(rot[k], phi, rtol=0, atol=1e-12)
    total = res.sensors["energy.total"][1]
    np.testing.assert_allclose(total[k], res.energy, rtol=16 * ULP, atol=16 * ULP * np.abs(res.energy).max())
    assert res.sensors["energy"][1].shape == (101, 4)
    assert res.metadata["sensors"]["node_velocity[%d].y" % tip]["units"] == "m/s"


def test_accelerations_match_the_velocities_differences():
    """The recorded accelerations against central differences of the recorded velocities:
    close, and closer at a halved step by the differences' second order."""
    model = cantilever()
    tip = model.n_nodes - 1
    errors = []
    for h in (2.5e-4, 1.25e-4):
        res = pf.simulate(model, 0.02, integrator="generalized_alpha", step=h, n_outputs=3, rho_inf=1.0,
                          state=released(model), progress=False,
                          sensors=[sensor.node_velocity(tip, "y"), sensor.node_acceleration(tip, "y")])
        t, v = res.sensors["node_velocity[%d].y" % tip]
        a = res.sensors["node_acceleration[%d].y" % tip][1]
        central = (v[2:] - v[:-2]) / (t[2:] - t[:-2])
        errors.append(np.abs(central - a[1:-1]).max() / np.abs(a).max())
    # the tip rings at ~600 rad/s: (h omega)^2 / 4 ~ 0.6 % at 0.25 ms (measured 1.1 %)
    assert errors[0] < 2e-2
    assert errors[0] / errors[1] == pytest.approx(4.0, rel=0.2)


def test_strain_and_section_force_of_a_bent_cantilever_match_the_beam_theory():
    """A tip force F on a cantilever: M(x) = F (L - x), kappa = M / EI, linear in x (which
    the Hermite elements represent exactly), axial force 0."""
    EI, L, F, n = 10.0, 1.0, 1e-3, 4
    b = pf.ModelBuilder()
    sec = pf.PipeSection(EI=EI, EA=1e6, pipe_mass=8.0, rotary_inertia=(1e-3, 0.0, 0.0))
    n0 = b.add_node((0.0, 0.0, 0.0))
    b.add_line(n0, (L, 0.0, 0.0), n, sec)
    b.clamp(n0)
    b.add_load(n, force=(0.0, 0.0, F))
    model = b.build()
    start = pf.static_equilibrium(model).state
    probes = [(e, s) for e in range(n) for s in (0.0, 0.5, 1.0)]
    sensors = [sensor.section_force(e, s, name=f"M{e}_{s}") for e, s in probes] + \
              [sensor.strain(e, s, name=f"k{e}_{s}") for e, s in probes]
    res = pf.simulate(model, 1e-3, integrator="generalized_alpha", step=1e-3, n_outputs=2, state=start,
                      sensors=sensors, progress=False)
    for e, s in probes:
        x = (e + s) * L / n
        M = F * (L - x)  # a tip force +z bends the beam about -y: M_y = -F (L - x) in the local frame
        sf = res.sensors[f"M{e}_{s}"][1][0]
        k = res.sensors[f"k{e}_{s}"][1][0]
        assert abs(sf[2]) == pytest.approx(M, rel=1e-6, abs=1e-9 * F * L)
        assert abs(k[2]) == pytest.approx(M / EI, rel=1e-6, abs=1e-9 * F * L / EI)
        assert np.sign(sf[2]) == np.sign(k[2])  # one sign convention
        assert abs(sf[3]) < 1e-9 * F * L and abs(k[3]) < 1e-9 * F * L / EI  # no bending about z
        assert abs(sf[0]) < 1e-3 * F  # F times the rotation (5e-5) and EA times the strains' round-off
    # a positive moment about +x, +y or +z at the tip: twist rate T / GJ, kappa = M / EI > 0
    for axis in range(3):
        b2 = pf.ModelBuilder()
        n0 = b2.add_node((0.0, 0.0, 0.0))
        b2.add_line(n0, (L, 0.0, 0.0), n, sec)
        b2.clamp(n0)
        b2.add_load(n, moment=np.eye(3)[axis] * 1e-3)
        m2 = b2.build()
        res = pf.simulate(m2, 1e-3, integrator="generalized_alpha", step=1e-3, n_outputs=2,
                          state=pf.static_equilibrium(m2).state, progress=False,
                          sensors=[sensor.strain(1, 0.3), sensor.section_force(2, 0.7)])
        k = res.sensors["strain[1](s=0.3)"][1][0]
        f = res.sensors["section_force[2](s=0.7)"][1][0]
        stiffness = (sec.GJ, EI, EI)[axis]
        np.testing.assert_allclose(k[1:], np.eye(3)[axis] * 1e-3 / stiffness, rtol=1e-6, atol=1e-12)
        np.testing.assert_allclose(f[1:], np.eye(3)[axis] * 1e-3, rtol=1e-6, atol=1e-12)


def test_crossings_of_an_oscillator_match_its_period_and_not_the_output_times():
    model, st, omega = oscillator()
    T = 2 * np.pi / omega
    y = sensor.node_position(0, "y")
    up = sensor.crossing(y, direction="up", name="up")
    down = sensor.crossing(y, 0.0, "down", name="down")
    runs = {}
    for n_outputs in (6, 51):
        for steps in (100, 200):
            res = pf.simulate(model, 5 * T, integrator="generalized_alpha", step=T / steps, n_outputs=n_outputs,
                              rho_inf=1.0, state=st, sensors=[y, up, down], progress=False)
            runs[n_outputs, steps] = res
    res = runs[51, 200]
    t_up, signs = res.sensors["up"]
    t_down = res.sensors["down"][0]
    assert np.all(signs == 1)
    # y = A sin(omega t): down through 0 at T/2, 3T/2, ...; up at T, 2T, ...
    assert len(t_down) == 5 and len(t_up) == 4
    # generalised-alpha (rho_inf = 1): the period errs by (h omega)^2 / 12 = 8.2e-5 at 200 steps
    err = np.abs(t_down - (np.arange(5) + 0.5) * T) / T
    err_up = np.abs(t_up - np.arange(1, 5) * T) / T
    assert max(err.max(), err_up.max()) < 5 * 8.3e-5
    coarse = np.abs(runs[51, 100].sensors["down"][0] - (np.arange(5) + 0.5) * T) / T
    assert coarse.max() / err.max() == pytest.approx(4.0, rel=0.1)  # second order: the integrator's error
    # not the step end (a step is 5e-3 T) nor the outputs (0.1 T apart)
    np.testing.assert_allclose(runs[6, 200].sensors["down"][0], t_down, rtol=0, atol=1e3 * ULP * T)
    assert np.abs(t_down / (T / 200) - np.round(t_down / (T / 200))).max() > 0.01


def test_a_crossing_of_a_sensor_without_a_rate_is_located_within_the_steps_interpolation_error():
    model, st, omega = oscillator()
    T = 2 * np.pi / omega
    force = sensor.spring_force(0, "y")  # -k y: no rate from the state (the parabola of three steps)
    res = pf.simulate(model, 2 * T, integrator="generalized_alpha", step=T / 200, n_outputs=3, rho_inf=1.0,
                      state=st, progress=False,
                      sensors=[force, sensor.crossing(force, direction="up", name="f"),
                               sensor.crossing(sensor.node_position(0, "y"), direction="down", name="y")])
    np.testing.assert_allclose(res.sensors["f"][0], res.sensors["y"][0], rtol=0, atol=1e-6 * T)
    t, f = res.sensors["spring_force[0].y"]
    y = res.sensors["y"]  # noqa: F841 (the crossing's own entry)
    assert f[1] < 0  # the mass moves +y first: the spring pulls back


def test_ground_spring_force_is_minus_k_times_the_displacement():
    model, st, omega = oscillator()
    res = pf.simulate(model, 0.1, integrator="generalized_alpha", step=1e-3, n_outputs=3, state=st, progress=False,
                      sensors=[sensor.spring_force(0), sensor.node_position(0, "y")])
    f = res.sensors["spring_force[0]"][1]
    y = res.sensors["node_position[0].y"][1]
    np.testing.assert_allclose(f[:, 1], -800.0 * y, rtol=0, atol=1e-12)
    assert np.all(f[:, [0, 2]] == 0)


def test_terminal_crossing_ends_the_run_at_its_step():
    model, st, omega = oscillator()
    T = 2 * np.pi / omega
    y = sensor.node_position(0, "y")
    res = pf.simulate(model, 3 * T, integrator="generalized_alpha", step=T / 100, n_outputs=31, rho_inf=1.0,
                      state=st, progress=False, sensors=[y, sensor.crossing(y, direction="down", terminal=True)])
    stop = res.metadata["stopped_at"]
    assert stop == pytest.approx(T / 2, rel=1e-3)
    assert res.t[-1] == pytest.approx(stop, abs=T / 100)
    assert res.t[-1] >= stop
    assert len(res.sensors["node_position[0].y"][0]) == res.stats["steps"] + 1


def test_ida_and_error_controlled_runs_record_every_step():
    model, st, omega = oscillator()
    T = 2 * np.pi / omega
    y = sensor.node_position(0, "y")
    for options in ({"integrator": "ida", "rtol": 1e-8, "atol": 1e-10},
                    {"integrator": "generalized_alpha", "rtol": 1e-3}):
        res = pf.simulate(model, 2 * T, n_outputs=5, state=st, progress=False,
                          sensors=[y, sensor.crossing(y, direction="up", name="up")], **options)
        t, v = res.sensors["node_position[0].y"]
        assert len(t) == res.stats["steps"] + 1
        assert np.all(np.diff(t) > 0)
        assert res.sensors["up"][0] == pytest.approx([T], rel=2e-3)


def test_to_xarray_has_the_sensors_on_their_step_time():
    pytest.importorskip("xarray")
    model, st, omega = oscillator()
    y = sensor.node_position(0, "y", name="y")
    res = pf.simulate(model, 0.2, integrator="generalized_alpha", step=1e-3, n_outputs=3, state=st, progress=False,
                      sensors=[y, sensor.energy(), sensor.crossing(y, name="zero")])
    ds = res.to_xarray()
    assert ds["y"].dims == ("step_time",) and ds["y"].attrs["units"] == "m"
    assert len(ds["step_time"]) == res.stats["steps"] + 1
    assert ds["energy"].dims == ("step_time", "energy_component")
    assert ds["zero"].dims == ("zero_event",)


def test_sensors_are_saved_and_loaded_with_the_result(tmp_path):
    model, st, omega = oscillator()
    y = sensor.node_position(0, "y")
    res = pf.simulate(model, 0.2, integrator="generalized_alpha", step=1e-3, n_outputs=3, state=st, progress=False,
                      sensors=[y, sensor.energy(), sensor.crossing(y, name="zero")])
    back = pf.analysis.TransientResult.load(res.save(tmp_path / "run"))
    assert set(back.sensors) == set(res.sensors)
    for name, (t, v) in res.sensors.items():
        np.testing.assert_array_equal(back.sensors[name][0], t)
        np.testing.assert_array_equal(back.sensors[name][1], v)
    assert back.metadata["sensors"] == res.metadata["sensors"]


def test_bad_sensors_are_refused_by_name():
    model = cantilever()
    run = dict(integrator="generalized_alpha", step=1e-3, n_outputs=2, progress=False)
    with pytest.raises(ValueError, match=r"node 99 is not in the model"):
        pf.simulate(model, 1e-3, sensors=[sensor.node_position(99)], **run)
    with pytest.raises(ValueError, match=r"element 7 is not in the model"):
        pf.simulate(model, 1e-3, sensors=[sensor.strain(7, 0.5)], **run)
    with pytest.raises(ValueError, match=r"spring 0 is not in the model"):
        pf.simulate(model, 1e-3, sensors=[sensor.spring_force(0)], **run)
    with pytest.raises(ValueError, match=r"s must be in \[0, 1\]"):
        sensor.strain(0, 1.5)
    with pytest.raises(ValueError, match="component"):
        sensor.node_position(0, "w")
    with pytest.raises(ValueError, match="choose one"):
        sensor.crossing(sensor.node_position(0))
    with pytest.raises(ValueError, match="direction"):
        sensor.crossing(sensor.node_position(0, "x"), direction="sideways")
    with pytest.raises(ValueError, match="named"):
        pf.simulate(model, 1e-3, sensors=[sensor.energy(name="e"), sensor.node_position(1, name="e")], **run)
    with pytest.raises(ValueError, match="node must be an integer"):
        sensor.node_velocity(1.5)


def _clamped_body(F=0.2):
    from pipeflex.multibody import MultibodyBuilder, flexible_body

    b = MultibodyBuilder()
    j = b.add_body(flexible_body(length=0.8, n_elements=4, section=pf.PipeSection(EI=50.0, pipe_mass=2.0)),
                   position=(0.4, 0.0, 0.0))
    b.fix(j, "start")
    b.add_load(j, "end", force=(0.0, 0.0, F))
    return b.build()


def test_joint_force_of_a_clamped_body_is_the_static_reaction():
    """A body clamped at its start under a tip force F (z): the clamp's force rows carry F,
    its moment rows F L (the multipliers' sign is the joint's convention: checked by size
    and direction)."""
    from pipeflex.multibody import static_equilibrium

    F, L = 0.2, 0.8
    system = _clamped_body(F)
    start = static_equilibrium(system).state
    res = pf.simulate(system, 1e-3, integrator="generalized_alpha", step=1e-4, n_outputs=2, state=start,
                      progress=False, sensors=[sensor.joint_force(0), sensor.joint_force(0, 2, name="fz")])
    t, lam = res.sensors["joint_force[0]"]
    assert lam.shape == (len(t), 6) and len(t) == res.stats["steps"] + 1
    assert abs(lam[0, 2]) == pytest.approx(F, rel=1e-6)
    np.testing.assert_allclose(lam[0, [0, 1]], 0.0, atol=1e-9 * F)
    assert abs(lam[0, 4]) == pytest.approx(F * L, rel=1e-3)  # about y; the deflection shortens the arm by ~1e-4
    # at rest it stays: every step's reaction within the integrator's ringing of the start
    np.testing.assert_allclose(res.sensors["fz"][1], lam[:, 2], rtol=0, atol=0)
    assert np.abs(lam[:, 2] - lam[0, 2]).max() < 1e-6 * F


def test_sensors_on_bodies_name_the_sensor_and_the_system():
    system = _clamped_body()
    run = dict(integrator="generalized_alpha", step=1e-3, n_outputs=2, progress=False)
    with pytest.raises(ValueError, match=r"sensor 'strain\[0\]\(s=0.5\)'.*floating-frame bodies.*pipe elements"):
        pf.simulate(system, 1e-3, sensors=[sensor.strain(0)], **run)
    with pytest.raises(ValueError, match=r"joint 3 is not in the system"):
        pf.simulate(system, 1e-3, sensors=[sensor.joint_force(3)], **run)
    with pytest.raises(ValueError, match=r"an element model has no joints"):
        pf.simulate(cantilever(), 1e-3, sensors=[sensor.joint_force(0)], **run)


def test_coriolis_time_lag_from_crossing_sensors_equals_the_interpolated_outputs():
    """seed 000's driven meter: the time lag from two crossing sensors (located inside the
    steps) equals the one from linearly interpolated every-step outputs within their
    interpolation error, and the complex mode's."""
    from pipeflex.seeds.seed000 import coriolis
    from pipeflex.signals import zero_crossings

    d = coriolis.driven_time_lag(flow_scaled=0.01, periods=12, ramp_periods=4, measure_periods=4,
                                 steps_per_period=100)
    res, period = d.result, 2 * np.pi / d.omega
    s1, s2 = coriolis.first_mode(pf.scenes.coriolis_meter(leg_length=coriolis.LEG_FIG8),
                                 mass_flow=d.mass_flow).sensors
    keep = res.t >= res.t[-1] - 4 * period
    z0 = [res.sensors[k][0] for k in ("S1", "S2")]
    lin = [zero_crossings(res.t[keep], res.x[keep, s, 2] - res.x[0, s, 2]) for s in (s1, s2)]
    for a, b in zip(z0, lin):
        a = a[a >= res.t[-1] - 4 * period]
        assert len(a) == len(b) >= 3
        # the linear interpolation's error near a zero, at 100 steps per period (measured 3e-6 periods)
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-5 * period)
    lag_linear = np.mean(lin[0] - lin[1])
    # the lag is 1e-3 of a period: measured 1.1e-3 relative apart, the sensors' 1.2e-4 from the mode's
    assert d.time_lag == pytest.approx(lag_linear, rel=5e-3)
    assert d.time_lag == pytest.approx(d.time_lag_mode, rel=1e-3)
