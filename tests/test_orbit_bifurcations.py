"""Orbit continuation in any parameter, the bifurcations between its orbits (fold, period
doubling, Neimark-Sacker, branch point) and branch switching: on multiplier paths whose
crossings are known, and on the flutter cycles of seed 000's cantilever (Fig. 3, EA =
1e5 N), planar and in 3D."""
import numpy as np
import pytest

import pipeflex as pf
from pipeflex.analysis import periodic
from pipeflex.analysis.periodic import _Branch, _floquet, _Parameter, _Point
from pipeflex.seeds.seed000.limit_cycle import limit_cycle_model

STEPS = 128


# ---------------------------------------------------------------------------------------
# classification on known multiplier paths (no shooting: interpolated, locate=False)

def path(values, ps):
    """A branch of orbits whose non-trivial multipliers are ``values`` (k, m), the trivial 1
    first, at the parameter values ``ps`` (scaled = physical)."""
    par = _Parameter(None, "p", None, ps[0], 1.0, 0.0)
    br = _Branch(None, par, tol=1e-8, max_iterations=10, ds=0.1, max_step=1.0, p_end=ps[-1], max_points=99,
                 locate=False)
    prev = None
    for mu, p in zip(values, ps):
        mu = np.concatenate([[1.0], np.asarray(mu, complex)])
        y = np.array([p, 1.0])
        if prev is None:
            tangent, step = np.array([0.0, 0.0, 1.0]), 0.0
        else:
            d = np.concatenate([y - prev.y, [p - prev.p]])
            step = float(np.linalg.norm(d))
            tangent = d / step
        pt = _Point(y, float(p), tangent, mu, 0, np.eye(len(mu), dtype=complex), None, None, step)
        if prev is not None and prev.tangent[-1] != 0 and np.sign(tangent[-1]) != np.sign(prev.tangent[-1]):
            br.folds.append(len(br.points) - 1)
        br.points.append(pt)
        prev = pt
    return br.bifurcations()


def test_a_real_multiplier_through_minus_one_is_a_period_doubling_at_its_root():
    bifs = path([[-0.9, 0.5], [-0.96, 0.5], [-1.04, 0.5], [-1.2, 0.5]], [0.0, 1.0, 2.0, 3.0])
    assert [b.kind for b in bifs] == ["period_doubling"]
    assert bifs[0].parameter == pytest.approx(1.5) and bifs[0].index == 1 and not bifs[0].located


def test_a_complex_pair_leaving_the_circle_is_one_neimark_sacker():
    r = [0.9, 0.95, 1.05, 1.1]
    bifs = path([[x * np.exp(1j), x * np.exp(-1j), 0.3] for x in r], [0.0, 1.0, 2.0, 3.0])
    assert [b.kind for b in bifs] == ["neimark_sacker"] and bifs[0].parameter == pytest.approx(1.5)
    assert abs(bifs[0].multiplier.imag) > 0.5


def test_plus_one_is_a_branch_point_unless_the_parameter_turns_there():
    values = [[0.9], [0.96], [1.04], [1.1]]
    assert [b.kind for b in path(values, [0.0, 1.0, 2.0, 3.0])] == ["branch_point"]
    turned = path(values, [0.0, 1.0, 1.5, 1.0])  # the parameter turns at the third orbit
    assert [b.kind for b in turned] == ["fold"]


def test_a_multiplier_one_of_a_symmetry_is_no_bifurcation():
    """Round-off puts a symmetry's multiplier 1 on either side of the circle: within
    NEUTRAL it crosses nothing."""
    wobble = 1.0 + np.array([1e-9, -1e-9, 2e-9, -1e-9])
    assert path([[w, 0.5] for w in wobble], [0.0, 1.0, 2.0, 3.0]) == ()


def test_a_crossing_that_lingers_within_neutral_is_found_where_it_changes_sign():
    """A multiplier that creeps through the band of NEUTRAL over several orbits crosses
    once, in the interval where abs(mu) - 1 changes sign."""
    creep = 1.0 + np.array([-5e-6, -2e-7, 3e-7, 6e-7, 4e-6])
    bifs = path([[c, 0.5] for c in creep], [0.0, 1.0, 2.0, 3.0, 4.0])
    assert [(b.kind, b.index) for b in bifs] == [("branch_point", 1)]
    assert bifs[0].parameter == pytest.approx(1.0 + 0.2 / 0.5)


