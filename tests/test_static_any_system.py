"""pf.static_equilibrium is one driver for every formulation: load stepping, arc-length
continuation (path="arclength") and flow continuation (from_mass_flow) on a system of
bodies and on a coupled system, through the core's system object (_core.static_arc_newton
and _core.static_arc_tangent on any System)."""
import numpy as np
import pytest

import pipeflex as pf
from helpers import on_clamped_hub
from pipeflex import _core
from pipeflex.analysis import arclength, static
from pipeflex.multibody import MultibodyBuilder, flexible_body

L = 0.8  # m
FLUID = pf.PipeSection(EI=50.0, pipe_mass=2.0, fluid_mass=1.0, rotary_inertia=(1e-3, 0.0, 0.0))
ARM = pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0, EA=1e5, rotary_inertia=(1e-3, 0.0, 0.0))


def bodies(force=(0.0, 40.0, 0.0), *, n_bodies=1, mass_flow=0.0):
    """A cantilever of ``n_bodies`` fluid-carrying bodies along x (rigidly joined, the
    first clamped), ``force`` [N] at the tip."""
    b = MultibodyBuilder()
    length = L / n_bodies
    previous = None
    for k in range(n_bodies):
        j = b.add_body(flexible_body(length=length, n_elements=4, section=FLUID),
                       position=((k + 0.5) * length, 0.0, 0.0))
        if previous is None:
            b.fix(j, "start")
        else:
            b.rigid(previous, "end", j, "start")
        previous = j
    b.add_load(previous, "end", force=force)
    return b.build(mass_flow=mass_flow)


def coupled(*, mass_flow=0.0, force=1.5, n=8):
    """A cantilever of n pipe elements (L = 1 m, EI = 10 N m^2) under a tip force [N],
    clamped to a stiff hub body clamped to the ground: (system, tip node)."""
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    nodes = b.add_line(n0, (1.0, 0.0, 0.0), n, ARM)
    b.add_load(nodes[-1], force=(0.0, force, 0.0))
    arm = b.build(mass_flow=mass_flow, floating=True)
    return on_clamped_hub(arm, n0, stiffness_ratio=1e4), nodes[-1]


def counted(monkeypatch):
    """The arc-length correctors the driver calls (static._arc_newton), counted."""
    calls = []
    corrector = static._arc_newton

    def counting(*args, **kwargs):
        out = corrector(*args, **kwargs)
        calls.append(out[0])
        return out
    monkeypatch.setattr(static, "_arc_newton", counting)
    return calls


def tip(system, st):
    """A system of bodies' tip position [m]."""
    return np.asarray(pf.multibody.MultibodyResult(
        np.zeros(1), st.r[None], st.R[None], st.eta[None], st.v[None], np.zeros(1), np.array(system.offsets),
        system.n_constraints, tuple(np.array(b.nodes_s) for b in system.bodies),
        tuple(np.array(b.basis) for b in system.bodies)).node_position(len(system.bodies) - 1, "end")[0])


def test_the_bodies_arclength_path_ends_where_load_stepping_does(monkeypatch):
    """A two-body cantilever under 40 N at its tip (a deflection of 0.1 of its length):
    path="arclength" follows the path from rest by the core's bordered Newton on the
    bodies' system object and lands on the load stepping's equilibrium (to the Newton
    tolerance, 1e-10 model sizes, far below 1e-8), with no limit point passed."""
    system = bodies(n_bodies=2)
    stepped = pf.static_equilibrium(system, path="load")
    calls = counted(monkeypatch)
    arc = pf.static_equilibrium(system, path="arclength")
    assert len(calls) >= 2 and all(calls[-2:])
    assert isinstance(arc, pf.StaticResult) and arc.limit_points == ()
    deflection = tip(system, stepped.state)[1]
    assert 0.05 * L < deflection < 0.5 * L
    np.testing.assert_allclose(tip(system, arc.state), tip(system, stepped.state), rtol=0, atol=1e-8 * L)
    np.testing.assert_allclose(arc.state.eta, stepped.state.eta, rtol=0,
                               atol=1e-8 * np.abs(stepped.state.eta).max())
    np.testing.assert_allclose(arc.state.lam, stepped.state.lam, rtol=1e-7, atol=1e-7 * 40.0)
    # the reactions balance the tip force: the clamp's force along y
    assert abs(arc.state.lam[1]) == pytest.approx(40.0, rel=1e-6)


