"""The periodic analyses on floating-frame bodies and coupled systems: seed 004's FFRF
cantilever's Hopf point against the element model of the same pipe, its orbit branch's
branch point and the switched (non-planar) branch, continuation in gravity by name
against the system built anew, the parameter's name in the shooting's messages; the
forced response of a clamped-clamped chain of bodies through its own loads: the linear
limit against pf.linearize's FRF, the hardening folds against the element model's, the
transient sweep, the backbone's refusal."""
import numpy as np
import pytest

import pipeflex as pf
from pipeflex.analysis import periodic
from pipeflex.errors import ConvergenceError
from pipeflex.multibody import MultibodyBuilder, flexible_body
from pipeflex.seeds.seed004.studies import element_cantilever_model

STEPS = 128


def cantilever(**options):
    """Seed 004's cantilever of 2 FFRF bodies of 4 elements, 1.5 N tip force along z, the
    flow's lever arm on the deformed centre line (so that it flutters as the element model)."""
    return pf.scenes.ffrf_cantilever_pipe(n_bodies=2, elements_per_body=4, tip_force=1.5,
                                          fluid_lever_arm="deformed", **options)


def test_the_hopf_point_of_the_bodies_is_the_element_models():
    """pf.critical_mass_flow of the chain against the element model of the same pipe (8
    elements, the chain's mesh): unreduced bodies agree to the formulations' difference
    (measured 1.4e-4 kg/s, 2.3e-5 rad/s); with boundary modes only the modal truncation
    raises the flow by 0.046 kg/s (1.8e-3)."""
    model, _ = element_cantilever_model(n_elements=8, tip_force=1.5)
    ref = pf.critical_mass_flow(model)
    full = pf.critical_mass_flow(cantilever(reduction="full"))
    assert full.mass_flow == pytest.approx(ref.mass_flow, abs=1e-3)
    assert full.frequency == pytest.approx(ref.frequency, abs=1e-3)
    reduced = pf.critical_mass_flow(cantilever())
    assert 0.0 < reduced.mass_flow - ref.mass_flow < 3e-3 * ref.mass_flow
    assert reduced.frequency == pytest.approx(ref.frequency, rel=5e-3)


@pytest.fixture(scope="module")
def branch():
    """The chain's flutter cycle continued from its Hopf point: it swings across the tip
    force's plane (along y; along z only the deflection's second-order wobble, ~1e-6 m)
    and loses stability out of its plane at a branch point just above."""
    system = cantilever()
    hopf = pf.critical_mass_flow(system)
    br = pf.continue_orbits(system, start=hopf, mass_flow_end=hopf.mass_flow + 0.1, amplitude=1e-2, steps=STEPS,
                            max_points=3)
    tip = system.bodies[0].n_nodes + system.bodies[1].node_index("end")
    return system, tip, br


def test_the_body_branch_has_a_branch_point_and_the_switched_branch_leaves_the_plane(branch):
    system, tip, br = branch
    assert np.all(br.amplitude[:, tip, 2] < 1e-5) and np.all(br.amplitude[:, tip, 1] > 5e-3)  # (nearly) planar
    points = [b for b in br.bifurcations if b.kind == "branch_point"]
    assert len(points) == 1
    bp = points[0]
    # measured 25.0559 kg/s, 2.1e-3 kg/s above the Hopf point (unreduced bodies: 2.0e-3)
    assert 0.0 < bp.parameter - br.hopf[0] < 5e-3 and bp.located and abs(bp.residual) < 1e-5
    assert bp.y.shape == (2 * system.n_coordinates + 1,)
    new = pf.switch_branch(br, bp, amplitude=2e-3, max_points=2)
    assert np.all(new.amplitude[:, tip, 2] > 5e-4)  # out of the plane
    assert np.all(np.abs(new.mass_flow - bp.parameter) < 2e-2)
    # an orbit of the bodies: solved again at its flow it stays out of the plane
    k = len(new.mass_flow) - 1
    again = pf.periodic_orbit(system, period=new.period[k], state=new.starts[k], mass_flow=new.mass_flow[k],
                              steps=STEPS)
    assert again.amplitude[tip, 2] == pytest.approx(new.amplitude[k, tip, 2], rel=1e-4)