def test_the_trivial_multiplier_is_the_flow_direction_not_the_closest_to_one():
    """Two multipliers next to 1: the one whose eigenvector is the flow is the trivial one,
    even when the other lies closer to 1."""
    rng = np.random.default_rng(3)
    V = rng.standard_normal((4, 4))
    mu = np.array([1.0 + 1e-5, 1.0 + 1e-9, 0.5, 0.2])  # the flow's (first) is farther from 1
    Phi = V @ np.diag(mu) @ np.linalg.inv(V)
    out, trivial, vectors = _floquet(Phi, V[:, 0])
    assert out[trivial] == pytest.approx(mu[0], abs=1e-10)
    assert abs(abs(vectors[:, trivial] @ V[:, 0]) / np.linalg.norm(V[:, 0]) - 1.0) < 1e-8


# ---------------------------------------------------------------------------------------
# the planar cantilever: continuation in the mass flow by name and in EI

def cantilever(EI=10.0, n_elements=4, planar=True, tip_force=1.5):
    """limit_cycle_model's cantilever with the bending stiffness EI [N m^2] in both planes
    (GJ that of EI = 10 N m^2) built anew, to check the parameter by name against it."""
    sec = pf.PipeSection(EI=EI, pipe_mass=8.0, fluid_mass=2.0, EA=1e5, rotary_inertia=(1e-3, 0.0, 0.0),
                         GJ=10.0 / 1.3)
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    nodes = b.add_line(n0, (1.0, 0.0, 0.0), n_elements, sec)
    b.clamp(n0)
    if planar:
        for k in nodes[1:]:
            b.fix(k, ("uz", "rx", "ry"))
    b.add_load(nodes[-1], force=(0.0, tip_force, 0.0))
    return b.build(mass_flow=30.0), nodes[-1]


@pytest.fixture(scope="module")
def planar():
    """The planar 4-element cantilever and the orbits of its branch from the Hopf point."""
    m, tip = limit_cycle_model(n_elements=4, EA=1e5, planar=True)
    hopf = pf.critical_mass_flow(m)
    br = pf.continue_orbits(m, start=hopf, mass_flow_end=25.3, amplitude=1e-2, steps=STEPS, max_points=6)
    return m, tip, hopf, br


def orbit_of(model, branch, k, **options):
    return pf.periodic_orbit(model, period=branch.period[k], state=branch.starts[k], mass_flow=branch.mass_flow[k],
                             steps=STEPS, **options)


def test_the_branch_keeps_every_multiplier_and_its_parameter(planar):
    m, tip, hopf, br = planar
    k = len(br.mass_flow)
    assert br.parameter_name == "mass_flow" and np.array_equal(br.parameter, br.mass_flow)
    assert br.multipliers.shape == (k, 2 * m.n_dofs) and br.trivial.shape == (k,)
    mu = br.multipliers[np.arange(k), br.trivial]
    np.testing.assert_allclose(mu, 1.0, atol=periodic.TRIVIAL_MULTIPLIER_TOL)
    others = np.abs(np.where(np.arange(2 * m.n_dofs)[None, :] == br.trivial[:, None], 0.0, br.multipliers))
    np.testing.assert_allclose(others.max(axis=1), br.max_multiplier, rtol=1e-12)
    assert br.bifurcations == () and not np.any(np.isnan(br.hopf))


def test_mass_flow_by_name_from_the_hopf_point_is_the_default_branch(planar):
    m, tip, hopf, br = planar
    named = pf.continue_orbits(m, start=hopf, parameter="mass_flow", mass_flow_end=25.3, amplitude=1e-2,
                               steps=STEPS, max_points=6)
    np.testing.assert_allclose(named.mass_flow, br.mass_flow, rtol=1e-12)
    np.testing.assert_allclose(named.period, br.period, rtol=1e-12)
    np.testing.assert_allclose(named.multipliers, br.multipliers, atol=1e-10)


