"""pf.parametric_stability and pf.instability_chart: Floquet stability of pipes conveying a
pulsating flow mdot0 (1 + mu sin(Omega t)), against an independent Galerkin-Floquet solver
of the Paidoussis-Issid equation (tests/galerkin_floquet.py: no pipeflex code), against a
transient (pf.simulate), and the linearisation's polynomial in the flow and its rate.

Cost ~30 s on a busy 2-core machine (the Galerkin solver ~0.3 s per multiplier set, the
tongue boundaries by Brent's method on both solvers; one chart on a process pool).
"""
import pickle
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
from scipy.optimize import brentq

import pipeflex as pf
from galerkin_floquet import Pipe, basis
from pipeflex.analysis import parametric
from pipeflex.analysis.stability_map import cantilever

EPS = np.finfo(float).eps
#: simply supported pipe of the scenes (L = 1 m, EI = 1 N m^2, m = 0.75, M = 0.25 kg/m):
#: u = mdot L / sqrt(M EI) = pi / 2, half its buckling flow
SS_FLOW = 0.785
#: the cantilever (beta = 0.2) at u = 5, below its flutter flow (u_cr ~ 5.6): the flow damps
BETA = 0.2
CANT_FLOW = 5.0 * np.sqrt(BETA)


@pytest.fixture(scope="module")
def ss_pipe():
    return pf.scenes.simply_supported_pipe(n_elements=16)


@pytest.fixture(scope="module")
def ss_oracle():
    return Pipe("pinned", n_modes=4)


def stability(model, mdot0, mu, Omega, **options):
    return pf.parametric_stability(model, mean_flow=mdot0, amplitude=mu, frequency=Omega, **options)


# ---------------------------------------------------------------------------------------
# the independent solver, checked before it is trusted

def test_galerkin_oracle_has_the_beam_frequencies_and_the_buckling_flow():
    # without flow: pinned omega_n = (n pi)^2, clamped-free lambda_n^2 (lambda_1 = 1.87510407,
    # lambda_2 = 4.69409113; Blevins, Table 8-1), for EI = m + M = L = 1
    np.testing.assert_allclose(Pipe("pinned", pipe_mass=0.75).frequencies(0.0)[:3],
                               (np.arange(1, 4) * np.pi) ** 2, rtol=1e-12)
    np.testing.assert_allclose(Pipe("cantilever", pipe_mass=0.8, fluid_mass=0.2).frequencies(0.0)[:2],
                               np.array([1.87510407, 4.69409113]) ** 2, rtol=1e-8)
    # the cantilever's modes: phi''(L) = phi'''(L) = 0 is used implicitly; phi(0) = phi'(0) = 0
    p, d1, d2, _ = basis("cantilever", 4, 1.0, np.array([0.0, 1.0]))
    np.testing.assert_allclose(np.r_[p[:, 0], d1[:, 0], d2[:, 1]], 0.0, atol=1e-9)
    # the pinned pipe buckles at u = pi: mdot = pi sqrt(M EI) / L
    assert Pipe("pinned").frequencies(0.999 * np.pi * 0.5)[0] < 0.1 * np.pi ** 2
    # no pulsation: the multipliers are exp(lambda T)
    o = Pipe("pinned", n_modes=3)
    rho = o.multipliers(SS_FLOW, 0.0, 7.0)
    np.testing.assert_allclose(np.sort_complex(rho), np.sort_complex(np.exp(o.eigenvalues(SS_FLOW) * 2 * np.pi / 7.0)),
                               atol=1e-9)


# ---------------------------------------------------------------------------------------
# the linearisation: polynomial in the flow and linear in its rate, to round-off