def _with_gravity(system, g):
    """The chain built anew with the gravity g [m/s^2] (its builder's description)."""
    from pipeflex.multibody.system import _rebuild_system

    data, junction_forces = system._description
    return _rebuild_system(({**data, "_gravity": np.asarray(g, float)}, junction_forces), system.mass_flow)


@pytest.fixture(scope="module")
def gravity_branch(branch):
    system, tip, br = branch
    start = pf.periodic_orbit(system, period=br.period[-1], state=br.starts[-1], mass_flow=br.mass_flow[-1],
                              steps=STEPS)
    return start, pf.continue_orbits(system, start=start, parameter="gravity_z", end=-0.1, ds=0.05, max_points=2)


def test_gravity_by_name_continues_the_bodies_orbit_of_the_system_built_anew(branch, gravity_branch):
    """The branch in gravity_z (0 down past -0.1 m/s^2) at a fixed flow: its orbits are those
    of the chain built anew with that gravity (the same period and tip amplitude)."""
    system, tip, _ = branch
    start, g = gravity_branch
    assert g.parameter_name == "gravity_z" and g.parameter[0] < 0.0 and g.parameter[-1] <= -0.1
    assert np.all(g.mass_flow == start.mass_flow)
    k = len(g.parameter) - 1
    anew = _with_gravity(system, (0.0, 0.0, g.parameter[k]))
    orbit = pf.periodic_orbit(anew, period=g.period[k], state=g.starts[k], mass_flow=start.mass_flow, steps=STEPS)
    assert orbit.iterations <= 2 and orbit.period == pytest.approx(g.period[k], rel=1e-8)
    assert orbit.amplitude[tip, 1] == pytest.approx(g.amplitude[k, tip, 1], rel=1e-6)
    # gravity down lowers the cycle's centre: its orbits differ from the start's
    assert abs(g.period[k] - start.period) > 1e-6 * start.period


def test_the_shootings_messages_name_the_continued_parameter(gravity_branch):
    """A failed shooting in gravity_z names gravity_z and its value, not a scaled value as
    a mass flow."""
    start, g = gravity_branch
    shooter, par = g._context["shooter"], g._context["par"]
    k = len(g.parameter) - 1
    y = np.concatenate([start.z0, start.v0, [1.01 * start.period]])  # no orbit at this gravity
    with pytest.raises(ConvergenceError, match=rf"gravity_z = {g.parameter[k]:.6g} \(mdot = ") as info:
        periodic._solve(shooter, y, g.parameter[k] / par.scale, tol=1e-14, max_iterations=1)
    assert "mdot = -" not in str(info.value)


def _pipe_on_body(g_bodies=(0.0, 0.0, -9.81), g_model=(0.0, 0.0, -9.81)):
    """An element pipe clamped to the end of one FFRF body, both under gravity."""
    bb = MultibodyBuilder()
    body = flexible_body(length=0.5, n_elements=2, section=pf.scenes.ffrf_cantilever_pipe(
        n_bodies=1, elements_per_body=2).bodies[0].section)
    j = bb.add_body(body, position=(0.25, 0.0, 0.0))
    bb.fix(j, "start")
    bb.set_gravity(g_bodies)
    b = pf.ModelBuilder()
    n0 = b.add_node((0.5, 0.0, 0.0))
    b.add_line(n0, (1.0, 0.0, 0.0), 2, body.section)
    b.set_gravity(g_model)
    system = pf.CoupledSystem(b.build(floating=True), bb.build())
    system.rigid(n0, 0, "end")
    return system


