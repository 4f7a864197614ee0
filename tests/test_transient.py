"""Time integration: energy, order of accuracy, agreement of the integrators, rotations,
results on disk, bad input and failures."""
import math

import numpy as np
import pytest

import pipeflex as pf
from helpers import fluttering_cantilever


def swinging_cantilever(n=4):
    """A cantilever with rotary inertia, released with a tip velocity (no flow)."""
    b = pf.ModelBuilder()
    n0 = b.add_node((0, 0, 0))
    sec = pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0, EA=1e5, GJ=8.0, rotary_inertia=(1e-2, 1e-3, 1e-3))
    nodes = b.add_line(n0, (1, 0, 0), n, sec)
    b.clamp(n0)
    m = b.build()
    st = m.initial_state()
    st.v[6 * nodes[-1] + 1] = 0.5
    st.v[6 * nodes[-1] + 2] = 0.3
    return m, st, nodes[-1]


@pytest.mark.parametrize("integrator,opts,tol", [
    ("ida", dict(rtol=1e-9, atol=1e-11), 1e-6),
    ("generalized_alpha", dict(step=1e-3, rho_inf=1.0), 1e-4),
])
def test_energy_conserved_without_flow(integrator, opts, tol):
    m, st, tip = swinging_cantilever()
    r = pf.simulate(m, 1.0, integrator=integrator, state=st, n_outputs=21, progress=False, **opts)
    E = r.energy
    assert np.abs(E - E[0]).max() <= tol * E[0]
    assert np.all(r.fluid_work == 0.0)
    assert r.x[:, tip, 1].max() > 0.01  # it does swing


def test_generalized_alpha_is_second_order():
    """Start in the first mode shape (0.05 m/s at its largest); against a tight IDA run the
    error falls as h^2 (rates 2.00 and 2.01 measured). The vector's phase is normalised
    away (Re(1j x) of an undamped mode is round-off, no start for the run)."""
    m, st, tip = swinging_cantilever()
    e = pf.eigenvalues(pf.linearize(m), vectors=True)
    i = np.argmin(np.abs(e.values - 1j * e.frequencies.min()))
    x = e.vectors[:, i]
    v = np.real(x / x[np.argmax(np.abs(x))])  # the mode shape, whatever the vector's phase
    st.v = m.basis @ (0.05 * v / np.abs(v).max())
    ref = pf.simulate(m, 0.3, integrator="ida", state=st, rtol=1e-12, atol=1e-14, n_outputs=2, progress=False)
    errs = []
    for h in (5e-4, 2.5e-4, 1.25e-4):
        r = pf.simulate(m, 0.3, integrator="generalized_alpha", state=st, step=h, rho_inf=0.8, n_outputs=2,
                        progress=False)
        errs.append(np.abs(r.x[-1, tip] - ref.x[-1, tip]).max())
    rates = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(np.abs(rates - 2.0) < 0.25), (errs, rates)


def test_energy_balance_with_flow_and_many_turns():
    """The sprinkler spins several turns: E - E0 equals the work of the fluid forces, and
    the rotations pass far beyond pi (re-based frames)."""
    m = pf.scenes.sprinkler(EI=1000.0)
    r = pf.simulate(m, 1.5, integrator="generalized_alpha", step=5e-4, n_outputs=16, progress=False)
    assert r.angle(0)[-1] > 4 * np.pi
    assert r.stats["rebases"] > 0
    assert np.abs(r.energy_balance()).max() <= 1e-4 * r.energy[-1]


def test_save_and_load_round_trip(tmp_path):
    m, st, _ = swinging_cantilever(2)
    r = pf.simulate(m, 0.1, state=st, n_outputs=5, progress=False)
    path = tmp_path / "run.npz"
    r.save(path)
    q = pf.TransientResult.load(path)
    for k in pf.TransientResult._ARRAYS:
        assert np.array_equal(getattr(r, k), getattr(q, k))
    assert q.stats == r.stats and q.metadata == r.metadata