def test_linearisation_is_quadratic_in_the_flow_and_linear_in_its_rate():
    # the pinned pipe with a moderate EA, so that round-off is small against the flow's terms
    b = pf.ModelBuilder()
    nodes = b.add_line(b.add_node((0.0, 0.0, 0.0)), (1.0, 0.0, 0.0), 8,
                       pf.PipeSection(EI=1.0, EA=100.0, pipe_mass=0.75, fluid_mass=0.25))
    b.fix(nodes[0], ("ux", "uy", "uz", "rx"))
    b.fix(nodes[-1], ("uy", "uz"))
    model = b.build()
    lin = lambda mdot, rate=0.0: pf.linearize(model, mass_flow=mdot, mass_flow_rate=rate)
    flows = (0.0, 0.5, 1.0)
    L = [lin(x) for x in flows]
    x = 1.7  # a fourth flow: the quadratic through three reproduces it entry by entry
    lag = [np.prod([(x - b) / (a - b) for b in flows if b != a]) for a in flows]
    scale = max(abs(l.K).max() for l in L)  # the assembly's round-off is relative to its largest terms
    for name in ("K", "C", "M"):
        got = getattr(lin(x), name).toarray()
        parts = [c * getattr(l, name).toarray() for c, l in zip(lag, L)]
        assert np.abs(got - sum(parts)).max() <= 64 * EPS * scale * sum(abs(c) for c in lag), name
    # the rate: K linear in it, C and M independent of it; and it does enter K
    K0, K1, K2 = (lin(SS_FLOW, r).K.toarray() for r in (0.0, 3.0, 6.0))
    assert np.abs(K1 - K0).max() > 0.1
    assert np.abs((K2 - K0) - 2 * (K1 - K0)).max() <= 64 * EPS * scale
    assert (lin(SS_FLOW, 3.0).C != lin(SS_FLOW).C).nnz == 0
    with pytest.raises(ValueError, match="mass_flow_rate"):
        pf.linearize(model, mass_flow_rate=np.nan)


def axial_displacements(model, u_reduced):
    q = model.basis @ u_reduced
    return q.reshape(model.n_nodes, 6)[:, 0]


def test_the_fluid_acceleration_loads_the_pipe_axially_as_the_supports_allow():
    # The element's fluid acceleration term pushes on the wall with -mdot' [N/m] along the
    # axis, so N' = mdot': a free (or axially sliding) outlet gives N = -mdot' (L - x)
    # (Paidoussis' M U' (L - x) w'' term), both ends held axially N = mdot' (x - L / 2).
    # Checked through the axial displacement u = int N / EA of the quasi-static response
    # to a unit rate (exact at the nodes: a bar under nodal loads).
    EA, L = 1e6, 1.0

    def line(hold_outlet):
        b = pf.ModelBuilder()
        n0 = b.add_node((0.0, 0.0, 0.0))
        nodes = b.add_line(n0, (L, 0.0, 0.0), 8, pf.PipeSection(EI=1.0, EA=EA, pipe_mass=0.8, fluid_mass=0.2))
        b.clamp(n0)
        if hold_outlet:
            b.clamp(nodes[-1])
        return b.build(), np.linspace(0.0, L, 9)

    for held, u_exact in ((False, lambda x: -(L * x - x * x / 2) / EA), (True, lambda x: (x * x - L * x) / (2 * EA))):
        model, x = line(held)
        flow = parametric._FlowModel(model, 0.0)  # (a mean flow's momentum flux would soften EA by kv mdot^2 / M)
        np.testing.assert_allclose(axial_displacements(model, flow.u_rate), u_exact(x), rtol=1e-8,
                                   atol=1e-8 * abs(u_exact(L / 2)))


# ---------------------------------------------------------------------------------------
# Floquet multipliers

