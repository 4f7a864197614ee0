"""Element models and floating-frame bodies in one system: the coupled equations
integrated by the one generalised-alpha integrator."""
import numpy as np
import pytest

import pipeflex as pf
from helpers import on_clamped_hub
from pipeflex import coupled, scenes
from pipeflex.coupled import CoupledSystem, simulate
from pipeflex.multibody import MultibodyBuilder, flexible_body
from pipeflex.seeds.seed002.studies import tip_deflection
from pipeflex.seeds.seed004.coupled_scenes import angular_momentum_z, hub_frame_deflection

HUB = pf.PipeSection(EI=1e5, pipe_mass=5.0, rotary_inertia=(1e-2, 0.0, 0.0))


def hub_body(*, torque=None, axis=(0.0, 0.0, 1.0), gravity=None):
    """A stiff 0.2 m hub body ending at the origin, hinged to the ground there."""
    mb = MultibodyBuilder()
    j = mb.add_body(flexible_body(length=0.2, n_elements=2, section=HUB), position=(-0.1, 0.0, 0.0))
    mb.hinge(j, "end", axis, torque=torque)
    if gravity is not None:
        mb.set_gravity(gravity)
    return mb.build(), j


def sprinkler_arm(EI=100.0, mass_flow=10.0):
    """The seed-000 sprinkler's semicircular arm (scenes.sprinkler) without its hinge."""
    sec = pf.PipeSection(EI=EI, EA=scenes.SPRINKLER_EA, GJ=EI / 1.3, pipe_mass=0.5, fluid_mass=1.0,
                         rotary_inertia=(1e-4, 0.0, 0.0))
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    b.add_arc(n0, center=(0.5, 0.0, 0.0), angle=-np.pi, normal=(0.0, 0.0, 1.0), n_elements=8, section=sec)
    return b.build(mass_flow=mass_flow, floating=True), n0


def test_sprinkler_on_a_hub_body_reaches_the_element_sprinklers_speed():
    """Acceptance scene (a): the arm rigidly joined to a hinged hub body with inertia,
    driven by the flow, ends at the element-only sprinkler's speed (same step and
    rho_inf: the same discrete steady state, 9.00976 rad/s; steady_rotation's
    9.009826 differs by the O(h^2) error of h = 1 ms). The hub's inertia only slows the
    spin-up."""
    cs, n0, j = scenes.sprinkler_on_hub()
    res = simulate(cs, 3.0, step=1e-3, n_outputs=31)
    alone = pf.simulate(scenes.sprinkler(EI=100.0), 3.0, integrator="generalized_alpha", step=1e-3,
                        rho_inf=0.8, n_outputs=31, progress=False)
    w_hub = res.bodies.node_angular_velocity(j, "end")[:, 2]
    # the joint holds (velocities to the index-3 form's drift: positions are enforced)
    assert res.elements.omega[:, n0, 2] == pytest.approx(w_hub, rel=1e-5)
    assert w_hub[-1] == pytest.approx(alone.omega[-1, 0, 2], rel=1e-8)
    assert w_hub[-1] == pytest.approx(pf.steady_rotation(scenes.sprinkler(EI=100.0)).omega, rel=2e-5)
    # positions: the arm's inlet stays on the hinge with the hub's node
    assert np.abs(res.elements.x[:, n0]).max() < 1e-9
    # a heavier hub spins up later to the same speed
    heavy, _, jh = scenes.sprinkler_on_hub(hub_inertia=1.0)
    slow = simulate(heavy, 0.5, step=1e-3, n_outputs=6)
    assert slow.bodies.angular_velocity(jh)[-1, 2] < 0.95 * w_hub[5]  # 8.24 against 8.87 rad/s at 0.5 s


def test_pendulum_of_elements_and_a_body_keeps_its_energy():
    """Without flow: a straight arm of elements rigidly joined to a hub body hinged about a
    horizontal axis swings down under gravity; the energy of both parts together is kept
    (rho_inf = 0.95, h = 0.5 ms: the numerical damping takes little)."""
    g = (0.0, 0.0, -9.81)
    sec = pf.PipeSection(EI=50.0, EA=1e6, GJ=40.0, pipe_mass=1.0, rotary_inertia=(1e-3, 5e-4, 5e-4))
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    b.add_line(n0, (0.6, 0.0, 0.0), 4, sec)
    b.set_gravity(g)
    arm = b.build(floating=True)
    hub, j = hub_body(axis=(0.0, 1.0, 0.0), gravity=g)
    cs = CoupledSystem(arm, hub)
    cs.rigid(n0, j, "end")
    res = simulate(cs, 0.6, step=5e-4, n_outputs=13, rho_inf=0.95, mass_flow=0.0)
    E = res.elements.energy + np.array([hub.energy(res.bodies.state(k)) for k in range(len(res.t))])
    kinetic = res.elements.kinetic.max()
    assert kinetic > 0.5  # it swung
    assert np.abs(E - E[0]).max() < 2e-5 * kinetic  # measured 1.9e-6