def test_auto_default_serves_the_undamped_sprinkler():
    """The default (integrator "auto") runs generalised-alpha at a step from the model:
    400 steps per period of the slowest rate (|lambda_1| = 7.9 1/s), divided into the
    2.5 ms output spacing: 1.25 ms, a few hundred steps where IDA takes ~1e5. Against a
    0.1 ms run the mean hinge speed over the second half agrees to 5e-5 and the final
    hinge angle to 1.4e-5 (measured; the runs differ in the undamped elastic ripple the
    fine step keeps, 1.5 % of omega pointwise, which the mean averages out)."""
    m = pf.scenes.sprinkler(EI=100.0)
    r = pf.simulate(m, 0.5, progress=False)
    assert r.metadata["integrator"] == "generalized_alpha" and r.metadata["requested"] == "auto"
    assert r.metadata["step"] == pytest.approx(1.25e-3, rel=1e-12)
    assert r.stats["steps"] < 1000
    fine = pf.simulate(m, 0.5, integrator="generalized_alpha", step=1e-4, progress=False)
    assert fine.metadata["step"] == 1e-4 and fine.metadata["requested"] == "generalized_alpha"
    late = r.t >= 0.25
    assert r.omega[late, 0, 2].mean() == pytest.approx(fine.omega[late, 0, 2].mean(), rel=2e-4)
    assert r.angle(0)[-1] == pytest.approx(fine.angle(0)[-1], rel=1e-4)


def test_auto_step_skips_rigid_modes():
    """Without flow the sprinkler's hinge is free: its double zero eigenvalue, split by
    round-off to ~1e-3 1/s, is rigid, and the step follows the first bending mode
    (13.06 rad/s); with flow the slowest rate is the spin-up's 7.9 1/s."""
    from pipeflex.analysis.transient import default_step, slowest_rate
    m = pf.scenes.sprinkler(EI=100.0)
    assert slowest_rate(m, mass_flow=0.0) == pytest.approx(13.0598, rel=1e-4)
    assert slowest_rate(m) == pytest.approx(7.9064, rel=1e-4)
    # 2 pi / (400 * 7.9064) = 1.99 ms, into the 5 ms spacing: 3 steps
    assert default_step(m, np.linspace(0.0, 1.0, 201)) == pytest.approx(5e-3 / 3, rel=1e-12)
    assert default_step(m, [0.0, 0.001, 0.5]) == pytest.approx(1e-3, rel=1e-12)


def test_auto_follows_the_options():
    """An IDA-only option selects IDA (the same run as integrator="ida", exactly: one code
    path); a step selects generalised-alpha at that step (the same run as asked for by
    name); an explicit integrator is run as asked."""
    m, st, _ = swinging_cantilever(2)
    run = lambda **kw: pf.simulate(m, 0.05, state=st, n_outputs=6, progress=False, **kw)
    ida, by_order = run(integrator="ida"), run(max_order=5)  # IDA's default
    for r in (ida, by_order):
        assert r.metadata["integrator"] == "ida" and r.metadata["step"] is None
    assert by_order.metadata["requested"] == "auto"
    for k in pf.TransientResult._ARRAYS:
        assert np.array_equal(getattr(ida, k), getattr(by_order, k), equal_nan=True)
    assert ida.stats["steps"] == by_order.stats["steps"]
    # rtol alone: generalised-alpha with its error-controlled step
    by_rtol = run(rtol=1e-4)
    assert by_rtol.metadata["integrator"] == "generalized_alpha" and by_rtol.metadata["rtol"] == 1e-4
    ga, by_step = run(integrator="generalized_alpha", step=2e-3), run(step=2e-3)
    assert by_step.metadata["integrator"] == "generalized_alpha" and by_step.metadata["step"] == 2e-3
    for k in pf.TransientResult._ARRAYS:
        assert np.array_equal(getattr(ga, k), getattr(by_step, k), equal_nan=True)
    from pipeflex.analysis.transient import choose_integrator
    assert choose_integrator("auto", {"divergence_limit": 10.0, "work": False}) == "generalized_alpha"
    assert choose_integrator("auto", {"max_order": 2}) == "ida"