def test_the_names_rebuild_the_model_they_say():
    """A point mass, a gravity component, EI (EIz with it in an isotropic section) and a
    section field, each rebuilt through the builder's description."""
    from pipeflex.analysis.periodic import _element_rebuild

    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    nodes = b.add_line(n0, (1.0, 0.0, 0.0), 3, pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0))
    b.clamp(n0)
    b.add_point_mass(nodes[-1], 0.5)
    b.set_gravity((0.0, -9.81, 0.0))
    model = b.build(mass_flow=3.0)
    rebuild, value = _element_rebuild(model, "point_mass")
    assert value == 0.5 and [m["mass"] for m in rebuild(2.0)._description["_masses"]] == [2.0]
    rebuild, value = _element_rebuild(model, "gravity")
    np.testing.assert_allclose(rebuild(2.0).gravity, [0.0, -2.0, 0.0])
    rebuild, value = _element_rebuild(model, "gravity_x")
    np.testing.assert_allclose(rebuild(1.0).gravity, [1.0, -9.81, 0.0])
    assert value == 0.0
    rebuild, value = _element_rebuild(model, "EI")
    sec = rebuild(20.0).elements[0].section
    assert value == 10.0 and (sec.EI, sec.EIz, sec.GJ) == (20.0, 20.0, 10.0 / 1.3)
    rebuild, value = _element_rebuild(model, "fluid_mass")
    assert value == 2.0 and rebuild(4.0).elements[-1].section.fluid_mass == 4.0
    assert rebuild(4.0).mass_flow == 3.0 and model.elements[0].section.fluid_mass == 2.0  # the model stays


def test_mass_flow_by_name_from_an_orbit_continues_the_hopf_branch(planar):
    """From an orbit of the Hopf branch, the branch in "mass_flow" holds orbits: each
    solved again at its flow by periodic_orbit agrees to the shooting's tolerance, and its
    amplitude lies on the Hopf branch's curve."""
    m, tip, hopf, br = planar
    start = orbit_of(m, br, 2)
    on = pf.continue_orbits(m, start=start, parameter="mass_flow", end=25.3, ds=0.02, max_points=3)
    assert np.all(np.diff(on.mass_flow) > 0) and on.mass_flow[0] > start.mass_flow
    again = orbit_of(m, on, len(on.mass_flow) - 1, tol=1e-10)
    assert again.period == pytest.approx(on.period[-1], rel=1e-7)
    np.testing.assert_allclose(again.amplitude[tip], on.amplitude[-1, tip], atol=1e-6)
    # the same curve: amplitude against mass flow interpolated along the Hopf branch
    a = np.interp(on.mass_flow[0], br.mass_flow, br.amplitude[:, tip, 1])
    assert on.amplitude[0, tip, 1] == pytest.approx(a, rel=2e-2)


def test_continuation_in_EI_by_name_and_by_a_callable_agree_with_a_model_built_anew(planar):
    """A stiffer pipe flutters later: at 25.3 kg/s the amplitude falls as EI rises. The
    orbit at the branch's last EI equals the shooting of a model built with that EI."""
    m, tip, hopf, br = planar
    start = orbit_of(m, br, len(br.mass_flow) - 1)
    by_name = pf.continue_orbits(m, start=start, parameter="EI", end=10.004, max_points=3, ds=2e-4)
    assert by_name.parameter_name == "EI" and by_name.parameter[0] > 10.0
    assert np.all(np.diff(by_name.amplitude[:, tip, 1]) < 0) and np.all(by_name.mass_flow == start.mass_flow)
    EI = by_name.parameter[-1]
    fresh, _ = cantilever(EI=EI)
    again = pf.periodic_orbit(fresh, period=by_name.period[-1], state=by_name.starts[-1], mass_flow=start.mass_flow,
                              steps=STEPS, tol=1e-10)
    assert again.period == pytest.approx(by_name.period[-1], rel=1e-7)
    np.testing.assert_allclose(again.amplitude[tip], by_name.amplitude[-1, tip], atol=1e-6)

    def rebuild(value):
        return cantilever(EI=value)[0]

    by_callable = pf.continue_orbits(m, start=start, parameter=rebuild, parameter_value=10.0, end=10.004,
                                     max_points=3, ds=2e-4)
    assert by_callable.parameter_name == "rebuild"
    np.testing.assert_allclose(by_callable.parameter, by_name.parameter, rtol=1e-9)
    np.testing.assert_allclose(by_callable.period, by_name.period, rtol=1e-9)