def test_the_bodies_flow_continuation_reaches_the_direct_solve():
    """A fluid-carrying cantilever of bodies under a tip force, at mdot = 2 kg/s: the flow
    followed from the equilibrium at 0 (from_mass_flow=0 from that state, in 4 steps) ends
    on the equilibrium solved at 2 kg/s directly; the flow changes it (the follower forces
    of the bent pipe), so the comparison is not that of two equal starts."""
    system = bodies((0.0, 20.0, 0.0), n_bodies=2)
    still = pf.static_equilibrium(system, mass_flow=0.0)
    direct = pf.static_equilibrium(system, mass_flow=2.0)
    followed = pf.static_equilibrium(system, mass_flow=2.0, state=still.state, from_mass_flow=0.0, load_steps=4)
    assert followed.mass_flow == direct.mass_flow == 2.0
    moved = np.abs(tip(system, direct.state) - tip(system, still.state)).max()
    assert moved > 1e-6 * L
    np.testing.assert_allclose(tip(system, followed.state), tip(system, direct.state), rtol=0, atol=1e-9 * L)
    # by arc length too, from rest, the flow ramped with the loads
    arc = pf.static_equilibrium(system, mass_flow=2.0, from_mass_flow=0.0, path="arclength")
    np.testing.assert_allclose(tip(system, arc.state), tip(system, direct.state), rtol=0, atol=1e-8 * L)


def test_the_coupled_arclength_path_ends_where_load_stepping_does(monkeypatch):
    """A cantilever of 8 pipe elements clamped to a hub body, 50 N at its tip (a load
    stepping needs halved steps: the full step diverges): the arc-length path on the
    coupled system object ends on the load stepping's equilibrium, parts and multipliers."""
    system, tip_node = coupled(force=50.0)
    stepped = pf.static_equilibrium(system, path="load")
    calls = counted(monkeypatch)
    arc = pf.static_equilibrium(system, path="arclength")
    assert len(calls) >= 2
    y = stepped.state.q[6 * tip_node + 1]
    assert 0.3 < y < 1.0
    np.testing.assert_allclose(np.asarray(arc.state.q), np.asarray(stepped.state.q), rtol=0, atol=1e-8)
    np.testing.assert_allclose(arc.body_state.eta, stepped.body_state.eta, rtol=0, atol=1e-9)
    np.testing.assert_allclose(arc.coupling_forces, stepped.coupling_forces, rtol=1e-6, atol=1e-6 * 50.0)
    assert arc.limit_points == () and arc.body_state is not None


def test_the_coupled_flow_continuation_reaches_the_direct_solve():
    """The coupled cantilever at 10 kg/s: followed from its equilibrium without flow
    (from_mass_flow=0 from that result) it ends on the direct solve at 10 kg/s; with
    path="load" and "auto" alike."""
    system, tip_node = coupled()
    still = pf.static_equilibrium(system, mass_flow=0.0)
    direct = pf.static_equilibrium(system, mass_flow=10.0)
    assert abs(direct.state.q[6 * tip_node + 1] - still.state.q[6 * tip_node + 1]) > 1e-4
    for path in ("load", "auto"):
        followed = pf.static_equilibrium(system, mass_flow=10.0, state=still, from_mass_flow=0.0, load_steps=3,
                                         path=path)
        np.testing.assert_allclose(np.asarray(followed.state.q), np.asarray(direct.state.q), rtol=0, atol=1e-9)
        np.testing.assert_allclose(followed.coupling_forces, direct.coupling_forces, rtol=1e-6, atol=1e-8)
    assert pf.coupled.static_equilibrium(system, mass_flow=10.0, state=still, from_mass_flow=0.0).mass_flow == 10.0


def test_the_path_tangent_is_the_core_one_on_every_system():
    """_core.static_arc_tangent: the unit tangent of the path, K v + dR/dt s = 0 with
    |W v|^2 + psi2 s^2 = 1 and t increasing from rest, on an element model (checked against
    the element assembler's K and a central difference of R) and on the bodies' system
    (constraints: s > 0 and unit length)."""
    from pipeflex.analysis._assembly import residual_and_tangent

    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    nodes = b.add_line(n0, (1.0, 0.0, 0.0), 6, ARM)
    b.add_load(nodes[-1], force=(0.0, 2.0, 0.0))
    b.clamp(n0)
    model = b.build()
    state = model.initial_state()
    w2 = arclength.weights(model, model.length_scale)
    assert set(np.unique(w2)) == {1.0, 1.0 / model.length_scale**2}
    out = _core.static_arc_tangent(model._system(state), (0.0, 0.0, 0.0, 1.0), 0.0, w2, 1.0,
                                   np.zeros(model.n_dofs), 1.0)
    v, s = np.asarray(out[0]), out[1]
    assert s > 0 and np.dot(w2 * v, v) + s * s == pytest.approx(1.0, rel=1e-12)
    _, K = residual_and_tangent(model, state, model.load_state(gravity_factor=0.0), load_factor=0.0)
    rp, _ = residual_and_tangent(model, state, model.load_state(), load_factor=1.0, matrix=False)
    r0, _ = residual_and_tangent(model, state, model.load_state(gravity_factor=0.0), load_factor=0.0, matrix=False)
    assert np.abs(K @ v + (rp - r0) * s).max() <= 1e-9 * np.abs(rp - r0).max()
    system = bodies()
    w2b = arclength.weights(system, system.length_scale)
    assert len(w2b) == system.n_coordinates
    v, s = _core.static_arc_tangent(system._system(None), (0.0, 0.0, 0.0, 1.0), 0.0, w2b, 1.0,
                                    np.zeros(system.n_coordinates), 1.0)
    assert s > 0 and np.dot(w2b * v, v) + s * s == pytest.approx(1.0, rel=1e-12)
    with pytest.raises(ValueError, match="entries"):
        _core.static_arc_tangent(system._system(None), (0.0, 0.0, 0.0, 1.0), 0.0, w2b[:-1], 1.0,
                                 np.zeros(system.n_coordinates), 1.0)