@pytest.mark.parametrize("kwargs,match", [
    (dict(t_end=-1.0), "t_end must be > t_start"),
    (dict(t_end=math.nan), "t_end must be finite"),
    (dict(t_end=1.0, rtol=0.0), "rtol must be > 0"),
    (dict(t_end=1.0, integrator="ida", atol=-1e-9), "atol must be > 0"),
    (dict(t_end=1.0, rtol=1e-6, atol=-1e-9), "atol must be >= 0"),
    (dict(t_end=1.0, rtol=1e-13), "rtol must be >= 1e-12"),
    (dict(t_end=1.0, integrator="rk4"), "unknown integrator 'rk4'"),
    (dict(t_end=1.0, integrator="ida", step=1e-3), "unknown option.*'step'.*'ida'"),
    (dict(t_end=1.0, max_order=2, step=1e-3), "options of both integrators.*'max_order'.*'step'"),
    (dict(t_end=1.0, integrator="generalized_alpha", rho_inf=1.5), "rho_inf must be in"),
    (dict(t_end=1.0, times=[0.0, 0.5, 0.4]), "strictly increasing"),
    (dict(t_end=1.0, mass_flow=([0.0, 1.0], [1.0])), "mass_flow table.*equal length"),
    (dict(t_end=1.0, load_factor=pf.Sine(omega=-1.0)), "load_factor.omega must be > 0"),
])
def test_bad_input(kwargs, match):
    m, st, _ = swinging_cantilever(2)
    with pytest.raises(ValueError, match=match):
        pf.simulate(m, state=st, progress=False, **kwargs)


def test_singular_mass_matrix_is_reported():
    m = pf.scenes.cantilever_pipe(n_elements=2)  # no rotary inertia: torsion has no mass
    with pytest.raises(ValueError, match="mass matrix is singular.*rotary_inertia"):
        pf.simulate(m, 0.1, progress=False)


@pytest.mark.parametrize("integrator", ["ida", "generalized_alpha"])
def test_divergence_stops_with_time(integrator):
    """A cantilever beyond its flutter flow grows (into a limit cycle); with a divergence
    limit of 5 % of its length the run stops with a message that says when and how."""
    m, st = fluttering_cantilever()
    with pytest.raises(pf.ConvergenceError, match=r"diverged at t = [0-9.e+-]+ s .*node 2 moved"):
        pf.simulate(m, 20.0, integrator=integrator, state=st, progress=False, divergence_limit=0.05,
                    **({"step": 1e-3} if integrator == "generalized_alpha" else {}))


def test_generalized_alpha_sparse_lu_on_a_long_chain():
    """256 elements (1536 coordinates, a banded iteration matrix factorised by the sparse
    LU): Newton converges as with a dense LU (no failed or halved steps, few iterations
    and factorisations per step), halving the step changes the motion by O(h^2) only, and
    the tip follows a 4-element IDA run of the same swing to the mesh's accuracy."""
    def released(n):
        m, st, tip = swinging_cantilever(n)
        x = np.asarray(m.positions)[:, 0]
        v = np.zeros(6 * m.n_nodes)
        v[1::6], v[5::6] = 0.2 * x, 0.2  # a rigid turn about the clamp at 0.2 rad/s
        st.v = v
        return m, st, tip

    m, st, tip = released(256)
    runs = [pf.simulate(m, 0.05, integrator="generalized_alpha", state=st, step=h, rho_inf=0.8, n_outputs=6,
                        progress=False) for h in (1e-3, 5e-4)]
    for r, n_steps in zip(runs, (50, 100)):
        s = r.stats
        assert s["steps"] == n_steps and s["convergence_failures"] == 0
        assert s["newton_iterations"] <= 4 * n_steps and s["jacobians"] <= 1.2 * n_steps
    m4, st4, tip4 = released(4)
    ref = pf.simulate(m4, 0.05, integrator="ida", state=st4, rtol=1e-10, atol=1e-12, n_outputs=6, progress=False)
    swing = np.abs(ref.x[:, tip4, 1] - ref.x[0, tip4, 1]).max()
    assert swing > 5e-3  # it moves
    assert np.abs(runs[0].x[:, tip] - runs[1].x[:, tip]).max() <= 1e-3 * swing
    assert np.abs(runs[0].x[:, tip] - ref.x[:, tip4]).max() <= 1e-2 * swing