def test_continuation_in_a_gravity_component_holds_the_rebuilt_models_orbits(planar):
    """gravity_y from 0 (the tip force's direction): each orbit is one of the model built
    with that gravity; the parameter moves from its start value 0 toward ``end``."""
    m, tip, hopf, br = planar
    start = orbit_of(m, br, len(br.mass_flow) - 1)
    g = pf.continue_orbits(m, start=start, parameter="gravity_y", end=-0.05, max_points=2, ds=1e-2)
    assert g.parameter_name == "gravity_y" and np.all(np.diff(np.r_[0.0, g.parameter]) < 0)
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    sec = pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0, EA=1e5, rotary_inertia=(1e-3, 0.0, 0.0))
    nodes = b.add_line(n0, (1.0, 0.0, 0.0), 4, sec)
    b.clamp(n0)
    for k in nodes[1:]:
        b.fix(k, ("uz", "rx", "ry"))
    b.add_load(nodes[-1], force=(0.0, 1.5, 0.0))
    b.set_gravity((0.0, g.parameter[-1], 0.0))
    fresh = b.build(mass_flow=30.0)
    again = pf.periodic_orbit(fresh, period=g.period[-1], state=g.starts[-1], mass_flow=start.mass_flow,
                              steps=STEPS, tol=1e-10)
    assert again.period == pytest.approx(g.period[-1], rel=1e-7)
    np.testing.assert_allclose(again.amplitude[tip], g.amplitude[-1, tip], atol=1e-6)


def test_bad_parameters_are_refused_by_name(planar):
    m, tip, hopf, br = planar
    start = orbit_of(m, br, 0, multipliers=False)
    with pytest.raises(ValueError, match=r"parameter must be one of mass_flow, gravity.*EI.*'stiffness'"):
        pf.continue_orbits(m, start=start, parameter="stiffness", end=1.0)
    with pytest.raises(ValueError, match="parameter_value"):
        pf.continue_orbits(m, start=start, parameter=lambda v: m, end=1.0)
    with pytest.raises(ValueError, match="mass_flow_end is the end of a continuation in the mass flow"):
        pf.continue_orbits(m, start=start, parameter="EI", mass_flow_end=26.0)
    with pytest.raises(ValueError, match="Hopf point.*mass flow only"):
        pf.continue_orbits(m, start=hopf, parameter="EI", end=11.0)
    with pytest.raises(ValueError, match="'gravity' scales the model's gravity vector, which is zero"):
        pf.continue_orbits(m, start=start, parameter="gravity", end=1.0)
    with pytest.raises(ValueError, match="'point_mass'.*none"):
        pf.continue_orbits(m, start=start, parameter="point_mass", end=1.0)
    with pytest.raises(ValueError, match="dof layout must not change"):
        pf.continue_orbits(m, start=start, parameter=lambda v: cantilever(n_elements=5)[0], parameter_value=1.0,
                           end=2.0, max_points=1)
    with pytest.raises(ValueError, match="end"):
        pf.continue_orbits(m, start=start, parameter="EI")
    with pytest.raises(ValueError, match="one of branch.bifurcations"):
        pf.switch_branch(br, None, amplitude=1e-3)


# ---------------------------------------------------------------------------------------
# the 3D cantilever: the planar cycle's branch point and the non-planar branch

def test_the_non_planar_branch_turns_back_at_a_fold(spatial):
    """The non-planar branch leaves the branch point toward lower flows, turns at a fold
    (the mass flow's minimum along it) and returns: the fold is reported there."""
    full, tip, branch = spatial
    bp = next(b for b in branch.bifurcations if b.kind == "branch_point")
    new = pf.switch_branch(branch, bp, amplitude=2e-3, end=25.06, max_points=30)
    k = int(np.argmin(new.mass_flow))
    assert 0 < k < len(new.mass_flow) - 1 and new.mass_flow[-1] >= 25.06  # it turned and came back
    folds = [b for b in new.bifurcations if b.kind == "fold"]
    assert len(folds) == 1 and len(new.folds) == 1
    assert folds[0].parameter == pytest.approx(new.mass_flow[k], abs=2e-5) and folds[0].located
    assert folds[0].parameter <= new.mass_flow[k] + 1e-6  # the turn lies at (or below) the orbits' minimum
    assert np.all(new.amplitude[:, tip, 2] > 5e-4)


