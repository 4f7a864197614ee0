"""Periodic orbits by shooting, Floquet multipliers and continuation from the Hopf point
(the flutter limit cycle of Meijaard & Hakvoort's Fig. 3 cantilever, seed 000)."""
import numpy as np
import pytest

import pipeflex as pf
from pipeflex import _core
from pipeflex.analysis.periodic import continue_orbits, orbit_guess, periodic_orbit
from pipeflex.seeds.seed000.limit_cycle import limit_cycle_model
from pipeflex.signals import cycle_metrics


def cantilever(n_elements, *, planar, tip_force=1.5, EA=1e5):
    """Fig. 3's cantilever (L = 1 m, EI = 10 N m^2, 8 + 2 kg/m, 30 kg/s, tip force along y);
    ``planar`` fixes the out-of-plane coordinates (uz, rx, ry) of every node."""
    return limit_cycle_model(n_elements=n_elements, tip_force=tip_force, planar=planar, EA=EA)


@pytest.fixture(scope="module")
def planar4():
    return cantilever(4, planar=True)


@pytest.fixture(scope="module")
def settled(planar4):
    """A transient of the planar 4-element cantilever that has settled on its cycle."""
    m, tip = planar4
    st = pf.static_equilibrium(m, mass_flow=0.0).state
    r = pf.simulate(m, 5.0, state=st, step=5e-4, n_outputs=5001, progress=False, integrator="generalized_alpha")
    amp, period, _ = cycle_metrics(r.t, r.x[:, tip, 1], after=3.0)
    return r, amp, period


def flow_map_start(m, *, newton_tol, seed, z_scale):
    """Options (tight Newton), the static state and a random start (z0, v0) of a flow map."""
    opt = _core.TransientOptions()
    opt.newton_tol, opt.max_newton = newton_tol, 30
    base = pf.static_equilibrium(m).state.to_core(m)
    rng = np.random.default_rng(seed)
    return opt, base, rng, z_scale * rng.standard_normal(m.n_dofs), 1e-2 * rng.standard_normal(m.n_dofs)


def test_monodromy_equals_finite_differences(planar4):
    """The tangent-linear generalised-alpha map (exact iteration matrix per step) against
    central differences of the flow map; the differences' own error is ~1e-9 here."""
    m, _ = planar4
    n = m.n_dofs
    opt, base, rng, z0, v0 = flow_map_start(m, newton_tol=1e-14, seed=3, z_scale=1e-4)

    def flow(z, v, sens=False):
        return _core.flow_map(m.system(base.copy()), m.mass_flow, z, v, 0.1, 100, sens, opt)

    Phi = flow(z0, v0, True)["monodromy"]
    fd = np.zeros_like(Phi)
    eps = 1e-6
    for j in range(2 * n):
        d = np.zeros(2 * n)
        d[j] = eps
        hi, lo = flow(z0 + d[:n], v0 + d[n:]), flow(z0 - d[:n], v0 - d[n:])
        fd[:, j] = np.r_[hi["z"][-1] - lo["z"][-1], hi["v"] - lo["v"]] / (2 * eps)
    assert np.abs(Phi - fd).max() <= 1e-6 * np.abs(Phi).max()


def test_stored_tangent_applies_the_monodromy(planar4):
    """The flow map's stored tangent-linear map (the matrix-free form the shooting's
    multipliers come from) applied to any directions equals the monodromy times them."""
    m, _ = planar4
    n = m.n_dofs
    opt, base, rng, z0, v0 = flow_map_start(m, newton_tol=1e-12, seed=5, z_scale=1e-3)
    out = _core.flow_map(m.system(base.copy()), m.mass_flow, z0, v0, 0.2, 200, True, opt)
    D = rng.standard_normal((2 * n, 3))
    Phi = out["monodromy"]
    assert out["tangent"].dimension == 2 * n
    assert np.abs(out["tangent"].apply(D) - Phi @ D).max() <= 1e-10 * np.abs(Phi @ D).max()
    lean = _core.flow_map(m.system(base.copy()), m.mass_flow, z0, v0, 0.2, 200, True, opt, monodromy=False)
    # exact: the same integration; monodromy=False only skips applying the tangent map
    assert "monodromy" not in lean and np.array_equal(lean["v"], out["v"])
    with pytest.raises(ValueError, match="rows"):
        out["tangent"].apply(np.zeros((n, 1)))


