"""Flow maps, periodic orbits and their continuation for floating-frame bodies and coupled
systems: the flow map re-bases the frames every step and maps its end back to the start
chart with its exact tangent-linear map (checked against central differences of the flow
map itself at rotations of 0.3 rad from the chart's frames), a spin against the analytic
rotation, seed 004's FFRF cantilever's flutter cycle continued from its Hopf point, and
the shooting from a guess on bodies."""
import numpy as np
import pytest

import pipeflex as pf
from pipeflex import _core
from pipeflex.multibody import MultibodyBuilder, flexible_body
from pipeflex.analysis.constrained import from_core
from pipeflex.rotation import rotation_exp, rotation_log, skew
from scipy.linalg import null_space

from conftest import FAST


def _options(newton_tol=1e-14):
    opt = _core.TransientOptions()
    opt.newton_tol, opt.max_newton = newton_tol, 30
    return opt


def _turned(state, angles):
    """The state with each body's frame turned back by exp(-angles[j]~) and shifted: a chart
    whose coordinates of ``state`` are rotations of |angles[j]| rad."""
    base = state.copy()
    for j, w in enumerate(angles):
        base.R[j] = rotation_exp(-np.asarray(w, float)) @ base.R[j]
        base.r[j] -= 0.01 * np.asarray(w, float)
    return base


def _left_jacobian(phi):
    """T(phi) = I + (1 - cos t) / t^2 phi~ + (t - sin t) / t^3 phi~^2 (t = |phi|): the
    spatial rotation d theta of a change d phi of the rotation vector."""
    t = np.linalg.norm(phi)
    W = skew(phi)
    return np.eye(3) + (1 - np.cos(t)) / t ** 2 * W + (t - np.sin(t)) / t ** 3 * W @ W


def _on_constraints(core_system, mdot, z0, rotations, rng, count):
    """``count`` random directions (dz0; dv0) that keep the joints (C_q dtheta = 0 and
    C_q dv = 0 at the start, C_q of the core's linearisation; dz0 = T(z0)^-1 dtheta per
    frame). Off the joints the first step's projection makes the flow map so curved that
    central differences need steps of 1e-8."""
    _, _, _, Cq = from_core(_core.linear_matrices(core_system, mdot))
    N = null_space(Cq.toarray())
    D = np.vstack([N @ rng.standard_normal((N.shape[1], count)), N @ rng.standard_normal((N.shape[1], count))])
    for c in rotations:
        D[c:c + 3] = np.linalg.solve(_left_jacobian(z0[c:c + 3]), D[c:c + 3])
    return D


def _fd_check(flow, z0, v0, D, *, eps=1e-6):
    """max |tangent - central differences| / max |central differences| over the
    directions D (columns), and the flow map with its tangent."""
    n = len(z0)
    out = flow(z0, v0, True)
    directions = D.shape[1]
    got = out["tangent"].apply(D)
    fd = np.zeros_like(got)
    for j in range(directions):
        hi = flow(z0 + eps * D[:n, j], v0 + eps * D[n:, j], False)
        lo = flow(z0 - eps * D[:n, j], v0 - eps * D[n:, j], False)
        fd[:, j] = np.r_[hi["z"][-1] - lo["z"][-1], hi["v"] - lo["v"]] / (2 * eps)
    return np.abs(got - fd).max() / np.abs(fd).max(), out