@pytest.fixture(scope="module")
def spatial(planar):
    """The planar branch continued in the 3D model from its orbit next to the Hopf point."""
    m, tip, hopf, br = planar
    full, _ = limit_cycle_model(n_elements=4, EA=1e5)
    near = pf.continue_orbits(m, start=hopf, mass_flow_end=hopf.mass_flow + 1e-4, amplitude=5e-3, steps=STEPS,
                              max_points=1)
    lifted = pf.periodic_orbit(full, period=near.period[0], state=near.starts[0], mass_flow=near.mass_flow[0],
                               steps=STEPS)
    branch = pf.continue_orbits(full, start=lifted, mass_flow_end=25.06, ds=2e-3, max_points=10)
    return full, tip, branch


def test_the_planar_cycle_has_a_branch_point_and_the_switched_branch_leaves_the_plane(spatial):
    full, tip, branch = spatial
    assert np.all(branch.amplitude[:, tip, 2] < 1e-9)  # planar orbits
    points = [b for b in branch.bifurcations if b.kind == "branch_point"]
    assert len(points) == 1
    bp = points[0]
    assert 25.055 < bp.parameter < 25.059 and bp.located and abs(bp.residual) < 1e-5
    assert abs(bp.multiplier - 1.0) < 1e-4
    # the eigenvector is out of plane (uz, rx, ry), not along the orbit
    labels = [c for _, c in full.dof_labels]
    n = full.n_dofs
    out_of_plane = np.array([c in ("uz", "rx", "ry") for c in labels] * 2)
    assert np.abs(bp.vector[~out_of_plane]).max() < 1e-6 * np.abs(bp.vector[out_of_plane]).max()
    assert bp.y.shape == (2 * n + 1,)
    new = pf.switch_branch(branch, bp, amplitude=2e-3, max_points=4)
    assert np.all(new.amplitude[:, tip, 2] > 5e-4)  # non-planar
    assert np.all(np.abs(new.mass_flow - bp.parameter) < 1e-2) and np.all(np.isnan(new.hopf))
    # each is an orbit: solved again at its flow it stays out of the plane
    k = len(new.mass_flow) - 1
    again = pf.periodic_orbit(full, period=new.period[k], state=new.starts[k], mass_flow=new.mass_flow[k],
                              steps=STEPS)
    assert again.amplitude[tip, 2] == pytest.approx(new.amplitude[k, tip, 2], rel=1e-4)


def test_at_30_the_planar_cycle_is_unstable_and_the_transient_whirls(planar):
    """Fig. 3's 3D cantilever at 30 kg/s: the planar cycle continued in 3D has a real
    multiplier about 1.19 out of plane; the transient started on it with a small
    out-of-plane push leaves the plane and settles on a whirl (tip y and z amplitudes
    equal, uncorrelated), a stable orbit by shooting."""
    from pipeflex.signals import cycle_metrics
    from pipeflex.state import State

    m, tip, hopf, br = planar
    full, _ = limit_cycle_model(n_elements=4, EA=1e5)
    guess = pf.orbit_guess(m, node=tip, step=4e-3, state=pf.static_equilibrium(m, mass_flow=0.0).state)
    planar30 = pf.periodic_orbit(m, period=guess.period, state=guess.state, steps=STEPS)
    in3d = pf.periodic_orbit(full, period=planar30.period, state=planar30.start, mass_flow=30.0, steps=STEPS)
    assert not in3d.stable
    assert 1.1 < np.abs(np.delete(in3d.multipliers, in3d.trivial)).max() < 1.3
    st = in3d.start
    v = np.array(st.v)
    v[6 * tip + 2] = 1e-3
    pushed = State(np.array(st.q), v, np.zeros_like(v), st.frames.copy(), st.ancf.copy())
    run = pf.simulate(full, 30.0, state=pushed, step=2e-3, n_outputs=6001, progress=False,
                      integrator="generalized_alpha")
    ay, T, _ = cycle_metrics(run.t, run.x[:, tip, 1], after=25.0)
    az, _, _ = cycle_metrics(run.t, run.x[:, tip, 2], after=25.0)
    assert az == pytest.approx(ay, rel=0.05) and az > 0.2
    whirl = pf.periodic_orbit(full, period=T, state=run.final_state, steps=STEPS)
    assert whirl.stable and whirl.amplitude[tip, 2] == pytest.approx(whirl.amplitude[tip, 1], rel=0.05)