def test_orbit_without_multipliers_is_the_same_orbit(planar4, settled):
    """multipliers=False skips the monodromy at the solution: the same orbit, no
    multipliers and no stability verdict."""
    m, tip = planar4
    r, amp, period = settled
    steps = int(round(period / 5e-4))
    full = periodic_orbit(m, period=period, state=r.final_state, steps=steps)
    lean = periodic_orbit(m, period=period, state=r.final_state, steps=steps, multipliers=False)
    assert lean.multipliers.size == 0 and lean.trivial == -1 and lean.stable is None
    assert lean.residual <= 1e-8
    assert lean.amplitude[tip, 1] == pytest.approx(full.amplitude[tip, 1], rel=1e-6)
    assert lean.period == pytest.approx(full.period, rel=1e-7)


def test_orbit_equals_the_settled_transient(planar4, settled):
    """Shooting from the transient's last state converges to the cycle the transient
    reached: amplitude and period to 1e-3 (the same model, step and method)."""
    m, tip = planar4
    r, amp, period = settled
    o = periodic_orbit(m, period=period, state=r.final_state, steps=int(round(period / 5e-4)))
    assert o.residual <= 1e-8
    assert o.amplitude[tip, 1] == pytest.approx(amp, rel=1e-3)
    assert o.period == pytest.approx(period, rel=1e-3)
    # a stable cycle: the trivial multiplier is 1, all others inside the unit circle
    assert abs(o.multipliers[o.trivial] - 1.0) <= 1e-6
    assert o.stable and np.delete(np.abs(o.multipliers), o.trivial).max() < 1.0


def test_coarse_transient_guess_leads_to_the_fine_orbit(planar4, settled):
    """orbit_guess with 8 times the step stops by itself once two cycles agree to 1e-3;
    its coarse cycle differs from the fine one by O(h^2) (here 1e-3 .. 1e-2), and shooting
    from it with the fine step lands on the settled fine transient's cycle to 1e-3."""
    m, tip = planar4
    r, amp, period = settled
    st = pf.static_equilibrium(m, mass_flow=0.0).state
    g = orbit_guess(m, node=tip, step=8 * 5e-4, state=st)
    assert g.settled and g.time < 10.0
    assert g.amplitude == pytest.approx(amp, rel=3e-2)
    assert g.period == pytest.approx(period, rel=3e-2)
    assert g.amplitude != pytest.approx(amp, rel=1e-4)  # a coarse guess, not the fine cycle
    o = periodic_orbit(m, period=g.period, state=g.state, steps=int(round(g.period / 5e-4)), multipliers=False)
    assert o.residual <= 1e-8
    assert o.amplitude[tip, 1] == pytest.approx(amp, rel=1e-3)
    assert o.period == pytest.approx(period, rel=1e-3)


def test_orbit_guess_without_oscillation_and_bad_input(planar4):
    """A growing oscillation stopped by t_max is not settled; below the flutter flow the
    start's oscillation dies out, and at rest in equilibrium there is none: errors."""
    m, tip = planar4
    st = pf.static_equilibrium(m, mass_flow=0.0).state
    g = orbit_guess(m, node=tip, step=4e-3, state=st, t_max=1.5)
    assert not g.settled and g.time == pytest.approx(1.5)
    for mdot, start in ((10.0, st), (0.0, st)):
        with pytest.raises(pf.ConvergenceError, match="fewer than two cycles"):
            orbit_guess(m, node=tip, step=4e-3, state=start, mass_flow=mdot, t_max=3.0)
    with pytest.raises(ValueError, match="node"):
        orbit_guess(m, node=m.n_nodes, step=4e-3)
    with pytest.raises(ValueError, match="component"):
        orbit_guess(m, node=tip, step=4e-3, component=3)
    with pytest.raises(ValueError, match="step"):
        orbit_guess(m, node=tip, step=0.0)