def test_hinge_torque_turns_arm_and_hub_together():
    """A driving torque at the hub's hinge: the element node joined to the hub turns with
    it (equal angular velocities), and the stiff system's mean rate follows T t / I."""
    sec = pf.PipeSection(EI=1e4, EA=1e7, GJ=1e4, pipe_mass=1.5, rotary_inertia=(1e-4, 0.0, 0.0))
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    b.add_line(n0, (0.5, 0.0, 0.0), 2, sec)
    arm = b.build(floating=True)
    hub, j = hub_body(torque=1.0)
    cs = CoupledSystem(arm, hub)
    cs.rigid(n0, j, "end")
    res = simulate(cs, 0.2, step=5e-4, n_outputs=5, mass_flow=0.0)
    w = res.bodies.node_angular_velocity(j, "end")[:, 2]
    assert res.elements.omega[:, n0, 2] == pytest.approx(w, rel=1e-5)
    inertia = 1.5 * 0.5**3 / 3 + 5.0 * 0.2**3 / 3  # arm and hub about the hinge [kg m^2]
    assert w[-1] == pytest.approx(1.0 * res.t[-1] / inertia, rel=2e-2)


def test_couplings_refuse_bad_input():
    arm, n0 = sprinkler_arm()
    hub, j = hub_body()
    cs = CoupledSystem(arm, hub)
    with pytest.raises(ValueError, match="do not coincide"):
        cs.rigid(n0, j, "start")
    with pytest.raises(ValueError, match="node must be a node of the element model"):
        cs.rigid(99, j, "end")
    with pytest.raises(ValueError, match="axis"):
        cs.hinge(n0, j, "end", (0.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="model must be a pipeflex.Model"):
        CoupledSystem(hub, hub)
    with pytest.raises(ValueError, match="rho_inf"):
        simulate(cs, 1.0, step=1e-3, rho_inf=1.0)
    with pytest.raises(ValueError, match="no supports"):
        b = pf.ModelBuilder()
        b.add_line(b.add_node((0, 0, 0)), (1, 0, 0), 2, pf.PipeSection(EI=1.0, pipe_mass=1.0))
        b.build()


def test_pf_simulate_takes_a_coupled_system():
    arm, n0 = sprinkler_arm()
    hub, j = hub_body()
    cs = pf.CoupledSystem(arm, hub)
    cs.rigid(n0, j, "end")
    a = pf.simulate(cs, 0.05, step=1e-3, n_outputs=3, rho_inf=0.8)
    b = simulate(cs, 0.05, step=1e-3, n_outputs=3, rho_inf=0.8)
    # exact: pf.simulate calls the same integrator with the same options
    assert np.array_equal(a.elements.x, b.elements.x) and np.array_equal(a.bodies.r, b.bodies.r)


# -- acceptance scene (b): seed 002's rotating cantilever on a free hub ------------------

SPIN = dict(omega=2.0, spin_up_time=2.0, t_end=3.0)  # Omega [rad/s], T [s], run [s]


def test_free_hub_approaches_the_prescribed_spin_up():
    """Acceptance scene (b): with a motor torque instead of a prescribed angle, the tip
    deflection in the hub frame approaches the prescribed-rate result (the co-rotating
    model of scenes.rotating_cantilever, same elements and step) as the hub's inertia
    grows: its deviation falls like 1/J (measured 2.0e-3 at J = 100, 2.1e-5 at 1e4)."""
    ref = scenes.rotating_cantilever(n_elements=6, omega=SPIN["omega"], spin_up_time=SPIN["spin_up_time"])
    prescribed = pf.simulate(ref, SPIN["t_end"], integrator="generalized_alpha", step=1e-3, n_outputs=7,
                             rho_inf=0.8, progress=False)
    expected = tip_deflection(ref, prescribed)
    deviation = []
    for J in (1e2, 1e4):
        cs, nodes, j, _ = scenes.beam_on_free_hub(hub_inertia=J, **SPIN)
        res = simulate(cs, SPIN["t_end"], step=1e-3, n_outputs=7, mass_flow=0.0)
        deviation.append(np.abs(hub_frame_deflection(res, nodes[-1], j) - expected).max())
    assert deviation[1] < 1e-4 < deviation[0] < 1e-2
    assert deviation[0] / deviation[1] == pytest.approx(100.0, rel=0.3)


def test_free_hub_angular_momentum_equals_the_torque_impulse():
    """Angular momentum about the hinge axis at the end of the run, beam (Hermite
    interpolation of the ANCF nodes) plus hub body (the generalised momentum of its mass
    matrix), equals the impulse of the motor torque from rest (the table's integral), to
    1e-6: a light hub (J = 1 kg m^2, three times the beam's inertia) whose motion the
    beam's bending disturbs strongly."""
    cs, nodes, j, (tt, torque) = scenes.beam_on_free_hub(hub_inertia=1.0, **SPIN)
    res = simulate(cs, SPIN["t_end"], step=1e-3, n_outputs=3, mass_flow=0.0)
    impulse = np.trapz(torque, tt)
    H = angular_momentum_z(res, cs, nodes, j)
    assert H == pytest.approx(impulse, rel=1e-6)
    # the beam carries a good part of it: the hub alone would not balance
    hub_only = angular_momentum_z(res, cs, nodes[:1], j)
    assert abs(hub_only - impulse) > 0.2 * impulse


def test_pf_simulate_takes_a_multibody_system():
    """One entry for every system: pf.simulate runs a MultibodySystem through
    pipeflex.multibody.simulate (the same integrator), with the same option names."""
    from pipeflex.multibody import simulate as mb_simulate

    s = scenes.ffrf_cantilever_pipe(n_bodies=2, elements_per_body=4, tip_force=1.5)
    a = pf.simulate(s, 0.02, step=1e-3, n_outputs=3, mass_flow=30.0, rho_inf=0.8)
    b = mb_simulate(s, 0.02, step=1e-3, n_outputs=3, mass_flow=30.0, rho_inf=0.8)
    assert np.array_equal(a.r, b.r) and np.array_equal(a.eta, b.eta)  # exact: one integrator, one call


TIP_SECTION = pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0, EA=1e5, rotary_inertia=(1e-3, 0.0, 0.0))