def test_body_flow_map_tangent_equals_central_differences_at_large_rotations():
    """2-body FFRF cantilever (tip force, flow 20 kg/s) in a chart whose frames are turned
    0.3 rad from the state's: the transported tangent (dexp per step, the start's and
    end's chart maps, the joints' d(C_q a0)/dz) against central differences of the flow
    map. A flow map in one fixed chart missed by 1.5e-5 here."""
    system = pf.scenes.ffrf_cantilever_pipe(n_bodies=2, elements_per_body=4, tip_force=1.5)
    mdot = 20.0
    eq = pf.static_equilibrium(system, mass_flow=mdot).state
    rng = np.random.default_rng(3)
    angles = 0.3 * np.array([[0.6, -0.8, 0.0], [0.0, 0.6, 0.8]])
    base = _turned(eq, angles)
    n = system.n_coordinates
    z0 = np.zeros(n)
    for j, o in enumerate(system.offsets[:-1]):
        z0[o:o + 3] = eq.r[j] - base.r[j]
        z0[o + 3:o + 6] = rotation_log(eq.R[j] @ base.R[j].T)
    v0 = 0.05 * rng.standard_normal(n)
    assert min(np.linalg.norm(z0[o + 3:o + 6]) for o in system.offsets[:-1]) > 0.29

    def flow(z, v, sens):
        return _core.flow_map(system.system(base), mdot, z, v, 0.03, 30, sens, _options(1e-13))

    rotations = [o + 3 for o in system.offsets[:-1]]
    D = _on_constraints(system.system(eq), mdot, z0, rotations, rng, 4)
    err, out = _fd_check(flow, z0, v0, D)
    # measured 1.6e-8; without the joints' d(C_q a0)/dz at the start 7e-7, without the
    # frames' transport 6e-2
    assert err <= 1e-7
    # the end is in the start chart: the frames still ~0.3 rad from the base's
    assert np.linalg.norm(out["z"][-1][3:6]) > 0.25
    # the monodromy is the tangent applied to the identity
    D = rng.standard_normal((2 * n, 2))
    assert np.abs(out["monodromy"] @ D - out["tangent"].apply(D)).max() <= 1e-10 * np.abs(out["monodromy"] @ D).max()


def test_body_flow_map_from_the_state_is_the_integrator():
    """From z0 = 0 in the state's own chart the flow map re-bases as integrate does: the
    same steps, so the same end state (to Newton's round-off)."""
    system = pf.scenes.ffrf_cantilever_pipe(n_bodies=2, elements_per_body=4, tip_force=1.5)
    st = pf.static_equilibrium(system, mass_flow=20.0).state.copy()
    st.v[:] = 0.05 * np.random.default_rng(2).standard_normal(len(st.v))
    n = system.n_coordinates
    out = _core.flow_map(system.system(st), 20.0, np.zeros(n), st.v.copy(), 0.02, 20, False, _options(1e-12))
    run = pf.multibody.simulate(system, 0.02, step=1e-3, state=st, mass_flow=20.0, n_outputs=3, rho_inf=0.9,
                                newton_tol=1e-12)
    end = run.state(-1)
    for j, o in enumerate(system.offsets[:-1]):
        assert np.abs(out["z"][-1][o:o + 3] - (end.r[j] - st.r[j])).max() <= 1e-9
        assert np.abs(out["z"][-1][o + 3:o + 6] - rotation_log(end.R[j] @ st.R[j].T)).max() <= 1e-9
    assert np.abs(out["v"] - end.v).max() <= 1e-7 * max(1.0, np.abs(end.v).max())


def test_spin_matches_the_analytic_rotation():
    """A straight body on a ball joint at its centre spinning about its own axis (a
    principal axis, every node on it: no centrifugal load) turns at a constant rate: R(T) = exp(T omega~) R0. The flow
    map's end (its rotation's log relative to the start frame) is T omega beyond pi/2,
    where a fixed chart's coordinates would not move at the spatial rate."""
    section = pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=0.0, EA=1e4, GJ=8.0, rotary_inertia=(6e-3, 0.0, 0.0))
    body = flexible_body(length=1.0, n_elements=4, section=section)
    b = MultibodyBuilder()
    b.spherical(b.add_body(body, position=(0.5, 0.0, 0.0)), "center")  # a ball joint at its frame
    system = b.build()
    st = system.initial_state()
    axis = st.R[0][:, 0]  # the body's axis
    omega = 6.0
    n = system.n_coordinates
    v0 = np.zeros(n)
    v0[3:6] = omega * axis
    T = 0.35  # 2.1 rad
    out = _core.flow_map(system.system(st), 0.0, np.zeros(n), v0, T, 70, True, _options(1e-13))
    assert np.abs(out["z"][-1][3:6] - T * omega * axis).max() <= 1e-9
    assert np.abs(out["z"][-1][:3]).max() <= 1e-12 and np.abs(out["v"] - v0).max() <= 1e-9
    # every step on the way too
    t = np.linspace(0.0, T, 71)
    assert np.abs(out["z"][:, 3:6] - np.outer(t * omega, axis)).max() <= 1e-9