def test_without_pulsation_every_multiplier_of_the_undamped_pipe_has_modulus_one():
    model = pf.scenes.simply_supported_pipe(n_elements=8)
    for Omega in (5.0, 13.0, 30.0):
        r = stability(model, SS_FLOW, 0.0, Omega, modes=8)
        assert r.stable and len(r.multipliers) == 16
        np.testing.assert_allclose(np.abs(r.multipliers), 1.0, atol=1e-11)
        np.testing.assert_allclose(r.period, 2 * np.pi / Omega)
    # a small pulsation away from the tongues: still on the unit circle
    r = stability(model, SS_FLOW, 0.05, 0.8 * 2 * r.natural_frequencies[0], modes=8)
    assert r.stable and np.abs(np.abs(r.multipliers) - 1.0).max() < 1e-8
    # the steps are converged: twice as many change nothing that matters
    inside = dict(mdot0=SS_FLOW, mu=0.2, Omega=2 * r.natural_frequencies[0])
    a = stability(model, *inside.values(), modes=8)
    b = stability(model, *inside.values(), modes=8, steps=2 * a.steps)
    assert a.largest > 1.1 and abs(a.largest - b.largest) < 1e-7 * a.largest
    assert a.truncation_change < 1e-4 and a.fit_error < 1e-5


def test_planar_ancf_beam_without_fluid_is_not_excited():
    b = pf.ModelBuilder()
    nodes = b.add_ancf_beam((0, 0, 0), (1, 0, 0), 4, pf.PipeSection(EI=1.0, EA=1e4, pipe_mass=1.0))
    b.pin(nodes[0])
    b.pin(nodes[-1])
    r = stability(b.build(), 0.0, 0.5, 2 * np.pi ** 2, modes=4)  # at 2 omega_1: no fluid, no tongue
    assert r.stable and np.abs(np.abs(r.multipliers) - 1.0).max() < 1e-10


def tongue_edges(largest, centre, *, width=0.2, tol=1e-6):
    """The principal tongue's edges [rad/s] at one amplitude: largest(Omega) = 1 + tol."""
    g = lambda W: largest(W) - 1.0 - tol
    return (brentq(g, centre * (1 - width), centre, xtol=1e-7 * centre),
            brentq(g, centre, centre * (1 + width), xtol=1e-7 * centre))


def test_principal_tongue_of_the_pinned_pipe_matches_the_galerkin_solver(ss_pipe, ss_oracle):
    w1 = ss_oracle.frequencies(SS_FLOW)[0]
    r = stability(ss_pipe, SS_FLOW, 0.0, 2 * w1, modes=8)
    # the apex: 2 omega_1(mdot0), with omega_1 of the flowing pipe (gyroscopic: below sqrt(1 - u^2/pi^2))
    assert r.natural_frequencies[0] == pytest.approx(w1, rel=1e-3)
    assert w1 < np.pi ** 2 * np.sqrt(1 - 0.25)
    # the tongue opens from mu = 0 (no dissipation): unstable at its apex however small mu,
    # stable 1 % to either side at small mu
    assert not stability(ss_pipe, SS_FLOW, 0.005, 2 * r.natural_frequencies[0], modes=8).stable
    for side in (0.99, 1.01):
        assert stability(ss_pipe, SS_FLOW, 0.005, side * 2 * w1, modes=8).stable
    # its edges at one amplitude, each by Brent's method on both solvers
    for mu in (0.15,):
        ours = tongue_edges(lambda W: stability(ss_pipe, SS_FLOW, mu, W, modes=8, check_modes=False).largest, 2 * w1)
        theirs = tongue_edges(lambda W: ss_oracle.largest(SS_FLOW, mu, W), 2 * w1)
        np.testing.assert_allclose(ours, theirs, rtol=1e-3)
        assert theirs[1] - theirs[0] > 0.02 * w1 * mu  # a tongue of finite width


@pytest.fixture(scope="module")
def cantilever_pair():
    return cantilever(BETA, n_elements=16), Pipe("cantilever", pipe_mass=1 - BETA, fluid_mass=BETA, n_modes=10)


