"""The one continuation driver (pipeflex.analysis._continuation.follow) and its two users:
static_equilibrium's load stepping and rotating_state's steps in Omega^2."""
import numpy as np
import pytest

import pipeflex as pf
from pipeflex import _core, scenes
from pipeflex.analysis import static
from pipeflex.analysis._continuation import follow

from test_arclength import fine_cantilever


class Box:
    """A state: the last parameter solved at (copy() as the core's State)."""

    def __init__(self, t=0.0):
        self.t = t

    def copy(self):
        return Box(self.t)


def solver(ok):
    """solve(trial, t) converging where ok(t, trial.t), recording (t, converged)."""
    calls = []

    def solve(trial, t):
        good = ok(t, trial.t)
        calls.append((t, good))
        if good:
            trial.t = t
        return good, len(calls)
    return solve, calls


def test_equal_steps_when_every_solve_converges():
    for halving in ("step", "interval"):
        solve, calls = solver(lambda t, t0: True)
        way = follow(solve, Box(), start=0.0, end=1.0, steps=4, halving=halving, max_failures=3)
        assert way.done and way.t == 1.0 and way.state.t == 1.0 and way.failures == 0 and way.stop is None
        assert [t for t, _ in calls] == pytest.approx([0.25, 0.5, 0.75, 1.0], abs=1e-15)
        assert way.outcome == 4 and way.target is None


def test_the_last_step_lands_on_the_end_exactly():
    """Ten steps of 0.1 add up to 0.9999999999999999: the last solve is at 1.0 itself,
    not at the sum (one rounding short of the full load)."""
    solve, calls = solver(lambda t, t0: True)
    way = follow(solve, Box(), start=0.0, end=1.0, steps=10, halving="step", max_failures=0)
    assert calls[-1][0] == 1.0 and way.t == 1.0 and len(calls) == 10


def test_step_halving_keeps_the_halved_step():
    """"step": a failed step is halved for the rest of the path (load stepping)."""
    solve, calls = solver(lambda t, t0: t - t0 <= 0.3)
    way = follow(solve, Box(), start=0.0, end=1.0, steps=2, halving="step", max_failures=1)
    assert way.done and way.failures == 1
    assert [t for t, _ in calls] == [0.5, 0.25, 0.5, 0.75, 1.0]
    assert [ok for _, ok in calls] == [False, True, True, True, True]


def test_interval_halving_resumes_the_schedule():
    """"interval": a failed target is bisected from the last converged t, then reached,
    then the schedule's step is taken again (rotating_state)."""
    solve, calls = solver(lambda t, t0: t - t0 <= 0.3)
    way = follow(solve, Box(), start=0.0, end=1.0, steps=2, halving="interval", max_failures=2)
    assert way.done and way.failures == 2
    assert [t for t, _ in calls] == [0.5, 0.25, 0.5, 1.0, 0.75, 1.0]


def test_interval_halving_goes_either_way():
    solve, calls = solver(lambda t, t0: abs(t - t0) <= 0.3)
    way = follow(solve, Box(1.0), start=1.0, end=0.0, steps=2, halving="interval", max_failures=2)
    assert way.done and way.state.t == 0.0
    assert [t for t, _ in calls] == [0.5, 0.75, 0.5, 0.0, 0.25, 0.0]


@pytest.mark.parametrize("halving", ["step", "interval"])
def test_it_stops_after_max_failures_and_says_where(halving):
    solve, calls = solver(lambda t, t0: t <= 0.6)
    way = follow(solve, Box(), start=0.0, end=1.0, steps=1, halving=halving, max_failures=3)
    assert not way.done and way.stop == "failures" and way.failures == 4
    # 1 fails, 0.5 converges, then 1, 0.75 and 0.625 fail
    assert way.t == 0.5 and way.state.t == 0.5
    assert way.target == calls[-1][0] == 0.625 and not calls[-1][1] and way.outcome == len(calls)
    assert [t for t, _ in calls] == [1.0, 0.5, 1.0, 0.75, 0.625]
    assert way.step == 0.125


def test_it_stops_below_the_min_step():
    solve, calls = solver(lambda t, t0: t <= 0.5)
    way = follow(solve, Box(), start=0.0, end=1.0, steps=1, halving="interval", max_failures=100, min_step=1e-3)
    assert way.stop == "min_step" and way.t == 0.5 and 0 < way.target - 0.5 < 1e-3
    assert way.failures < 100


def test_a_path_failing_at_once_reports_its_start():
    solve, calls = solver(lambda t, t0: False)
    start = Box()
    way = follow(solve, start, start=0.0, end=1.0, steps=4, halving="step", max_failures=0)
    assert way.state is start and way.t == 0.0 and way.target == 0.25 and way.stop == "failures"
    assert len(calls) == 1