def test_planar_cycle_of_the_3d_pipe_is_unstable_out_of_plane():
    """In 3D the planar flutter cycle of Fig. 3 (3 elements here; 2 are too few) has a multiplier outside
    the unit circle whose eigenvector is out of plane (uz, rx, ry): the transient only
    reaches it because it starts exactly planar."""
    m, tip = cantilever(3, planar=False)
    st = pf.static_equilibrium(m, mass_flow=0.0).state
    r = pf.simulate(m, 4.0, state=st, step=5e-4, n_outputs=4001, progress=False, integrator="generalized_alpha")
    amp, period, _ = cycle_metrics(r.t, r.x[:, tip, 1], after=2.5)
    o = periodic_orbit(m, period=period, state=r.final_state, steps=int(round(period / 5e-4)))
    assert not o.stable
    opt = _core.TransientOptions()
    opt.newton_tol, opt.max_newton = 1e-12, 30
    out = _core.flow_map(m.system(o.base.to_core(m)), m.mass_flow, o.z0, o.v0, o.period,
                                           o.steps, True, opt)
    w, V = np.linalg.eig(out["monodromy"])
    k = int(np.argmax(np.abs(w)))
    assert abs(w[k]) > 1.01
    n = m.n_dofs
    comps = np.array([c for _, c in m.dof_labels])
    in_plane = np.isin(comps, ("ux", "uy", "rz"))
    vec = np.abs(V[:n, k]) + np.abs(V[n:, k])
    assert vec[in_plane].max() <= 1e-9 * vec.max()


def test_branch_from_the_hopf_point_is_supercritical(planar4):
    """Near the Hopf point the amplitude grows like sqrt(mdot - mdot_c) (fitted exponent
    0.5 +- 0.05) and the period tends to 2 pi / omega_c of critical_mass_flow: extrapolated
    to zero amplitude (the period grows with the amplitude squared) within 1e-4, the
    generalised-alpha period error (omega h)^2 / 12 at 256 steps per period being 5e-5."""
    m, tip = planar4
    c = pf.critical_mass_flow(m)
    assert c.kind == "flutter"
    br = continue_orbits(m, start=c, mass_flow_end=25.2, amplitude=1e-2, steps=256, max_points=8)
    d = br.mass_flow - c.mass_flow
    a = br.amplitude[:, tip, 1]
    assert np.all(d > 0) and np.all(np.diff(a) > 0) and br.stable.all() and len(br.folds) == 0
    exponent = np.polyfit(np.log(d[:5]), np.log(a[:5]), 1)[0]
    assert exponent == pytest.approx(0.5, abs=0.05)
    T0 = np.polyval(np.polyfit(a[:3] ** 2, br.period[:3], 1), 0.0)
    assert T0 == pytest.approx(2 * np.pi / c.frequency, rel=1e-4)


def test_bad_input(planar4):
    m, _ = planar4
    with pytest.raises(ValueError, match="period"):
        periodic_orbit(m, period=-1.0)
    with pytest.raises(ValueError, match="steps"):
        periodic_orbit(m, period=0.4, steps=0)
    with pytest.raises(ValueError, match="flutter"):
        continue_orbits(m, start=None, mass_flow_end=30.0)


def test_continued_orbit_at_30_equals_the_fig3_transient():
    """Seed 000, Fig. 3 (mdot = 30 kg/s, tip force 1.5 N), 4 elements, EA = 1e5 N: the orbit
    continued from the Hopf point and solved at exactly 30 kg/s has the amplitude and
    period of the long transient (the project's own values for the same model) to 1e-3;
    and with the continuation's planar stability, every orbit is stable in the plane."""
    from pipeflex.seeds.seed000.bifurcation import EA, bifurcation_diagram
    from pipeflex.seeds.seed000.limit_cycle import simulate_limit_cycle

    d = bifurcation_diagram(4, mass_flow_end=30.2, check_3d=False)
    lc = simulate_limit_cycle(4, EA=EA, progress=False)
    assert d.at_30.amplitude[d.tip, 1] == pytest.approx(lc.amplitude, rel=1e-3)
    assert d.at_30.period == pytest.approx(lc.period, rel=1e-3)
    assert d.branch.stable.all()
