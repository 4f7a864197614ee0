"""Every loop of the analyses ends: bounded by a count and by a tolerance with an absolute
floor (a relative one alone underflows), each with a clear error at its bound; and no
false success: a shooting that converges on an equilibrium is no periodic orbit, and a
critical flow limited by round-off says so, by one rule whatever the model's size."""
import re
import warnings

import numpy as np
import pytest

import pipeflex as pf
from pipeflex.analysis import critical, periodic
from pipeflex.analysis._continuation import follow
from pipeflex.analysis.periodic import orbit_guess, periodic_orbit
from pipeflex.seeds.seed000.limit_cycle import limit_cycle_model


def one_element_with_follower_moment():
    """The fuzz run's case (seed 2026): a clamped one-element pipe, 1 m along z, with a small
    follower moment at its free end. Stable without flow, flutter from the first flow on:
    the crossing is at zero flow (the moment's circulatory stiffness is marginal there)."""
    sec = pf.PipeSection(EI=0.01, EIz=0.01, GAy=1e4, GAz=1e4, fluid_mass=1.0, kv=4.0 / 3.0, pipe_mass=0.05,
                         rotary_inertia=(1e-3, 5e-4, 5e-4))
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    n1 = b.add_line(n0, (0.0, 0.0, 1.0), 1, sec)[-1]
    b.clamp(n0)
    level = 5.773076666045656e-05
    b.add_load(n1, force=level * np.array([6.103515625e-05, 0.0, 0.0]),
               moment=level * np.array([-1.0, 0.0, -0.99999]), follower=True)
    return b.build()


@pytest.mark.timeout(60)
def test_critical_flow_unstable_from_the_first_flow_ends():
    """The tracking puts the crossing at ~3e-12 kg/s; the bisection then halved the
    bracket towards 0 with the relative test hi - lo > 1e-3 hi, which never fails once hi
    is the smallest subnormal (the midpoint rounds to 0, 1e-3 hi underflows): a hang. Its
    tolerance now has the floor AT_ZERO_FLOW flow units, where the crossing is at zero
    flow: the error says so and names the flow."""
    model = one_element_with_follower_moment()
    with pytest.raises(pf.ConvergenceError, match=r"loses stability as soon as the flow starts \(crossing at mdot = "
                                                  r"[0-9.e+-]+ kg/s") as err:
        pf.critical_mass_flow(model, steps_per_unit=1)
    assert 0.0 < err.value.mass_flow <= critical.AT_ZERO_FLOW * model.flow_scale()


@pytest.mark.timeout(60)
def test_critical_flow_scan_is_bounded_by_a_count():
    """mass_flow_max = 1e300 kg/s: the scan stopped only at the first instability or at
    mass_flow_max, 1e300 / (flow unit / steps_per_unit) eigen-analyses (forever for a
    model that stays stable). It stops after MAX_SCAN_POINTS points and names the flows
    and the parameters; here (a bound of 50 for the test) before the clamped one-element
    pipe's divergence at 91 kg/s (29 flow units)."""
    sec = pf.PipeSection(EI=1.0, pipe_mass=1.0, fluid_mass=1.0, EA=1e4, GJ=1.0, GAy=1e3, GAz=1e3)
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    b.add_line(n0, (1.0, 0.0, 0.0), 1, sec)
    b.clamp(n0)
    model = b.build()
    unit = model.flow_scale()
    points = 50  # (a smaller bound for the test: the rule, not the default's cost)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(critical, "MAX_SCAN_POINTS", points, raising=False)  # (the old code: a hang)
        with pytest.raises(pf.ConvergenceError, match=r"no instability found up to [0-9.e+]+ kg/s in "
                                                      r"MAX_SCAN_POINTS = 50 scan points .*mass_flow_max = 1e\+300 "
                                                      r"kg/s would take .*lower mass_flow_max or steps_per_unit") as err:
            pf.critical_mass_flow(model, mass_flow_max=1e300)
    assert err.value.mass_flow == pytest.approx(points * unit / 4, rel=1e-9)