def _pipe_on_body(mdot):
    """An element pipe (0.5 m, 2 elements) clamped to the end of one FFRF body (0.5 m)
    fixed at the origin: seed 004's cantilever half bodies, half elements, under tip force
    and flow (both parts carry the fluid)."""
    bodies = pf.scenes.ffrf_cantilever_pipe(n_bodies=1, elements_per_body=4, length=0.5, mass_flow=mdot)
    b = pf.ModelBuilder()
    n0 = b.add_node((0.5, 0.0, 0.0))
    nodes = b.add_line(n0, (1.0, 0.0, 0.0), 2, bodies.bodies[0].section)
    b.add_load(nodes[-1], force=(0.0, 0.0, 1.5))
    system = pf.CoupledSystem(b.build(mass_flow=mdot, floating=True), bodies)
    system.rigid(n0, 0, "end")
    return system


def test_coupled_flow_map_tangent_equals_central_differences():
    """An element pipe (its fixed chart) clamped to an FFRF body (its frame re-based every
    step) under flow, in a chart whose body frame is turned 0.3 rad: the tangent of the
    coupled flow map against central differences."""
    mdot = 20.0
    system = _pipe_on_body(mdot)
    static = pf.static_equilibrium(system, mass_flow=mdot)
    base_bodies = _turned(static.body_state, [[0.0, 0.24, 0.18]])
    rng = np.random.default_rng(5)
    n1, n = system.model.n_dofs, system.n_coordinates
    z0 = np.zeros(n)
    z0[n1:n1 + 3] = static.body_state.r[0] - base_bodies.r[0]
    z0[n1 + 3:n1 + 6] = rotation_log(static.body_state.R[0] @ base_bodies.R[0].T)
    v0 = np.zeros(n)

    def core(bodies):
        return system.system(static.state.to_core(system.model), bodies, static.coupling_forces, mass_flow=mdot)

    def flow(z, v, sens):
        return _core.flow_map(core(base_bodies), mdot, z, v, 0.03, 30, sens, _options(1e-13))

    D = _on_constraints(core(static.body_state), mdot, z0, [n1 + 3], rng, 4)
    D[n:] *= 10.0  # rates: a visible motion over the run
    err, out = _fd_check(flow, z0, v0, D)
    assert err <= 1e-7  # measured 3.5e-9
    assert np.linalg.norm(out["z"][-1][n1 + 3:n1 + 6]) > 0.25


@pytest.fixture(scope="module")
def ffrf_branches():
    from pipeflex.seeds.seed004.studies import ffrf_orbit_branch

    points = 8 if FAST else 12
    return {nb: ffrf_orbit_branch(n_bodies=nb, max_points=points, reference_elements=16 if nb == 2 else None)
            for nb in (2, 4)}


