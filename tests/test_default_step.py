"""The generalised-alpha step of ``simulate(integrator="auto")``: 400 steps per period of
the slowest mode, and h |lambda| <= GROWING_STEP_FACTOR for the fastest mode that grows
over the run (flutter, divergence far above a critical flow)."""
import numpy as np
import pytest

import pipeflex as pf
from pipeflex.analysis.eigen import _growing, eigenvalues
from pipeflex.analysis.transient import (GROWING_STEP_FACTOR, STEPS_PER_SLOWEST_PERIOD, default_step, slowest_rate,
                                         step_rates)

TIMES = np.linspace(0.0, 1.0, 201)  # 1 s, 5 ms between outputs


def slow_motion_step(model, mass_flow, times=TIMES):
    """The step from the slowest mode alone, fitted to the output spacing."""
    dt = (times[-1] - times[0]) / (len(times) - 1)
    h_max = 2 * np.pi / (STEPS_PER_SLOWEST_PERIOD * slowest_rate(model, mass_flow=mass_flow))
    return dt / np.ceil(dt / h_max - 1e-9)


@pytest.mark.parametrize("name,model,mass_flow,expected", [
    ("cantilever, stable", lambda: pf.scenes.cantilever_pipe(n_elements=8), 20.0, 5e-3 / 3),
    ("cantilever, flutter just above 25 kg/s", lambda: pf.scenes.cantilever_pipe(n_elements=8), 30.0, 1.25e-3),
    ("cantilever, 64 elements (sparse eigen-solve)", lambda: pf.scenes.cantilever_pipe(n_elements=64), 30.0,
     1.25e-3),
    ("sprinkler", lambda: pf.scenes.sprinkler(EI=100.0), 10.0, 5e-3 / 3),
    ("sucking sprinkler, growth ~1e-4 1/s", lambda: pf.scenes.sprinkler(EI=100.0, suck=True), 10.0, 2.5e-3),
    ("Coriolis meter", lambda: pf.scenes.coriolis_meter(leg_length=0.2), 100.0, 1.1574074074074073e-05),
])
def test_common_cases_keep_the_slow_motion_step(name, model, mass_flow, expected):
    """A stable pipe and the seeds' scenes, also just above the critical flow (the
    cantilever's flutter at 30 kg/s: |lambda_g| = 14.4 against |lambda_1| = 12.0 1/s),
    get the slowest mode's step: the growing modes' bound does not bind (the values
    pin the steps that the seeds' runs and the tests take)."""
    m = model()
    h = default_step(m, TIMES, mass_flow=mass_flow)
    assert h == pytest.approx(slow_motion_step(m, mass_flow), rel=1e-12), name
    assert h == pytest.approx(expected, rel=1e-12), name


def flutter_start():
    """The 8-element cantilever with a tip velocity of 1 mm/s, for a run at 1e6 kg/s
    (40,000 times the critical flow, 25.0 kg/s): its fastest growing eigenvalue is
    |lambda_g| = 8.58e6 1/s, its slowest a torsion mode at 435 rad/s."""
    m = pf.scenes.cantilever_pipe(n_elements=8, polar_inertia=1e-4)
    st = m.initial_state()
    tip = m.n_nodes - 1
    st.v[6 * tip + 1] = 1e-3
    return m, st, tip


def test_auto_step_resolves_flutter_far_above_critical():
    """At 1e6 kg/s the motion grows ~25 e-foldings in 3 us, to a tip deflection of 5.6 mm.
    "auto" steps h = 5.8 ns (h |lambda_g| = 0.05): its tip history agrees with a run at
    h/4 within 3 % of the largest deflection (1.7 % measured; the error falls as h^2).
    The slowest mode's step (here the 150 ns output spacing) errs by ~900 %."""
    m, st, tip = flutter_start()
    t_end, mdot = 3e-6, 1e6
    run = lambda **kw: pf.simulate(m, t_end, state=st, mass_flow=mdot, n_outputs=21, progress=False, **kw)
    auto = run()
    h = auto.metadata["step"]
    rate, growth = step_rates(m, st, mdot, duration=t_end)
    assert growth == pytest.approx(8.58e6, rel=1e-3)
    assert 0.9 * GROWING_STEP_FACTOR / growth <= h <= GROWING_STEP_FACTOR / growth
    fine = run(step=h / 4)
    y = lambda r: r.x[:, tip, 1] - m.positions[tip, 1]
    amp = np.abs(y(fine)).max()
    assert amp > 1e-3  # the flutter grew from the 1 mm/s start
    assert np.abs(y(auto) - y(fine)).max() <= 0.03 * amp
    slow = run(step=slow_motion_step(m, mdot, auto.t))
    assert np.abs(y(slow) - y(fine)).max() > 0.5 * amp


def test_large_model_far_above_critical_finds_the_fastest_growth():
    """A 40-element cantilever (240 coordinates: the shift-invert path) at 1e6 kg/s: the
    shift-invert about 0 fails (K(mdot) is nearly singular there), so all eigenvalues are
    computed: the fastest growing one, 2.29e7 1/s, is the dense solve's."""
    m = pf.scenes.cantilever_pipe(n_elements=40, polar_inertia=1e-4)
    e = eigenvalues(pf.linearize(m, mass_flow=1e6), method="dense")
    grows = _growing(e) & (np.abs(e.values) > 1e4 * e.noise) & (e.values.real >= 1.0)
    _, growth = step_rates(m, mass_flow=1e6, duration=1.0)
    assert growth == pytest.approx(np.abs(e.values[grows]).max(), rel=1e-9)
    assert growth == pytest.approx(2.293e7, rel=1e-3)
    h = default_step(m, np.linspace(0.0, 1e-6, 11), mass_flow=1e6)
    assert h <= GROWING_STEP_FACTOR / growth


def test_growth_counts_over_the_run():
    """The soft sprinkler (EI = 1 N m^2) at rest with flow flutters at 6.7 +- 29.6j 1/s:
    over 1 s (6.7 e-foldings) the step resolves it, h |lambda| <= 0.05; over 0.1 s
    (0.67 e-foldings) it is an oscillation like the stable ones, and the step is the
    slow motion's."""
    m = pf.scenes.sprinkler(EI=1.0)
    _, growth = step_rates(m, duration=1.0)
    assert growth == pytest.approx(abs(6.7311 + 29.5649j), rel=1e-4)
    assert default_step(m, TIMES) <= GROWING_STEP_FACTOR / growth
    short = np.linspace(0.0, 0.1, 21)
    assert np.isnan(step_rates(m, duration=0.1)[1])
    assert default_step(m, short) == pytest.approx(slow_motion_step(m, m.mass_flow, short), rel=1e-12)