@pytest.mark.timeout(60)
def test_continuation_stops_below_the_resolution_of_its_parameter():
    """follow() with halving="step": every halving of a failing step used to go on as long as
    max_failures allowed; past the resolution of t a step does not move t, and a
    succeeding solve there is a loop without end. It stops at the resolution (stop
    "min_step"), whatever max_failures, and refuses a schedule whose step cannot move t."""
    calls = []

    def solve(trial, t):
        calls.append(t)
        return t <= 0.5, t  # no solution beyond t = 0.5

    way = follow(solve, np.zeros(1), start=0.0, end=1.0, steps=1, halving="step", max_failures=10**6)
    assert not way.done and way.stop == "min_step"
    assert way.t == pytest.approx(0.5, abs=1e-12) and len(calls) < 200
    with pytest.raises(ValueError, match=r"steps = 10000000000000000000 over \[0, 1\]: a step of 1e-19 is below "
                                         r"the resolution"):
        follow(solve, np.zeros(1), start=0.0, end=1.0, steps=10**19, halving="step", max_failures=1)


@pytest.fixture(scope="module")
def planar4():
    return limit_cycle_model(n_elements=4, tip_force=1.5, planar=True, EA=1e5)


@pytest.mark.timeout(60)
def test_orbit_guess_refuses_an_unbounded_t_max(planar4):
    """orbit_guess(t_max=1e300) integrated chunk by chunk without end below the flutter
    flow (the oscillation dies, the transient never settles). t_max / step is bounded by
    MAX_GUESS_STEPS, the error names both."""
    m, tip = planar4
    with pytest.raises(ValueError, match=r"t_max = 1e\+300 s is 2\.5e\+302 steps of step = 0\.004 s; at most "
                                         r"MAX_GUESS_STEPS = 1e\+08"):
        orbit_guess(m, node=tip, step=4e-3, mass_flow=10.0, t_max=1e300)
    assert periodic.MAX_GUESS_STEPS * 4e-3 > 200.0  # the default t_max stays allowed at this step


@pytest.mark.parametrize("mass_flow, at_rest", [(None, True), (10.0, True), (10.0, False)])
def test_periodic_orbit_from_an_equilibrium_is_refused(planar4, mass_flow, at_rest):
    """Shooting from the static equilibrium (at the flutter flow 30 kg/s, or at 10 kg/s
    below it) or from the reference state below the flutter flow converges on the
    equilibrium: amplitude ~1e-15 .. 1e-11 m, no multiplier at 1, and was returned as an
    orbit (stable=True at 10 kg/s). Now a ConvergenceError names the flow and the amplitude."""
    m, _ = planar4
    st = pf.static_equilibrium(m, mass_flow=0.0).state if at_rest else None
    flow = 30.0 if mass_flow is None else mass_flow
    with pytest.raises(pf.ConvergenceError, match=rf"the start decays to an equilibrium at mdot = {flow:g} kg/s.*"
                                                  r"its amplitude [0-9.e+-]+ m is below 1e-08 m \(MIN_ORBIT_AMPLITUDE"
                                                  r".*no Floquet multiplier is 1") as err:
        periodic_orbit(m, period=0.4, state=st, mass_flow=mass_flow)
    assert err.value.mass_flow == flow
    with pytest.raises(pf.ConvergenceError, match="decays to an equilibrium"):  # without multipliers too
        periodic_orbit(m, period=0.4, state=st, mass_flow=mass_flow, multipliers=False)