def test_cantilever_below_flutter_has_a_threshold_amplitude(cantilever_pair):
    model, oracle = cantilever_pair
    w = oracle.frequencies(CANT_FLOW)
    # the multipliers inside the second mode's principal tongue and at a combination tongue
    for mu, Omega, check in ((0.2, 2 * w[1], True), (0.4, w[0] + w[1], False)):
        r = stability(model, CANT_FLOW, mu, Omega, modes=16, check_modes=check)
        assert r.largest == pytest.approx(oracle.largest(CANT_FLOW, mu, Omega), rel=2e-3)
        assert not check or r.truncation_change < 2e-3
    # the flow damps: at the tongue's centre the pipe is stable below a threshold amplitude
    ours = brentq(lambda mu: stability(model, CANT_FLOW, mu, 2 * w[1], modes=16, check_modes=False).largest - 1.0,
                  0.01, 0.2, xtol=1e-6)
    theirs = brentq(lambda mu: oracle.largest(CANT_FLOW, mu, 2 * w[1]) - 1.0, 0.01, 0.2, xtol=1e-6)
    assert ours == pytest.approx(theirs, rel=1e-2)
    assert 0.02 < theirs < 0.2
    below = stability(model, CANT_FLOW, 0.5 * ours, 2 * w[1], modes=16, check_modes=False)
    assert below.stable and below.largest < 1.0  # no undamped coordinate: every multiplier inside


def test_a_transient_grows_inside_the_tongue_and_decays_just_outside():
    # the cantilever with a polar inertia (simulate needs a regular mass matrix; the torsion's
    # multipliers are then on the unit circle, the bending ones decide)
    b = pf.ModelBuilder()
    root = b.add_node((0.0, 0.0, 0.0))
    nodes = b.add_line(root, (1.0, 0.0, 0.0), 8, pf.PipeSection(EI=1.0, pipe_mass=1 - BETA, fluid_mass=BETA,
                                                                  rotary_inertia=(1e-4, 0.0, 0.0)))
    b.clamp(root)
    model = b.build(mass_flow=CANT_FLOW)
    mu = 0.2
    fast = dict(modes=12, check_modes=False)
    w2 = stability(model, CANT_FLOW, 0.0, 1.0, **fast).natural_frequencies[2]  # bending pairs: omega_1 twice
    edge = brentq(lambda W: stability(model, CANT_FLOW, mu, W, **fast).largest - 1.0 - 1e-6,
                  2 * w2, 1.3 * 2 * w2, xtol=1e-3 * w2)
    from pipeflex.charts import ElementChart

    v = np.zeros(model.n_dofs)
    v[model.dof_index(nodes[-1], "uy")] = 1e-3  # a small tip velocity: the linear range
    start = ElementChart(model, None).state(np.zeros(model.n_dofs), v)
    for factor, grows in ((0.97, True), (1.03, False)):
        Omega = factor * edge
        r = stability(model, CANT_FLOW, mu, Omega, **fast)
        assert r.stable is not grows
        periods, per = 16, 40
        T = periods * 2 * np.pi / Omega
        run = pf.simulate(model, T, state=start, times=np.linspace(0.0, T, periods * per + 1), progress=False,
                          mass_flow=pf.pulsating_flow(mean_flow=CANT_FLOW, amplitude=mu, frequency=Omega))
        y = run.x[:, nodes[-1], 1]
        early, late = np.abs(y[2 * per:4 * per]).max(), np.abs(y[-2 * per:]).max()
        ratio = (late / early) ** (1.0 / (periods - 4))  # per period, over 12 periods
        if grows:  # at the rate of the largest multiplier
            assert ratio == pytest.approx(r.largest, rel=0.03)
        else:
            assert ratio < 0.9


# ---------------------------------------------------------------------------------------
# the chart