def test_gravity_by_name_rebuilds_a_coupled_system_and_refuses_what_bodies_do_not_know():
    system = _pipe_on_body()
    par = periodic._parameter(system, "gravity", None, 0.0)
    assert par.value == pytest.approx(9.81)
    out = par.rebuild(2.0)
    assert isinstance(out, pf.CoupledSystem) and out.joints == system.joints
    assert np.allclose(out.model.gravity, (0, 0, -2.0)) and np.allclose(out.bodies.gravity, (0, 0, -2.0))
    assert np.allclose(system.bodies.gravity, (0, 0, -9.81))  # the start's system is left alone
    with pytest.raises(ValueError, match="differ"):
        periodic._parameter(_pipe_on_body(g_model=(0.0, 0.0, -1.0)), "gravity_z", None, 0.0)
    bodies = cantilever()
    with pytest.raises(ValueError, match="mass_flow, gravity, gravity_x, gravity_y, gravity_z"):
        periodic._parameter(bodies, "EI", None, 25.0)
    with pytest.raises(ValueError, match="which is zero"):
        periodic._parameter(bodies, "gravity", None, 25.0)
    rebuild = periodic._parameter(bodies, "gravity_y", None, 25.0).rebuild
    assert np.allclose(rebuild(-3.0).gravity, (0.0, -3.0, 0.0)) and rebuild(-3.0).info == bodies.info


# ---------------------------------------------------------------------------------------
# forced response of a clamped-clamped chain of bodies

#: the chain's midspan force [N] of the nonlinear test (the element tests' beam, FORCE)
FORCE = 0.15


def chain(zeta=0.011, force=None):
    """tests/test_forced_response.py's clamped-clamped beam (L = 1 m, EI = 1 N m^2, 1 kg/m,
    EA = 1e4 N: stretching hardens it) as 2 FFRF bodies of 2 elements (boundary modes),
    modal damping ratio ``zeta``; with ``force`` [N] a midspan load along y (the body
    chain's own load, MultibodyBuilder.add_load). Returns it and its midspan point."""
    sec = pf.PipeSection(EI=1.0, pipe_mass=1.0, EA=1e4, rotary_inertia=(1e-3, 1e-4, 1e-4))
    body = flexible_body(length=0.5, n_elements=2, section=sec, modal_damping=zeta)
    b = MultibodyBuilder()
    j0, j1 = b.add_body(body, position=(0.25, 0.0, 0.0)), b.add_body(body, position=(0.75, 0.0, 0.0))
    b.rigid(j0, "end", j1, "start")
    b.fix(j0, "start")
    b.fix(j1, "end")
    if force is not None:
        b.add_load(j0, "end", force=(0.0, force, 0.0))
    return b.build(), body.n_elements


def _midspan_row(system, point, component):
    """d x_point,component / d z of the chart at rest (central differences): the output
    row, and its transpose the generalised force of a unit dead load there."""
    chart = periodic._chart(system, None)
    n, eps = chart.n, 1e-7
    row = np.zeros(n)
    for i in range(n):
        dz = np.zeros(n)
        dz[i] = eps
        row[i] = (chart.positions(dz)[0, point, component] - chart.positions(-dz)[0, point, component]) / (2 * eps)
    return row


def test_small_forcing_of_the_bodies_is_pf_linearizes_frf():
    """A small midspan force of the body chain's own load, driven by load_factor: the
    amplitude is abs(H) F with H from pf.linearize(bodies)'s M, C, K (independent
    coordinates, through its null-space basis) at the trapezoidal rule's frequency
    2/h tan(Omega h / 2): measured 6.8e-5 (rho_inf = 0.9 differs from the trapezoidal
    rule by O((Omega h)^2) on the bending mode's damping; rho_inf = 1 leaves the chain's
    stiff modes undamped and the shooting stalls), against 5.7e-3 at the plain Omega."""
    F, N = 4e-4, 128
    system, mid = chain(zeta=0.056, force=F)
    r = pf.forced_response(system, load_factor=pf.Sine(omega=1.0, envelope=1.0), frequencies=(19.0, 26.0),
                           max_points=6, ds=0.3, max_step=0.6, steps=N, tol=1e-12, newton_tol=1e-13, rho_inf=0.9)
    assert (r.node, r.component) == (mid, 1)  # the loaded point and direction by default
    assert len(r.frequency) == 6 and r.stable.all() and len(r.folds) == 0
    lin = pf.linearize(system)
    M, C, K = (np.asarray(a.toarray() if hasattr(a, "toarray") else a) for a in (lin.M, lin.C, lin.K))
    B = np.asarray(lin.basis.toarray() if hasattr(lin.basis, "toarray") else lin.basis)
    c = _midspan_row(system, mid, 1) @ B

    def frf(w):
        return np.array([abs(c @ np.linalg.solve(-x ** 2 * M + 1j * x * C + K, c * F)) for x in w])

    h = 2 * np.pi / r.frequency / N
    warped = 2 / h * np.tan(r.frequency * h / 2)
    assert np.abs(r.amplitude / frf(warped) - 1).max() < 2e-4
    assert np.abs(r.amplitude / frf(r.frequency) - 1).max() > 1e-3