@pytest.mark.parametrize("period", [1e300, 1e6])
def test_periodic_orbit_refuses_a_period_far_beyond_the_models(planar4, period):
    """periodic_orbit(period=1e300) blamed a mechanism ("give rotary_inertia"): the step
    T / steps made the integrator's matrix singular. The period is compared with the
    model's slowest natural period (0.518 s here) and refused by MAX_PERIOD_RATIO."""
    m, _ = planar4
    st = pf.static_equilibrium(m, mass_flow=0.0).state
    with pytest.raises(ValueError, match=r"period = [0-9.e+]+ s is [0-9.e+]+ times the model's slowest natural "
                                         r"period 0\.518\d* s .*MAX_PERIOD_RATIO = 1000") as err:
        periodic_orbit(m, period=period, state=st)
    assert "rotary_inertia" not in str(err.value)


def test_roundoff_rule_is_one_rule_whatever_the_size(monkeypatch):
    """The guard of a flutter flow limited by round-off: the flow's estimate
    (CriticalFlow.roundoff) above ROUNDOFF_LIMIT relative warns, with the estimate, at any
    size. 10 000 elements returned 24.864 kg/s (0.57 % low) without a word while the
    failing tracking at 8192 was refused; measured here at small scale: the 2048-element
    cantilever's estimate, 1e-5 relative, is under the limit (no warning); with the limit
    below it the same path warns."""
    model = pf.scenes.cantilever_pipe(n_elements=2048)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        r = pf.critical_mass_flow(model)
    assert r.kind == "flutter" and r.mass_flow == pytest.approx(25.0055205579, rel=1e-9)
    assert 1e-7 * r.mass_flow < r.roundoff < critical.ROUNDOFF_LIMIT * r.mass_flow
    monkeypatch.setattr(critical, "ROUNDOFF_LIMIT", 0.1 * r.roundoff / r.mass_flow)
    with pytest.warns(RuntimeWarning, match=r"the flutter flow 25\.0055\d* kg/s is limited by round-off: at "
                                            r"\d+ coordinates .* move it by about [0-9.e-]+ kg/s") as rec:
        again = pf.critical_mass_flow(model)
    assert rec[0].filename == __file__  # the user's line
    assert again.mass_flow == r.mass_flow and again.roundoff == r.roundoff


def test_roundoff_estimate_grows_with_the_conditioning():
    """The estimate itself: ROUNDOFF_SHIFT eigen_noise / |dRe lambda / dmdot|, about N^3.5
    on the cantilever (eigen_noise ~ N^4 / sqrt(n)): 8 and 128 elements."""
    small, fine = (pf.critical_mass_flow(pf.scenes.cantilever_pipe(n_elements=n)) for n in (8, 128))
    assert 0.0 < small.roundoff < 1e-10
    assert fine.roundoff / small.roundoff == pytest.approx(16.0 ** 3.5, rel=0.5)


@pytest.mark.slow
@pytest.mark.timeout(600)
def test_roundoff_rule_at_8192_and_10000_elements():
    """The one rule at full scale (35-55 s each, two cores shared): 8192 elements (25.0055205768,
    right to 8e-10 since the element length 2^-13 m rounds exactly, estimate 3e-3 relative)
    and 10 000 (24.8643, 0.57 % low; estimate 0.14 kg/s) both warn with their estimate."""
    for n in (8192, 10000):
        with pytest.warns(RuntimeWarning, match="limited by round-off"):
            r = pf.critical_mass_flow(pf.scenes.cantilever_pipe(n_elements=n))
        assert r.roundoff > critical.ROUNDOFF_LIMIT * r.mass_flow
        assert abs(r.mass_flow - 25.0055205570) <= 2.0 * r.roundoff


def clamped_one_element_pipe():
    """A clamped one-element pipe, 1 m along x: divergence at 91 kg/s (29 flow units)."""
    sec = pf.PipeSection(EI=1.0, pipe_mass=1.0, fluid_mass=1.0, EA=1e4, GJ=1.0, GAy=1e3, GAz=1e3)
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    b.add_line(n0, (1.0, 0.0, 0.0), 1, sec)
    b.clamp(n0)
    return b.build()


