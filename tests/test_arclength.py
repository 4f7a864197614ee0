"""Arc-length continuation of static equilibria through limit points (snap-through).

The model: a shallow circular arch of pipe elements (span 2 m, rise 0.1 m, EI = 1 N m^2,
EA = 1e3 N), pinned at both ends and kept in its plane, with a downward load P at the
crown. Its equilibrium path has a limit point (the symmetric mode's stiffness vanishes;
the antisymmetric one stays positive, checked below) at P_lim ~ 0.923 N, then unloads to
a second limit point and rises again on the snapped (inverted, stretched) branch.

Oracles, independent of the continuation:
* the limit load: the largest load at which plain load stepping (``path="load"``, warm
  started) still converges on the unsnapped branch with a positive definite tangent,
  located by bisection, i.e. the zero crossing of the smallest tangent eigenvalue along
  the load-stepping path;
* the snapped equilibrium: coarse load stepping (ten steps) happens to jump over the
  limit point onto the same remote equilibrium; it is stable (positive definite
  tangent) and satisfies the residual.
"""
import numpy as np
import pytest

import pipeflex as pf
from pipeflex.analysis._assembly import residual_and_tangent

P = 3.0  # N: past the limit load


def arch(load, *, n=16, R=5.0, half=0.2):
    b = pf.ModelBuilder()
    n0 = b.add_node((-R * np.sin(half), 0.0, 0.0))
    nodes = b.add_arc(n0, center=(0.0, -R * np.cos(half), 0.0), angle=-2 * half, normal=(0, 0, 1),
                      n_elements=n, section=pf.PipeSection(EI=1.0, pipe_mass=1.0, EA=1e3))
    for k in nodes:
        b.fix(k, ("uz", "rx", "ry"))
    for k in (nodes[0], nodes[-1]):
        b.fix(k, ("ux", "uy"))
    b.add_load(nodes[n // 2], force=(0.0, -load, 0.0))
    return b.build(), nodes[n // 2]


def tangent_eigenvalues(model, state, load_factor=1.0):
    _, K = residual_and_tangent(model, state, model.load_state(gravity_factor=load_factor),
                                load_factor=load_factor)
    K = K.toarray()
    assert np.abs(K - K.T).max() < 1e-9 * np.abs(K).max()  # dead loads: a symmetric tangent
    return np.linalg.eigvalsh(K)


@pytest.fixture(scope="module")
def limit_load():
    """P_lim [N] by bisection on load stepping (the oracle, see the module)."""
    lo, hi, state = 0.5, 1.5, None
    model, crown = arch(lo)
    state = pf.static_equilibrium(model, path="load", load_steps=10).state
    while hi - lo > 1e-9:
        mid = 0.5 * (lo + hi)
        model, _ = arch(mid)
        try:
            st = pf.static_equilibrium(model, state=state, path="load", load_steps=1, max_bisections=0,
                                       max_iterations=60).state
            below = st.q[6 * crown + 1] > 0 and tangent_eigenvalues(model, st)[0] > 0
        except pf.ConvergenceError:
            below = False
        if below:
            lo, state = mid, st
        else:
            hi = mid
    return 0.5 * (lo + hi)


def test_oracle_limit_is_a_symmetric_fold(limit_load):
    model, crown = arch(limit_load * (1 - 1e-6))
    st = pf.static_equilibrium(model, path="load", load_steps=20).state
    ev = tangent_eigenvalues(model, st)
    assert 0 < ev[0] < 1e-2 * ev[1]  # one eigenvalue vanishes, the next does not
    assert 0.85 < limit_load < 1.0


def test_load_stepping_fails_at_the_limit_point_and_arclength_passes_it(limit_load):
    model, crown = arch(P)
    with pytest.raises(pf.ConvergenceError) as info:
        pf.static_equilibrium(model, path="load", load_steps=100)
    assert not isinstance(info.value, pf.LimitPointError)
    # fails just past it: a step onto the unstable branch changes the tangent's inertia (rejected)
    assert info.value.load_factor * P == pytest.approx(limit_load, rel=2e-3)

    res = pf.static_equilibrium(model, load_steps=100)  # path="auto"
    # both limit points passed; the first is the limit load
    assert len(res.limit_points) == 2
    assert res.limit_points[0] * P == pytest.approx(limit_load, rel=1e-6)
    assert 0 < res.limit_points[1] < res.limit_points[0]
    # the snapped equilibrium: through the chord, satisfies R = 0, stable
    assert res.state.q[6 * crown + 1] < -0.1
    r, _ = residual_and_tangent(model, res.state, model.load_state(), matrix=False)
    assert np.linalg.norm(r) <= 1e-9 * model.force_scale()
    assert tangent_eigenvalues(model, res.state)[0] > 0
    # the same equilibrium as coarse load stepping's lucky jump, and as continuation from the start
    jump = pf.static_equilibrium(model, path="load", load_steps=10)
    assert jump.limit_points == ()
    assert np.allclose(res.state.q, jump.state.q, rtol=0, atol=1e-9)
    whole = pf.static_equilibrium(model, path="arclength", load_steps=10)
    assert np.allclose(res.state.q, whole.state.q, rtol=0, atol=1e-9)
    assert whole.limit_points == pytest.approx(res.limit_points, rel=1e-7)


def test_a_load_past_the_limit_within_the_budget_is_a_limit_point_error(limit_load):
    """With a budget too small to come back to the full load the continuation reports the
    limit point: its load factor, and the state there (a singular tangent)."""
    model, crown = arch(P)
    with pytest.raises(pf.LimitPointError, match=r"limit point at load factor λ = 0\.3076") as info:
        pf.static_equilibrium(model, load_steps=100, arc_steps=8)
    e = info.value
    assert isinstance(e, pf.ConvergenceError)
    assert e.load_factor * P == pytest.approx(limit_load, rel=1e-6)
    assert e.limit_points[0] == e.load_factor
    ev = tangent_eigenvalues(model, e.reached_state, e.load_factor)
    assert abs(ev[0]) < 1e-5 * ev[1]
    assert e.reached_state.q[6 * crown + 1] > 0  # not snapped yet


def cantilever():
    b = pf.ModelBuilder()
    n0 = b.add_node((0, 0, 0))
    nodes = b.add_line(n0, (1.0, 0, 0), 6, pf.PipeSection(EI=2.0, pipe_mass=1.0, EA=1e9))
    b.clamp(n0)
    b.add_load(nodes[-1], force=(0.0, 3.0, 1.0))
    return b.build(), nodes[-1]


def test_an_ordinary_problem_is_unchanged():
    model, tip = cantilever()
    load = pf.static_equilibrium(model, path="load", load_steps=4)
    auto = pf.static_equilibrium(model, load_steps=4)
    # exact: "auto" runs the load path's solves first, the same code on the same inputs
    assert np.array_equal(auto.state.q, load.state.q) and auto.iterations == load.iterations
    assert auto.limit_points == ()
    arc = pf.static_equilibrium(model, path="arclength", load_steps=4)
    assert arc.limit_points == ()
    assert np.allclose(arc.state.q, load.state.q, rtol=0, atol=1e-10)
    # a small load: beam theory P L^3 / (3 EI)
    b = pf.ModelBuilder()
    n0 = b.add_node((0, 0, 0))
    nodes = b.add_line(n0, (1.0, 0, 0), 4, pf.PipeSection(EI=2.0, pipe_mass=1.0, EA=1e9))
    b.clamp(n0)
    b.add_load(nodes[-1], force=(0.0, 1e-6, 0.0))
    st = pf.static_equilibrium(b.build(), path="arclength").state
    assert st.q[6 * nodes[-1] + 1] == pytest.approx(1e-6 / 6.0, rel=1e-6)


def test_flow_ramp_by_arclength_matches_the_ramp():
    """The flow-ramp path parameter is continued too: a cantilever pipe bent by gravity,
    the flow ramped from 0 to 2 kg/s."""
    b = pf.ModelBuilder()
    n0 = b.add_node((0, 0, 0))
    b.add_line(n0, (1.0, 0, 0), 6, pf.PipeSection(EI=5.0, pipe_mass=0.5, fluid_mass=0.3, EA=1e7))
    b.clamp(n0)
    b.set_gravity((0, 0, -9.81))
    model = b.build()
    ramp = pf.static_equilibrium(model, mass_flow=2.0, from_mass_flow=0.0, load_steps=4, path="load")
    arc = pf.static_equilibrium(model, mass_flow=2.0, from_mass_flow=0.0, load_steps=4, path="arclength")
    assert np.abs(arc.state.q - ramp.state.q).max() < 1e-9  # both converged to tol = 1e-10 (relative)
    assert arc.mass_flow == 2.0


def test_limit_points_survive_save_and_load_and_old_files_load(tmp_path):
    model, _ = arch(P)
    res = pf.static_equilibrium(model, load_steps=100)
    back = pf.StaticResult.load(res.save(tmp_path / "snap"))
    assert back.limit_points == res.limit_points
    # a file written before the field existed
    old = pf.StaticResult(res.state, res.iterations, res.residual, res.mass_flow)
    import json
    path = old.save(tmp_path / "old")
    with np.load(path) as f:
        arrays = {k: f[k] for k in f.files}
    meta = json.loads(str(arrays["__result__"][()]))
    del meta["root"]["fields"]["limit_points"]
    arrays["__result__"] = np.array(json.dumps(meta))
    np.savez(path, **arrays)
    assert pf.StaticResult.load(path).limit_points == ()


def test_bad_path_option():
    model, _ = cantilever()
    with pytest.raises(ValueError, match="path"):
        pf.static_equilibrium(model, path="riks")
    with pytest.raises(ValueError):
        pf.static_equilibrium(model, arc_steps=0)


def test_a_load_step_that_changes_the_tangents_inertia_is_rejected():
    """Along a regular path the number of negative eigenvalues of the (symmetric) tangent
    is constant, so a load step whose Newton ends with another count than it started with
    crossed a critical point, and load stepping rejects it. The start: the stable
    equilibrium just below the limit point (lambda = 0.30765625) with its displacements
    doubled, a shape past the limit (one negative eigenvalue); at lambda = 0.3 Newton
    converges from it onto a stable equilibrium (none). (Newton from the stable state
    itself just past the limit point does not converge at all: the mixed Newton of the
    statics does not wander onto the unstable branch.)"""
    from pipeflex.analysis.static import _newton

    model, crown = arch(P)
    lam0, lam1 = 0.30765625, 0.3
    st = pf.static_equilibrium(arch(P * lam0)[0], path="load", load_steps=40).state.to_core(model)
    assert tangent_eigenvalues(model, st, lam0)[0] > 0
    reference = np.zeros(len(st.q))
    reference.reshape(-1, 6)[:, :3] = np.asarray(model.positions)

    def pushed(factor):
        s = st.copy()
        s.q = reference + factor * (np.asarray(st.q) - reference)
        return s

    start = pushed(2.0)
    assert (tangent_eigenvalues(model, start, lam1) < 0).sum() == 1
    plain = start.copy()
    ok, _, _, _, _ = _newton(model, plain, 0.0, lam1, 1e-10, 25)
    assert ok and (tangent_eigenvalues(model, plain, lam1) < 0).sum() == 0
    stepped = start.copy()
    ok, _, _, why, singular = _newton(model, stepped, 0.0, lam1, 1e-10, 25, step=True)
    assert not ok and not singular
    assert "crossed a critical point (the tangent's negative eigenvalues went from 1 to 0" in why
    # the same count at both ends (from 1.5 times the displacements: 1 and 1) is accepted
    ok, _, _, why, _ = _newton(model, pushed(1.5), 0.0, lam1, 1e-10, 25, step=True)
    assert ok, why


def test_the_core_corrector_lands_on_the_path_and_the_sphere():
    """One arc-length corrector (the core's static_newton with the spherical constraint as
    its border) from a point off the path: it ends where R(q, t) = 0 and
    |W dq|^2 + psi^2 dt^2 = ds^2, with dq, dt the increment from the step's start."""
    from pipeflex import _core
    from pipeflex.analysis import arclength
    from pipeflex.analysis.static import _arc_newton, _newton

    model, _ = cantilever()
    size = 1.0
    half = model.initial_state()
    assert _newton(model, half, 0.0, 0.5, 1e-10, 25)[0]  # the equilibrium at t = 0.5
    w2 = arclength.weights(model, size)
    dq0 = np.full(model.n_dofs, 1e-3)  # a predictor off the path and off the sphere
    arc = arclength.Arc(lambda t: (0.0, t), w2, 1.0, 0.2, 0.6, dq0.copy(), 0.1)
    trial = half.copy()
    _core.add_increment(model.core, trial, dq0, "q")
    ok, it, rnorm, why, singular = _arc_newton(model, trial, arc, 1e-10, size, 25)
    assert ok and not singular and it >= 2, why
    # on the sphere (the constraint evaluated here, independently of the core's border)
    assert abs((np.dot(arc.w2 * arc.dq, arc.dq) + arc.psi2 * arc.dt**2 - arc.ds**2) / arc.ds**2) <= 1e-9
    assert arc.t == pytest.approx(0.5 + arc.dt, abs=1e-12)
    r, _ = residual_and_tangent(model, trial, model.load_state(gravity_factor=arc.t), load_factor=arc.t,
                                matrix=False)
    # the residual's round-off floor: EA = 1e9 N times the coordinates' eps
    assert np.linalg.norm(r) == pytest.approx(rnorm, abs=1e-12) and rnorm <= 1e-7 * model.force_scale()
    assert 0.5 < arc.t < 0.7  # moved along the path, forward


def fine_cantilever(n, force):
    """The peer scene's cantilever (EA = 1e5 N, EI = 10 N m^2, L = 1 m) with n elements
    under a tip force [N]."""
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    nodes = b.add_line(n0, (1.0, 0.0, 0.0), n, pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0, EA=1e5))
    b.clamp(n0)
    b.add_load(nodes[-1], force=(0.0, force, 0.0))
    return b.build()


def test_a_diverging_load_step_fails_at_once_and_is_halved():
    """The cantilever under 50 N at its tip in one step (tip rotation 70 degrees):
    Newton's third correction runs beyond 10 model sizes, which is divergence, not a far
    branch, so the step fails at once (well before max_iterations) and the load stepping
    halves it; the halved steps converge onto the same equilibrium as eight explicit load
    steps."""
    model = fine_cantilever(256, 50.0)
    with pytest.raises(pf.ConvergenceError, match="Newton diverged at iteration") as info:
        pf.static_equilibrium(model, path="load", max_bisections=0)
    assert info.value.iteration < 25
    halved = pf.static_equilibrium(model)
    stepped = pf.static_equilibrium(model, load_steps=8)
    assert np.allclose(halved.state.q, stepped.state.q, rtol=0, atol=1e-9)
    assert halved.iterations < 25


def test_newton_iterations_do_not_grow_with_the_mesh():
    """The statics' mixed Newton (stresses extrapolated along each correction for the next
    tangent, pipe_predicted_stresses): the 1.5 N tip force (0.05 m deflection) converges in
    one load step in the same few iterations on 8 to 1024 elements. With the state's own
    stresses in the tangent the first correction's O(theta^2) chord stretch gave an axial
    force growing as N^2, and the count grew from 12 at 512 elements to ~150 at 8192
    (docs/performance.md)."""
    counts = {n: pf.static_equilibrium(fine_cantilever(n, 1.5), path="load", max_bisections=0).iterations
              for n in (8, 64, 1024)}
    assert max(counts.values()) <= 5 and max(counts.values()) - min(counts.values()) <= 1, counts