def test_bad_halving():
    with pytest.raises(ValueError, match="halving"):
        follow(lambda s, t: (True, None), Box(), start=0.0, end=1.0, steps=1, halving="half", max_failures=1)
    with pytest.raises(ValueError, match="start < end"):
        follow(lambda s, t: (True, None), Box(), start=1.0, end=0.0, steps=1, halving="step", max_failures=1)


def test_static_load_stepping_halves_a_failed_step(monkeypatch):
    """The cantilever under 50 N in one load step: the step to 1 diverges, 0.5 and 1
    converge; the targets, the iterations and the equilibrium are pinned (the load
    stepping's schedule on the package's one continuation driver)."""
    calls = []
    newton = static._newton

    def recorded(model, state, mdot, load_factor, *args, **kwargs):
        out = newton(model, state, mdot, load_factor, *args, **kwargs)
        calls.append((load_factor, out[0], out[1]))
        return out
    monkeypatch.setattr(static, "_newton", recorded)
    r = pf.static_equilibrium(fine_cantilever(32, 50.0))
    assert calls == [(1.0, False, 3), (0.5, True, 6), (1.0, True, 6)]
    assert r.iterations == 15
    assert float(np.asarray(r.state.q).sum()) == pytest.approx(49.75776239627016, rel=1e-12)


def test_rotating_state_halves_a_failed_step(monkeypatch):
    """rotating_cantilever (10 elements) at Omega = 400 rad/s in two steps of Omega^2:
    the rates tried and the iterations are pinned: each failed target bisected in
    Omega^2, then reached, then the schedule resumed."""
    calls = []
    newton = _core.rotating_state

    def recorded(model, free, state, load, center, axis, w, *args):
        out = newton(model, free, state, load, center, axis, w, *args)
        calls.append((w, out["converged"], out["iterations"]))
        return out
    monkeypatch.setattr(_core, "rotating_state", recorded)
    st = pf.rotating_state(scenes.rotating_cantilever(n_elements=10), 400.0, continuation_steps=2)
    rates = [282.842712474619, 200.0, 141.4213562373095, 200.0, 282.842712474619, 244.94897427831782,
             282.842712474619, 400.0, 346.41016151377545, 400.0]
    np.testing.assert_allclose([w for w, _, _ in calls], rates, rtol=1e-15)
    assert [ok for _, ok, _ in calls] == [False, False, True, True, False, True, True, False, True, True]
    assert [it for _, _, it in calls] == [1, 1, 5, 5, 1, 5, 5, 1, 5, 5]
    assert float(np.asarray(st.q).sum()) == pytest.approx(36.31869642377069, rel=1e-12)


def test_rotating_state_gives_up_near_a_fold():
    """More than MAX_CONTINUATION_FAILURES failed steps (Newton allowed 2 iterations a
    step creeps on): the message names the rate and the last steady state."""
    with pytest.raises(pf.ConvergenceError, match=r"Omega = 6.20098 rad/s \(60 failed steps; the last steady "
                                                  r"state at Omega = 5.74099 rad/s\): a fold") as info:
        pf.rotating_state(scenes.rotating_cantilever(n_elements=10), 300.0, max_iterations=2)
    assert info.value.iteration == 2


def test_the_min_step_holds_either_way():
    """A failed step down the path is halved too (the interval's length, not its sign)."""
    solve, calls = solver(lambda t, t0: abs(t - t0) <= 0.3)
    way = follow(solve, Box(1.0), start=1.0, end=0.0, steps=1, halving="interval", max_failures=10, min_step=1e-3)
    assert way.done and way.failures == 3
    assert [t for t, _ in calls] == [0.0, 0.5, 0.75, 0.5, 0.0, 0.25, 0.0]


def test_rotating_state_continues_down():
    """From the steady state at 600 rad/s down to 300, 100 and 0 rad/s in one step: each
    fails at once and is halved (a step down is halved too: the interval's length, not its
    sign, is held against the min step), and lands on the state found from rest. Down to
    0 the rates on the way have the start's sense (not 0)."""
    m = scenes.rotating_cantilever(n_elements=10)
    high = pf.rotating_state(m, 600.0, continuation_steps=3)
    for w in (300.0, 100.0, 0.0):
        down = pf.rotating_state(m, w, state=high, state_omega=600.0)
        up = pf.rotating_state(m, w, continuation_steps=2) if w else m.initial_state()
        np.testing.assert_allclose(np.asarray(down.q), np.asarray(up.q), rtol=0, atol=1e-9)