@pytest.mark.timeout(60)
def test_static_load_steps_below_the_resolution_are_named_as_the_user_wrote_them():
    """The continuation refuses a load step below the resolution of the load factor; the
    message names the static solver's parameter, load_steps (it named follow()'s own
    "steps", which the user never passed)."""
    model = clamped_one_element_pipe()
    with pytest.raises(ValueError, match=r"^load_steps = 1000000000000000 over \[0, 1\]: a step of 1e-15 is below "
                                         r"the resolution 1\.42e-14 of the parameter; use fewer steps \(lower "
                                         r"load_steps\)$"):
        pf.static_equilibrium(model, load_steps=10**15)
    # the largest allowed schedule still runs (a dead-force-free model: every step converges at once)
    assert pf.static_equilibrium(model, load_steps=10**3).state is not None


@pytest.mark.timeout(60)
def test_arclength_step_halved_to_zero_stops():
    """The arc-length continuation halves a failing step down to ds_min = 2^-12 of its first
    step; a first step below 2^-1063 (a subnormal dt0 from a huge load_steps and a flat
    path) makes ds_min itself 0, and ds / 2 reaches 0: without the ds == 0 test the loop
    would retry a zero step for ever. A corrector that always fails (a stand-in: no
    physical model makes every step fail this cheaply) drives it there: the path ends
    after the five halvings from 2^-1070 to 0, and says why."""
    from pipeflex.analysis import arclength

    model = clamped_one_element_pipe()
    calls = []

    def newton(state, arc):
        calls.append(arc.ds)
        return False, 1, 1.0, "Newton did not converge (a stand-in)", False

    way = arclength.follow(model, model.initial_state(), 0.0, at=lambda t: (0.0, t), newton=newton, size=1.0,
                           tol=1e-10, max_iterations=20, max_steps=10**6, dt0=2.0**-1070)
    assert way.end is None and way.steps == 0
    assert re.fullmatch(r"the arc-length step was halved to 0 from its first [0-9.e-]+ at t = 0: Newton did not "
                        r"converge \(a stand-in\)", way.why), way.why
    assert 0 < len(calls) <= 8 and calls[-1] > 0.0  # 2^-1070 .. 2^-1074, never a step of 0


@pytest.mark.timeout(120)
def test_continue_orbits_with_a_subnormal_ds_stops(planar4, monkeypatch):
    """continue_orbits halves a failing step down to 1e-6 ds; for a subnormal ds that bound
    underflows to 0 and h / 2 reaches 0 (then h < 0 never holds: a loop without end).
    Every orbit solve failing (periodic._solve replaced: a real shooting cannot be made
    to fail on every step cheaply) from ds = 2^-1070, the continuation stops after the
    halvings to 0 and says that no orbit was found next to the Hopf point."""
    m, _ = planar4
    calls = []

    def no_orbit(shooter, y, mdot, **kw):
        calls.append(kw["arclength"][-1])
        raise pf.ConvergenceError("no orbit (a stand-in)")

    monkeypatch.setattr(periodic, "_solve", no_orbit)
    start = critical.CriticalFlow(mass_flow=10.0, kind="flutter", frequency=12.0, eigenvalue=12.0j,
                                  mode=np.ones(m.n_dofs, complex), evaluations=0)
    with pytest.raises(pf.ConvergenceError, match=r"no orbit found next to the Hopf point at 10 kg/s"):
        periodic.continue_orbits(m, start=start, mass_flow_end=11.0, ds=2.0**-1070)
    assert 0 < len(calls) <= 8 and calls[-1] > 0.0