def test_one_result_type_and_the_aliases():
    """Every formulation returns pf.StaticResult: a coupled one with its parts, the
    aliases MultibodyStatic and CoupledStatic name it; a coupled system refuses another
    formulation's result as its start."""
    system, _ = coupled()
    res = pf.static_equilibrium(system)
    assert type(res) is pf.StaticResult and res.coupling_forces is not None
    assert pf.multibody.MultibodyStatic is pf.StaticResult is pf.coupled.CoupledStatic
    mb = pf.static_equilibrium(bodies())
    assert type(mb) is pf.StaticResult and mb.body_state is None
    with pytest.raises(TypeError, match="CoupledStatic"):
        pf.static_equilibrium(system, state=mb)


def arch(load, *, on_hub, n=16, R=5.0, half=0.2):
    """tests/test_arclength.py's shallow arch (span 2 m, rise 0.1 m, EI = 1 N m^2, EA = 1e3 N,
    pinned at both ends, in its plane) under a downward crown load [N]; on_hub: its left end
    pinned (a spherical coupling) to the end of a stiff hub body clamped to the ground
    instead of to the ground. (model or coupled system, crown node)."""
    b = pf.ModelBuilder()
    x0 = -R * np.sin(half)
    n0 = b.add_node((x0, 0.0, 0.0))
    nodes = b.add_arc(n0, center=(0.0, -R * np.cos(half), 0.0), angle=-2 * half, normal=(0, 0, 1),
                      n_elements=n, section=pf.PipeSection(EI=1.0, pipe_mass=1.0, EA=1e3))
    for k in nodes[1:] if on_hub else nodes:
        b.fix(k, ("uz", "rx", "ry"))
    if on_hub:
        b.fix(nodes[0], ("rx", "ry"))  # its position: the coupling's
    for k in (nodes[-1],) if on_hub else (nodes[0], nodes[-1]):
        b.fix(k, ("ux", "uy"))
    b.add_load(nodes[n // 2], force=(0.0, -load, 0.0))
    model = b.build()
    if not on_hub:
        return model, nodes[n // 2]
    mb = MultibodyBuilder()
    hub = mb.add_body(flexible_body(length=0.2, n_elements=2, section=pf.PipeSection(
        EI=1e5, pipe_mass=1.0, rotary_inertia=(1e-2, 0.0, 0.0))), position=(x0 - 0.1, 0.0, 0.0))
    mb.fix(hub, "start")
    system = pf.CoupledSystem(model, mb.build())
    system.spherical(n0, hub, "end")
    return system, nodes[n // 2]


def test_a_coupled_arch_snaps_through_its_limit_points():
    """The arch pinned to a stiff hub body under 3 N at its crown (past its limit load):
    load stepping fails at the limit point (0.923 N, the arch's on rigid pins to 1e-6: the
    stiff hub moves its pin by about 1e-8 m), and path="auto" continues by arc length on the coupled system object
    through both limit points to the snapped, inverted equilibrium; path="arclength" from
    the start reaches the same state and limit points."""
    P = 3.0
    system, crown = arch(P, on_hub=True)
    with pytest.raises(pf.ConvergenceError) as info:
        pf.static_equilibrium(system, path="load", load_steps=100)
    alone = pf.static_equilibrium(arch(P, on_hub=False)[0], load_steps=100)
    res = pf.static_equilibrium(system, load_steps=100)
    assert len(res.limit_points) == 2 == len(alone.limit_points)
    assert info.value.load_factor == pytest.approx(res.limit_points[0], rel=2e-3)
    assert res.limit_points[0] * P == pytest.approx(alone.limit_points[0] * P, rel=1e-6)
    assert 0 < res.limit_points[1] < res.limit_points[0]
    assert res.state.q[6 * crown + 1] < -0.1 and res.body_state is not None
    whole = pf.static_equilibrium(system, path="arclength", load_steps=10)
    np.testing.assert_allclose(np.asarray(whole.state.q), np.asarray(res.state.q), rtol=0, atol=1e-9)
    assert whole.limit_points == pytest.approx(res.limit_points, rel=1e-7)