def test_the_bodies_harden_as_the_element_model_and_the_sweep_agrees():
    """At the element tests' force the chain's response bends over (stretching through the
    frames' turns and the bodies' axial modes) with two folds near the element model's
    (4 elements, Kelvin-Voigt damping of 1.1 % at the first mode; the bodies' modal ratio
    1.1 % of their elastic modes): measured
    25.19 / 23.28 rad/s against 25.27 / 23.64, the truncation's (2 bodies of boundary modes)
    and damping's difference; load= on the unloaded chain is the same forcing."""
    unloaded, mid = chain()
    r = pf.forced_response(unloaded, load=(0, "end", (0.0, FORCE, 0.0)), frequencies=(15.0, 40.0))
    assert len(r.folds) == 2 and not r.stable.all()
    assert r.folds[0] == pytest.approx(25.27, rel=0.01)
    assert r.folds[1] == pytest.approx(23.64, rel=0.02)
    # the loaded chain driven by load_factor: the same curve's first orbit
    loaded, _ = chain(force=FORCE)
    same = pf.forced_response(loaded, load_factor=pf.Sine(omega=1.0, envelope=1.0), frequencies=(15.0, 40.0),
                              max_points=2)
    assert same.amplitude[0] == pytest.approx(r.amplitude[0], rel=1e-8)
    # a stepped sine below the folds settles on the stable orbit there (slowly: the bodies'
    # modal damping acts on their elastic coordinates, not on the frames' turns, so the
    # chain's first mode keeps about a tenth of the ratio; 600 periods leave 3e-3 of the start)
    sweep = pf.frequency_sweep(unloaded, load=(0, "end", (0.0, FORCE, 0.0)), frequencies=[18.0], periods=600)
    at = pf.forced_response(unloaded, load=(0, "end", (0.0, FORCE, 0.0)), frequencies=(18.0, 19.0), max_points=1)
    assert sweep.node == mid and sweep.amplitude[0] == pytest.approx(at.amplitude[0], rel=0.01)


def test_backbone_refuses_bodies_and_load_needs_an_unloaded_chain():
    loaded, _ = chain(force=FORCE)
    with pytest.raises(ValueError, match="backbone needs an element pipeflex.Model"):
        pf.backbone(loaded, node=2, component=1, amplitude_max=0.01)
    with pytest.raises(ValueError, match="system without loads"):
        pf.forced_response(loaded, load=(0, "end", (0.0, 1.0, 0.0)), frequencies=(15.0, 40.0))
    with pytest.raises(ValueError, match=r"\(body, node, force\)"):
        pf.forced_response(chain()[0], load=(2, (0.0, 1.0, 0.0)), frequencies=(15.0, 40.0))


def test_a_transients_load_factor_scales_the_bodies_loads():
    """pf.simulate(bodies, load_factor=...) scales the bodies' own loads (as an element
    model's nodal loads; gravity stays): a factor 0 leaves the loaded chain at rest, 0.5
    halves its (linear) midspan motion."""
    loaded, mid = chain(force=1e-3)

    def motion(factor):
        run = pf.simulate(loaded, 0.05, step=1e-3, n_outputs=6, load_factor=factor, progress=False,
                          integrator="generalized_alpha")
        eta = run.bodies.eta[-1] - loaded.initial_state().eta
        return np.abs(run.bodies.r[-1] - loaded.initial_state().r).max(), np.abs(eta).max()

    assert max(motion(0.0)) == 0.0
    full, half = np.array(motion(1.0)), np.array(motion(0.5))
    assert full.max() > 1e-7 and half == pytest.approx(0.5 * full, rel=1e-3)
