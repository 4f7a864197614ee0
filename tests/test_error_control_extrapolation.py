"""``pf.simulate(model, t_end, rtol=...)`` below EXTRAPOLATE_BELOW: Richardson over a
controlled mesh, its error estimate and what the levels cost.

The estimate of the finest combination's error is its change from the combination a level
coarser, divided by 15 (a rate of 16 per halving) where that change is at most
EXTRAPOLATION_SETTLED of the finest correction (the h^4 term small beside the h^2 one),
else by 3. Checked against converged references: on the peer's limit cycle the estimate
lands within 3x of the error either way and the error near the request (not far below it:
over-delivery costs steps), on a growing flutter (where the combinations do not converge
at 16) the rate-4 estimate stays in force and the error within 3x of the request.
"""
import numpy as np
import pytest

import pipeflex as pf
from pipeflex.analysis import transient

from test_error_control import T_END, _reference, _tip, tip_loaded_cantilever

PEER_REFERENCE = -0.397335948070  # m, the tip at 2 s (benchmarks/bench_limit_cycle.py, Richardson)


@pytest.fixture(scope="module")
def peer_scene():
    return tip_loaded_cantilever(8)


def _spied(monkeypatch):
    """The options of every core run of the next simulate calls: (controlled, work, newton_tol, steps)."""
    seen = []
    core = transient._core

    class Spy:
        TransientOptions = core.TransientOptions

        @staticmethod
        def integrate(system, flow, loads, times, opt, progress, integrator, **keywords):
            seen.append((opt.error_rate > 0.0, opt.work, opt.newton_tol, len(opt.steps)))
            return core.integrate(system, flow, loads, times, opt, progress, integrator, **keywords)

    monkeypatch.setattr(transient, "_core", Spy)
    return seen


def test_rtol_1e_6_lands_near_the_request_with_a_calibrated_estimate(peer_scene):
    """The peer's scene at rtol 1e-6: two halvings; the error within 3x of the request, the
    estimate not below a third of it and between 0.1 and 1 of the request (it stops near the
    request, not far below: measured 0.46-0.48), in fewer steps than the rate-4 estimate's
    finer mesh took (4480). The error itself, below the estimate, depends on how the
    combination's terms cancel: the round-off of one solver change moved it from 0.49 to 0.08
    of the request with the same estimate."""
    model, state = peer_scene
    rtol = 1e-6
    res = pf.simulate(model, 2.0, n_outputs=2, progress=False, state=state, rtol=rtol)
    err = abs(res.x[-1, -1, 1] - PEER_REFERENCE)
    estimate = res.stats["error_estimate"]
    assert err <= 3.0 * rtol, err
    assert res.metadata["extrapolated"]["halvings"] == 2
    assert err <= 3.0 * estimate, (estimate, err)
    assert 0.1 * rtol * model.length_scale <= estimate <= rtol * model.length_scale, estimate
    assert res.stats["steps"] < 3800, res.stats["steps"]
    assert np.all(np.isfinite(res.fluid_work)) and np.all(np.isfinite(res.load_work))  # the finest runs' works


def test_the_rate_4_estimate_stays_where_the_combinations_do_not_converge(monkeypatch):
    """The growing flutter (4 elements, 0.5 s): its combinations change by more than
    EXTRAPOLATION_SETTLED of the corrections, so the estimate keeps the rate 4: the same run
    as with the rate 16 never assumed; the error within 3x of the request (measured 0.74)."""
    model, state = tip_loaded_cantilever(4)
    reference, _ = _reference(model, state)
    rtol = 1e-6
    run = lambda: pf.simulate(model, T_END, n_outputs=2, progress=False, state=state, rtol=rtol)
    res = run()
    assert np.abs(_tip(res, model) - reference).max() <= 3.0 * rtol * model.length_scale
    monkeypatch.setattr(transient, "EXTRAPOLATION_SETTLED", 0.0)
    never = run()
    assert np.array_equal(res.x, never.x) and res.stats["error_estimate"] == never.stats["error_estimate"]
    assert res.metadata["extrapolated"]["halvings"] >= 3


def test_the_coarse_run_skips_the_works_and_newton_follows_the_steps(peer_scene, monkeypatch):
    """The coarse (mesh-recording) run enters only the estimate: no works integrated;
    each refined run's Newton tolerance is EXTRAPOLATION_NEWTON_SUM rtol / its steps, at
    most the coarse run's (EXTRAPOLATION_NEWTON_SHARE rtol); work=False given: none at all."""
    model, state = peer_scene
    rtol = 1e-7
    seen = _spied(monkeypatch)
    pf.simulate(model, 0.3, n_outputs=2, progress=False, state=state, rtol=rtol)
    (controlled, work, tol, _), refined = seen[0], seen[1:]
    assert controlled and not work and tol == pytest.approx(transient.EXTRAPOLATION_NEWTON_SHARE * rtol)
    assert len(refined) >= 2 and all(not c and w for c, w, _, _ in refined)
    for _, _, t, n in refined:
        assert t == pytest.approx(min(tol, transient.EXTRAPOLATION_NEWTON_SUM * rtol / n))
    assert refined[-1][2] < tol  # the finest run's steps tighten it
    seen.clear()
    pf.simulate(model, 0.3, n_outputs=2, progress=False, state=state, rtol=rtol, work=False)
    assert not any(w for _, w, _, _ in seen)


def test_a_replayed_mesh_ends_on_the_output_time_despite_the_sums_round_off(peer_scene, monkeypatch):
    """A replayed mesh of many small steps late in time: t's sum gathers eps |t| per step
    (here 1000 steps of 1 us from t = 1000 s: about 1e-10 s against a step of 1e-6 s), and
    the step that ends on the output time still counts as ending there (it raised "the
    steps given pass the output time" when the round-off was weighed by the step alone)."""
    model, state = peer_scene
    core = transient._core
    h, n = 1e-6, 1000
    ends = []

    class Replay:
        TransientOptions = core.TransientOptions

        @staticmethod
        def integrate(system, flow, loads, times, opt, progress, integrator, **keywords):
            opt.steps = [h] * n
            out = core.integrate(system, flow, loads, times, opt, progress, integrator, **keywords)
            ends.append(list(times))
            return out

    monkeypatch.setattr(transient, "_core", Replay)
    t0 = 1000.0
    assert abs(sum([t0] + [h] * n) - (t0 + n * h)) > 1e-6 * h  # the sum's round-off exceeds the old bound
    res = pf.simulate(model, t0 + n * h, t_start=t0, state=state, integrator="generalized_alpha", step=h,
                      n_outputs=2, progress=False)
    assert res.stats["steps"] == n
    assert res.t[-1] == pytest.approx(t0 + n * h, rel=1e-15)