def test_ida_motion_does_not_depend_on_the_node_numbering():
    """IDA's Newton matrix is solved by a sparse LU of its velocity Schur complement on
    the tangent's pattern, not a band LU: a cantilever whose nodes are numbered out of
    order (half bandwidth 5 nodes instead of 1) moves as the one numbered along it."""
    sec = pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0, EA=1e5, GJ=8.0, rotary_inertia=(1e-2, 1e-3, 1e-3))
    runs = []
    for order in ([0, 1, 2, 3, 4, 5, 6], [0, 4, 2, 6, 1, 5, 3]):
        b = pf.ModelBuilder()
        ids = {k: b.add_node((k / 6, 0.0, 0.0)) for k in sorted(range(7), key=order.index)}
        for k in range(6):
            b.add_pipe(ids[k], ids[k + 1], sec)
        b.clamp(ids[0])
        m = b.build(mass_flow=3.0)
        st = m.initial_state()
        st.v[6 * ids[6] + 1] = 0.5
        st.v[6 * ids[6] + 2] = 0.3
        r = pf.simulate(m, 0.05, integrator="ida", state=st, rtol=1e-10, atol=1e-12, n_outputs=3, progress=False)
        runs.append(r.x[:, [ids[k] for k in range(7)]])
    assert np.abs(runs[1] - runs[0]).max() <= 1e-8
    assert np.abs(runs[0][-1] - runs[0][0]).max() > 1e-3  # it moved


def _flutter_cantilever(n_elements=4):
    """The seed-000 cantilever of the peer scene (EA = 1e5 N, 1.5 N tip force, 30 kg/s
    from t = 0) from its static state without flow."""
    sec = pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0, EA=1e5, rotary_inertia=(1e-3, 0.0, 0.0))
    b = pf.ModelBuilder()
    nodes = b.add_line(b.add_node((0.0, 0.0, 0.0)), (1.0, 0.0, 0.0), n_elements, sec)
    b.clamp(nodes[0])
    b.add_load(nodes[-1], force=(0.0, 1.5, 0.0))
    m = b.build(mass_flow=30.0)
    return m, pf.static_equilibrium(m, mass_flow=0.0).state


def test_richardson_extrapolation_raises_the_order():
    """extrapolate=True (runs at h and h/2, y_h/2 + (y_h/2 - y_h)/3): after 1 s of the
    flow-driven motion the plain runs' error falls 4x per halving (second order), the
    extrapolated 3e2-2e3x below it and by more than 16x over two halvings (order > 2;
    measured 3.6). Reference: extrapolated at h = 0.625 ms (error ~1e-8 m)."""
    m, st = _flutter_cantilever()

    def run(h, **kw):
        return pf.simulate(m, 1.0, state=st, n_outputs=2, progress=False, integrator="generalized_alpha", step=h,
                           rho_inf=1.0, newton_tol=1e-12, **kw)

    ref = run(6.25e-4, extrapolate=True)
    assert ref.metadata["extrapolated"]["steps"] == [6.25e-4, 3.125e-4]
    plain = {h: np.abs(run(h).x - ref.x).max() for h in (1e-2, 5e-3, 2.5e-3)}
    extra = {h: run(h, extrapolate=True) for h in (1e-2, 5e-3, 2.5e-3)}
    err = {h: np.abs(r.x - ref.x).max() for h, r in extra.items()}
    rot = {h: np.abs(r.R - ref.R).max() for h, r in extra.items()}
    assert 3.5 < plain[1e-2] / plain[5e-3] < 4.5 and 3.5 < plain[5e-3] / plain[2.5e-3] < 4.5
    assert all(err[h] < 1e-2 * plain[h] for h in err)
    assert err[1e-2] / err[2.5e-3] > 40.0 and rot[1e-2] / rot[2.5e-3] > 16.0
    R = extra[5e-3].R
    assert np.allclose(np.einsum("...ji,...jk->...ik", R, R), np.eye(3), atol=1e-12)
    assert extra[5e-3].stats["steps"] == 200 + 400