@pytest.mark.timeout(120)
def test_large_model_divergence_widening_ends_at_zero_flow(monkeypatch):
    """Large models (sparse path): a divergence bracket whose smallest stiffness eigenvalue
    does not change sign is widened downward, doubling, until it does; where it never
    does the widening ends at zero flow with the ConvergenceError that names the bracket.
    Driven by the one-element pipe taken as large (SPARSE_MIN_DOFS lowered) and k_min
    replaced by its magnitude (no sign change: the Arnoldi round-off of ~10^4 elements
    that makes this happen cannot be had cheaply). The widening costs about log2(hi /
    width) + 2 stiffness eigen-analyses, here 13 (15 k_min in all)."""
    model = clamped_one_element_pipe()
    monkeypatch.setattr(critical, "SPARSE_MIN_DOFS", 1)
    kmin, evaluate, calls, flows = critical._kmin, critical._Evaluator.__call__, [], []

    def magnitude(eig, sparse):
        calls.append(sparse)
        return abs(kmin(eig, sparse))

    def at(self, mdot, vectors=False):
        flows.append(mdot)
        return evaluate(self, mdot, vectors)

    monkeypatch.setattr(critical, "_kmin", magnitude)
    monkeypatch.setattr(critical._Evaluator, "__call__", at)
    with pytest.raises(pf.ConvergenceError, match=r"divergence between 91\.\d+ and 91\.\d+ kg/s, but no stiffness "
                                                  r"eigenvalue changes sign there") as err:
        pf.critical_mass_flow(model, mass_flow_max=40 * model.flow_scale())
    assert err.value.mass_flow == pytest.approx(91.3, abs=0.1)
    assert all(calls)  # the sparse path's widening
    assert flows[-1] == 0.0 and min(flows) == 0.0  # the widening's last flow: zero, and none below
    width = 91.3025 - 91.2534  # the bisected bracket
    assert len(calls) <= 5 + np.log2(91.3 / width)  # Brent's 2, k_min at hi, a doubling each to 0


def _growing_everywhere(monkeypatch):
    """_track_root's inputs for a sparse block whose crossing eigenvalue grows at every flow
    (refine_eigenpair replaced; the real case is Arnoldi's round-off at ~10^4 elements)."""
    import scipy.sparse as sp
    from types import SimpleNamespace

    block = SimpleNamespace(dofs=np.arange(2), K=sp.identity(2, format="csr"))
    eig_hi = SimpleNamespace(values=np.array([0.5 + 10j, 0.5 - 10j]), blocks=[block], block_of=np.array([0, 0]))
    ev = SimpleNamespace(sparse=True, count=0, blocks=lambda m: ([block], None, None))
    monkeypatch.setattr(critical, "refine_eigenpair", lambda b, lam, x=None: (complex(1.0, 10.0), None))
    return ev, eig_hi


@pytest.mark.timeout(60)
def test_track_root_steps_down_to_zero_flow_and_no_further(monkeypatch):
    """Large models: _track_root moves the bracket's lower end down while the refined
    crossing eigenvalue still grows there, by the bracket's width, doubling after 4
    steps. Growing at every flow, it reaches zero flow after 13 steps here (width 1e-3 from
    1 kg/s) and stops: "grows down to zero flow" (critical_mass_flow then bisects on
    full eigen-analyses); with the count MAX_BISECTIONS lowered to 5 (the default, 64
    doublings, reaches 0 from any bracket a double can hold) the count ends it."""
    ev, eig_hi = _growing_everywhere(monkeypatch)
    with pytest.raises(ValueError, match="the crossing eigenvalue grows down to zero flow"):
        critical._track_root(ev, 1.0, 1.001, eig_hi, 1e-12)
    assert ev.count == 14  # 13 steps down (4 of the width, then doubling) and the one at 0
    ev.count = 0
    monkeypatch.setattr(critical, "MAX_BISECTIONS", 5)
    with pytest.raises(ValueError, match=r"the crossing eigenvalue still grows at 0\.994 kg/s after 5 steps down"):
        critical._track_root(ev, 1.0, 1.001, eig_hi, 1e-12)
    assert ev.count == 5