def tip_loaded_arm(n, *, clamped, mass_flow=0.0, force=1.5):
    """Seed 000's Fig. 3 cantilever (L = 1 m, EI = 10 N m^2, EA = 1e5 N) of n elements under
    a tip force [N] (1.5 N): (model, root node, tip node)."""
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    nodes = b.add_line(n0, (1.0, 0.0, 0.0), n, TIP_SECTION)
    b.add_load(nodes[-1], force=(0.0, force, 0.0))
    if clamped:
        b.clamp(n0)
    return b.build(mass_flow=mass_flow, floating=not clamped), n0, nodes[-1]


def test_coupled_statics_take_the_mixed_newton():
    """The coupled system's Newton passes its corrections to the element part, whose
    tangent then takes the extrapolated stresses (the statics' mixed Newton): a
    512-element cantilever clamped to a clamped hub body solves its 1.5 N tip force in one
    load step and as few iterations as 64 elements (4; with the state's own stresses in
    the tangent the count grows with the mesh: docs/statics.md)."""
    counts, tips = [], []
    for n in (64, 512):
        arm, root, tip = tip_loaded_arm(n, clamped=False)
        st = pf.static_equilibrium(on_clamped_hub(arm, root, stiffness_ratio=1e4), max_bisections=0)
        counts.append(st.iterations)
        tips.append(st.state.q[6 * tip + 1])
    assert counts[1] <= counts[0] + 1 <= 6, counts
    assert tips[1] == pytest.approx(tips[0], rel=1e-5)  # 0.0499 m: P L^3 / 3 EI = 0.05 m


def test_a_failed_coupled_load_step_is_halved(monkeypatch):
    """The coupled statics step the load on the package's one continuation driver (as
    element models): the 8-element cantilever on a clamped hub under a 50 N tip force
    (tip at 0.61 m, 0.72 m) diverges in one load step; the step is halved, 0.5 and 1
    converge, and the equilibrium is the one of two load steps, bit for bit (the same two
    solves from the same state, in one process)."""
    calls = []
    solve = coupled._core.static_equilibrium

    def recorded(*args):  # (system, mass_flow, load_factor, tol, max_iterations)
        out = solve(*args)
        calls.append((args[2], bool(out["converged"]), out["iterations"]))
        return out
    arm, root, tip = tip_loaded_arm(8, clamped=False, force=50.0)
    cs = on_clamped_hub(arm, root, stiffness_ratio=1e4)
    monkeypatch.setattr(coupled._core, "static_equilibrium", recorded)
    st = pf.static_equilibrium(cs, load_steps=1)
    assert [c[:2] for c in calls] == [(1.0, False), (0.5, True), (1.0, True)]
    assert st.iterations == sum(c[2] for c in calls)
    two = pf.static_equilibrium(cs, load_steps=2)
    np.testing.assert_array_equal(st.state.q, two.state.q)
    np.testing.assert_array_equal(st.coupling_forces, two.coupling_forces)
    np.testing.assert_array_equal(st.body_state.eta, two.body_state.eta)
    assert st.state.q[6 * tip:6 * tip + 2] == pytest.approx([0.609, 0.717], abs=1e-3)