def test_instability_chart_on_each_executor_and_its_tongues():
    model = pf.scenes.simply_supported_pipe(n_elements=8)
    w1 = stability(model, SS_FLOW, 0.0, 1.0, modes=8).natural_frequencies[0]
    W = np.array([0.9, 0.97, 1.0, 1.03, 1.1]) * 2 * w1
    mus = [0.0, 0.1, 0.3]
    run = dict(mean_flow=SS_FLOW, frequencies=W, amplitudes=mus, modes=8, progress=False)
    serial = pf.instability_chart(model, executor="serial", **run)
    assert serial.largest.shape == (5, 3)
    for i, j in ((2, 1), (0, 2)):  # the chart's batched columns are parametric_stability's numbers
        one = stability(model, SS_FLOW, mus[j], W[i], modes=8, check_modes=False).largest
        assert serial.largest[i, j] == pytest.approx(one, rel=64 * EPS)
    np.testing.assert_allclose(serial.largest[:, 0], 1.0, atol=1e-11)  # mu = 0: stable everywhere
    assert serial.unstable[2, 1] and not serial.unstable[0, 1] and serial.unstable[1:4, 2].all()
    with ThreadPoolExecutor(2) as pool:
        threads = pf.instability_chart(model, executor=pool, **run)
    np.testing.assert_allclose(threads.largest, serial.largest, rtol=64 * EPS)
    pool_chart = pf.instability_chart(model, workers=2, **run)  # the default: a process pool
    np.testing.assert_allclose(pool_chart.largest, serial.largest, rtol=64 * EPS)
    kinds = {t["kind"]: t["frequency"] for t in serial.tongues()}
    assert kinds["2 omega_1 / 1"] == pytest.approx(2 * w1, rel=1e-12)
    ds = serial.to_xarray()
    assert ds["largest"].dims == ("frequency", "amplitude")
    ax = serial.plot()
    assert "Omega" in ax.get_xlabel()
    again = pf.ParametricStability.load(_saved(stability(model, SS_FLOW, 0.1, W[2], modes=8)))
    assert again.largest > 1.0 and not again.stable
    assert pickle.loads(pickle.dumps(serial)).largest.tolist() == serial.largest.tolist()


def _saved(result, path=None):
    import tempfile, os

    path = os.path.join(tempfile.mkdtemp(), "r.npz")
    result.save(path)
    return path


def test_bad_input_is_named():
    model = pf.scenes.simply_supported_pipe(n_elements=2)
    for kwargs, name in ((dict(amplitude=-0.1), "amplitude"), (dict(frequency=0.0), "frequency"),
                         (dict(mean_flow=np.inf), "mean_flow"), (dict(modes=0), "modes")):
        args = dict(mean_flow=SS_FLOW, amplitude=0.1, frequency=10.0) | kwargs
        with pytest.raises(ValueError, match=name):
            pf.parametric_stability(model, **args)
    with pytest.raises(ValueError, match="frequencies"):
        pf.instability_chart(model, mean_flow=SS_FLOW, frequencies=[1.0, 1.0], amplitudes=[0.1])
    with pytest.raises(ValueError, match="amplitudes"):
        pf.instability_chart(model, mean_flow=SS_FLOW, frequencies=[1.0], amplitudes=[-0.1])
    with pytest.raises(TypeError, match="pipeflex.Model"):
        pf.parametric_stability(object(), mean_flow=1.0, amplitude=0.1, frequency=1.0)
    with pytest.raises(ValueError, match="amplitude"):
        pf.pulsating_flow(mean_flow=1.0, amplitude=-0.1, frequency=1.0)


def test_pulsating_flow_is_the_sine_about_its_mean():
    """pf.Sine(mean=) carries the mean into the core's table: the flow and its rate at any
    time are mdot0 (1 + mu sin(Omega t)) and mdot0 mu Omega cos(Omega t)."""
    from pipeflex.time_functions import time_function

    tab = time_function("mass_flow", pf.pulsating_flow(mean_flow=2.0, amplitude=0.25, frequency=3.0))
    for t in (0.0, 0.1, 0.77, 5.3):
        assert tab.at(t) == pytest.approx(2.0 * (1.0 + 0.25 * np.sin(3.0 * t)), rel=1e-15, abs=1e-15)
        assert tab.rate(t) == pytest.approx(2.0 * 0.25 * 3.0 * np.cos(3.0 * t), rel=1e-14, abs=1e-14)