def test_ffrf_cycle_starts_at_the_hopf_point(ffrf_branches):
    """The 2-body FFRF cantilever's branch from pf.critical_mass_flow's Hopf point:
    amplitude^2 linear in the flow excess near it (a supercritical Hopf bifurcation: the
    amplitude vanishes there), the period -> 2 pi / omega_c (to the integrator's period
    error at 128 steps, ~2e-4), the multiplier of the shift along the orbit 1."""
    d = ffrf_branches[2]
    b = d.branch
    mc, wc = b.hopf
    amp = d.tip_amplitude
    assert np.all(b.mass_flow > mc) and np.all(np.diff(amp) > 0)
    # amplitude^2 against the flow on the first orbits: a line through the Hopf point
    fit = np.polyfit(b.mass_flow[:4], amp[:4] ** 2, 1)
    assert -fit[1] / fit[0] == pytest.approx(mc, abs=2e-3 * (b.mass_flow[3] - mc) + 1e-6 * mc)
    assert np.abs(np.polyval(fit, b.mass_flow[:4]) - amp[:4] ** 2).max() <= 0.05 * amp[3] ** 2
    # the period extrapolates to 2 pi / omega_c at the Hopf point
    T_hopf = np.polyval(np.polyfit(b.mass_flow[:3] - mc, b.period[:3], 1), 0.0)
    assert T_hopf == pytest.approx(2 * np.pi / wc, rel=1e-3)
    # multipliers were computed for every orbit: the largest non-trivial one starts at 1
    # (the Hopf point) and leaves the unit circle as the amplitude grows (out of the
    # orbit's plane, as the element model's in 3D)
    assert abs(b.max_multiplier[0] - 1.0) < 1e-3 and np.all(np.diff(b.max_multiplier) > 0)


def test_more_bodies_come_closer_to_the_element_model(ffrf_branches):
    """Over the flows all three branches cover, the 4-body branch's tip amplitude lies
    closer to the element model's (16 elements) than the 2-body one's (n bodies behave
    like 2n elements), and both Hopf points too."""
    ref = ffrf_branches[2].reference
    lo = max(ffrf_branches[nb].branch.mass_flow[0] for nb in (2, 4))
    hi = min(min(ffrf_branches[nb].branch.mass_flow[-1] for nb in (2, 4)), ref["mass_flow"][-1])
    m = ref["mass_flow"][(ref["mass_flow"] >= lo) & (ref["mass_flow"] <= hi)]
    assert len(m) >= 3
    amp_ref = np.interp(m, ref["mass_flow"], ref["amplitude"])
    gaps = [np.abs(np.interp(m, ffrf_branches[nb].branch.mass_flow, ffrf_branches[nb].tip_amplitude)
                   - amp_ref).max() for nb in (2, 4)]
    assert gaps[1] < 0.5 * gaps[0]
    hopf = [abs(ffrf_branches[nb].branch.hopf[0] - ref["hopf"][0]) for nb in (2, 4)]
    assert hopf[1] < hopf[0]


def test_shooting_from_a_guess_gives_seed_004s_cycle_of_2_bodies():
    """The user's path on bodies: pf.orbit_guess (a coarse transient) then pf.periodic_orbit
    on seed 004's cantilever of 2 FFRF bodies with its 1.5 N tip force at 15 m/s (30 kg/s):
    the tip's cycle along the force has seed 004's Fig. 4 amplitude (0.38 m, as the long
    transient of the seed 000 bifurcation notebook); the shift along the orbit has the
    multiplier 1, and the planar cycle is unstable out of its plane."""
    system = pf.scenes.ffrf_cantilever_pipe(n_bodies=2, elements_per_body=4, tip_force=1.5, mass_flow=30.0)
    tip = system.bodies[0].n_nodes + system.bodies[1].node_index("end")
    guess = pf.orbit_guess(system, node=tip, component=2, step=2e-3, t_max=20.0)
    assert guess.settled
    orbit = pf.periodic_orbit(system, period=guess.period, state=guess.state, steps=int(round(guess.period / 1e-3)))
    assert orbit.amplitude[tip, 2] == pytest.approx(0.38, abs=0.005)
    assert abs(orbit.multipliers[orbit.trivial] - 1.0) <= 1e-3 and orbit.stable is False
    # the orbit's start is a state of the bodies on the cycle: one period later it is back
    assert isinstance(orbit.start, type(guess.state)) and orbit.residual <= 1e-8