def test_coupled_max_bisections_is_honoured():
    """max_bisections=0: the diverging full step of the 50 N cantilever raises, with the
    load factor, iteration, residual and flow of the failed step; a negative count is a
    ValueError naming it."""
    arm, root, _ = tip_loaded_arm(8, clamped=False, force=50.0)
    cs = on_clamped_hub(arm, root, stiffness_ratio=1e4)
    with pytest.raises(pf.ConvergenceError, match=r"load factor 1 \(from 0, after 0 halvings") as caught:
        pf.static_equilibrium(cs, max_bisections=0)
    e = caught.value
    assert (e.load_factor, e.mass_flow) == (1.0, 0.0)
    assert e.iteration >= 1 and e.residual > 0.0
    with pytest.raises(pf.ConvergenceError, match=r"load factor 0.5 \(from 0, after 1 halvings"):
        coupled.static_equilibrium(cs, load_steps=1, max_bisections=1, max_iterations=2)
    with pytest.raises(ValueError, match="max_bisections"):
        pf.static_equilibrium(cs, max_bisections=-1)


def test_static_cantilever_on_a_clamped_hub_equals_the_clamped_elements():
    """pf.static_equilibrium of a coupled system (the core's Newton on the KKT matrix of
    element and body equations): a cantilever of 8 pipe elements clamped to a hub body that
    is clamped to the ground deflects under a 1.5 N tip force and 10 kg/s as the same
    cantilever clamped to the ground (seed 000's Fig. 3 beam: 0.029 m; the stiff hub adds
    its compliance: 1e-4 relative). Without flow its multipliers balance the load."""
    alone, _, tip = tip_loaded_arm(8, clamped=True, mass_flow=10.0)
    expected = pf.static_equilibrium(alone).state.q[6 * tip + 1]
    floating, n0, tip = tip_loaded_arm(8, clamped=False, mass_flow=10.0)
    cs = on_clamped_hub(floating, n0, stiffness_ratio=1e4)
    st = pf.static_equilibrium(cs, load_steps=2)
    assert st.state.q[6 * tip + 1] == pytest.approx(expected, rel=1e-4)
    assert 0.02 < expected < 0.06  # 0.029 m
    # without flow the clamp to the ground carries the 1.5 N (its force multiplier along y);
    # with flow the fluid's forces on the bent pipe take part of it
    still = pf.static_equilibrium(cs, mass_flow=0.0)
    assert abs(still.body_state.lam[1]) == pytest.approx(1.5, rel=1e-6)
    assert abs(st.body_state.lam[1]) < 1.4
    # a hinged hub leaves the rotation free: a mechanism
    mb2 = MultibodyBuilder()
    j2 = mb2.add_body(flexible_body(length=0.2, n_elements=2, section=HUB), position=(-0.1, 0.0, 0.0))
    mb2.hinge(j2, "end", (0.0, 0.0, 1.0))
    loose = pf.CoupledSystem(floating, mb2.build())
    loose.rigid(n0, j2, "end")
    with pytest.raises(pf.SingularMatrixError, match="mechanism"):
        pf.static_equilibrium(loose)


def test_pf_static_equilibrium_passes_max_iterations_to_the_coupled_statics(monkeypatch):
    """One default, 30 Newton iterations per load step (as the element and multibody
    statics), and pf.static_equilibrium passes a given count on to the core."""
    seen = []
    solve = coupled._core.static_equilibrium

    def recorded(*args):  # (system, mass_flow, load_factor, tol, max_iterations)
        seen.append(args[4])
        return solve(*args)
    arm, root, _ = tip_loaded_arm(8, clamped=False)
    cs = on_clamped_hub(arm, root, stiffness_ratio=1e4)
    monkeypatch.setattr(coupled._core, "static_equilibrium", recorded)
    pf.static_equilibrium(cs)
    pf.static_equilibrium(cs, max_iterations=7)
    assert seen == [30, 7]