def test_numerical_damping_lets_one_newton_correction_converge():
    """The user guide's fast setting (rho_inf=0.6, newton_tol=1e-6): on the 8-element flutter
    cantilever at 1 ms the unresolved stiff modes ring undamped at rho_inf=1 and Newton needs
    two corrections per step (measured 2.02), damped one (1.09), while the slow motion's
    error hardly grows (3.8e-6 and 5.1e-6 m after 0.5 s; reference: extrapolated from 1 and
    0.5 ms at newton_tol 1e-12, error ~1e-8 m)."""
    m, st = _flutter_cantilever(8)

    def run(rho, **kw):
        return pf.simulate(m, 0.5, state=st, n_outputs=2, progress=False, integrator="generalized_alpha",
                           step=1e-3, rho_inf=rho, **kw)

    ref = run(1.0, newton_tol=1e-12, extrapolate=True).x[-1]
    stats, err = {}, {}
    for rho in (1.0, 0.6):
        r = run(rho, newton_tol=1e-6, work=False)
        stats[rho] = r.stats["newton_iterations"] / r.stats["steps"]
        err[rho] = np.abs(r.x[-1] - ref).max()
    assert stats[0.6] < 1.3 < 1.7 < stats[1.0], stats
    assert err[1.0] < err[0.6] < 2.0 * err[1.0] < 2e-5, err


def test_richardson_refuses_what_has_no_error_expansion():
    m, st = _flutter_cantilever(2)
    with pytest.raises(ValueError, match="whole steps of h"):
        pf.simulate(m, 0.1, state=st, n_outputs=3, progress=False, integrator="generalized_alpha", step=0.03,
                    extrapolate=True)
    with pytest.raises(ValueError, match="needs generalised-alpha"):
        pf.simulate(m, 0.1, state=st, progress=False, integrator="ida", rtol=1e-6, extrapolate=True)
    with pytest.raises(ValueError, match="error-controlled"):
        pf.simulate(m, 0.1, state=st, progress=False, rtol=1e-6, extrapolate=True)
    from pipeflex.analysis.transient import richardson

    a, b = (pf.simulate(m, 0.02, state=st, n_outputs=2, progress=False, integrator="generalized_alpha", step=h)
            for h in (1e-3, 5e-4))
    with pytest.raises(ValueError, match="h and h/2"):
        richardson(b, a)
    b.stats["failed_steps"] = 1
    with pytest.raises(pf.ConvergenceError, match="halved 1 steps"):
        richardson(a, b)


def test_rotation_log_inverts_the_exponential():
    from pipeflex.rotation import rotation_exp, rotation_log

    rng = np.random.default_rng(3)
    axes = rng.standard_normal((20, 3))
    phis = axes / np.linalg.norm(axes, axis=1, keepdims=True) * np.geomspace(1e-10, 3.0, 20)[:, None]
    R = np.array([rotation_exp(p) for p in phis])
    assert np.allclose(rotation_log(R), phis, rtol=1e-8, atol=1e-15)
    assert np.allclose(rotation_log(R[0]), phis[0], rtol=1e-8, atol=1e-15)
