"""Error-controlled generalised-alpha: ``pf.simulate(model, t_end, rtol=...)``.

Each step's local error estimate (Zienkiewicz & Xie's (beta - 1/6) h^2 (a' - a)) is kept
below (rtol L + atol) h / (ERROR_ACCUMULATION T), so that the run's error, a fraction
ERROR_ACCUMULATION of the summed estimates, lands near rtol L + atol. Checked against
converged references computed by the library's fixed-step integrator (Richardson-
extrapolated from two fine steps with a tight Newton tolerance): on the flutter limit cycle
the error lands within a factor 3 of the request either way, elsewhere below it (never
above 3x); it shrinks in proportion to rtol; Newton's tolerance follows rtol; the steps
follow the motion (short while a step start of the flow rings, long after). The same on
floating-frame bodies (their rotations counted at the model size)."""
import numpy as np
import pytest

import pipeflex as pf
from pipeflex.multibody import MultibodyBuilder, flexible_body

T_END = 0.5
FLOW = 30.0  # kg/s, above the 4-element cantilever's flutter flow (~25 kg/s): a growing motion


def tip_loaded_cantilever(n_elements):
    """Seed 000's cantilever (``n_elements``, polar inertia for time integration, the
    peer scene's section) with a 1.5 N tip force at FLOW, and its static deflection without
    flow (the start: the flow switched on at t = 0)."""
    sec = pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0, EA=1e5, rotary_inertia=(1e-3, 0.0, 0.0))
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    nodes = b.add_line(n0, (1.0, 0.0, 0.0), n_elements, sec)
    b.clamp(n0)
    b.add_load(nodes[-1], force=(0.0, 1.5, 0.0))
    model = b.build(mass_flow=FLOW)
    return model, pf.static_equilibrium(model, mass_flow=0.0).state


@pytest.fixture(scope="module")
def cantilever():
    """Seed 000's cantilever (4 elements, polar inertia for time integration) with a tip
    force, from its static deflection without flow, the flow switched on at t = 0."""
    return tip_loaded_cantilever(4)


def _tip(res, model):
    return res.x[-1, model.n_nodes - 1, :]


def _reference(model, state, **run):
    """The converged end state: fixed steps h and h/2 with Newton to 1e-13, Richardson."""
    a, b = (pf.simulate(model, T_END, n_outputs=2, progress=False, integrator="generalized_alpha", step=h,
                        newton_tol=1e-13, state=state, **run) for h in (1e-4, 5e-5))
    return _tip(b, model) + (_tip(b, model) - _tip(a, model)) / 3.0, abs(_tip(b, model) - _tip(a, model)).max() / 3


@pytest.fixture(scope="module")
def reference(cantilever):
    model, state = cantilever
    ref, err = _reference(model, state)
    assert err < 1e-6  # the reference is far more accurate than the runs checked
    return ref


def test_rtol_alone_meets_the_request_and_the_error_follows_it(cantilever, reference):
    model, state = cantilever
    L = model.length_scale
    errors = {}
    for rtol in (1e-3, 1e-4):
        res = pf.simulate(model, T_END, n_outputs=2, progress=False, state=state, rtol=rtol)
        assert res.metadata["integrator"] == "generalized_alpha" and res.metadata["rtol"] == rtol
        err = float(np.abs(_tip(res, model) - reference).max())
        errors[rtol] = err
        # the request: within 3 rtol L above; below it by at most 30 here, a growing
        # flutter whose stiff modes' local errors do not add up (measured 0.18-0.21 rtol L)
        assert rtol * L / 30.0 <= err <= 3.0 * rtol * L, (rtol, err)
        # the estimate reported stays within the request
        assert 0.0 < res.stats["error_estimate"] <= rtol * L * (1 + 1e-12)
        assert res.stats["failed_steps"] <= 0.25 * res.stats["steps"]  # steps redone for their error
    # tolerance proportionality: ten times tighter, about ten times smaller (error per unit step)
    assert 3.0 <= errors[1e-3] / errors[1e-4] <= 30.0


@pytest.fixture(scope="module")
def limit_cycle():
    """The flutter limit cycle of benchmarks/bench_limit_cycle.py: 8 elements, 30 kg/s from
    the static deflection without flow, 2 s (the tip settles on its limit cycle); the
    model, its start and the tip's lateral position at 2 s converged (Richardson from 0.1
    and 0.05 ms: the finer run errs by 1.8e-7 m, the combination by ~5e-10 m, against one
    from 0.05 and 0.025 ms)."""
    model, state = tip_loaded_cantilever(8)
    tip = model.n_nodes - 1
    a, b = (pf.simulate(model, 2.0, n_outputs=2, progress=False, state=state, integrator="generalized_alpha",
                        step=h, newton_tol=1e-13, work=False).x[-1, tip, 1] for h in (1e-4, 5e-5))
    assert abs(b - a) / 3.0 < 1e-6
    return model, state, b + (b - a) / 3.0


def test_rtol_lands_on_the_request_on_the_limit_cycle(limit_cycle):
    """On the limit cycle the error lands within a factor 3 of rtol L either way (measured
    1.05 and 0.91 at rtol 1e-3 and 1e-4; 0.04-1.17 over 1e-2 ... 1e-8, docs/user_guide.md)."""
    model, state, ref = limit_cycle
    run = lambda **o: pf.simulate(model, 2.0, n_outputs=2, progress=False, state=state, **o).x[-1, -1, 1]
    for rtol in (1e-3, 1e-4):
        ratio = abs(run(rtol=rtol) - ref) / (rtol * model.length_scale)
        assert 1.0 / 3.0 <= ratio <= 3.0, (rtol, ratio)


def test_a_new_iteration_matrix_is_not_judged_by_the_old_ones_rate(limit_cycle):
    """The peer's scene at rtol 1e-4. The first correction with a matrix evaluated within a
    step corrects the error the old matrix left: its rate is the old matrix's and no longer
    sends the new one to be evaluated again at the next step, nor is a matrix evaluated
    within a long step stale after it: 69 matrices in 2113 steps (100 in 2170 judged so, 83
    in 2107 with the first rule alone), the error within the request."""
    model, state, ref = limit_cycle
    res = pf.simulate(model, 2.0, n_outputs=2, progress=False, state=state, rtol=1e-4)
    assert res.stats["jacobians"] < 0.036 * res.stats["steps"], res.stats
    assert abs(res.x[-1, -1, 1] - ref) <= 1e-4 * model.length_scale


def test_below_the_rule_the_run_is_extrapolated_over_the_controlled_mesh(limit_cycle):
    """rtol < EXTRAPOLATE_BELOW: Richardson over a controlled mesh halved until the
    estimate meets the request. On the limit cycle at rtol 1e-6: within 3x above and 30x
    below (measured 0.08-0.49: the combination's cancellation moves with the mesh's
    round-off), in a fifth of the second-order control's 33483 steps (3374-3395 measured),
    its estimate within a factor 10 of the error either way."""
    model, state, ref = limit_cycle
    rtol = 1e-6
    res = pf.simulate(model, 2.0, n_outputs=2, progress=False, state=state, rtol=rtol)
    err = abs(res.x[-1, -1, 1] - ref)
    assert rtol * model.length_scale / 30.0 <= err <= 3.0 * rtol * model.length_scale, err
    assert res.metadata["extrapolated"]["halvings"] >= 2 and res.stats["steps"] < 33483 / 5
    assert 0.1 <= res.stats["error_estimate"] / err <= 10.0
    assert res.stats["error_estimate"] <= rtol * model.length_scale
    assert res.metadata["rtol"] == rtol and res.metadata["integrator"] == "generalized_alpha"


def test_extrapolated_runs_meet_the_request_on_a_growing_flutter(cantilever, reference):
    """The 4-element flutter from the flow's start: extrapolation gains less there per
    halving (3-4x instead of 16x: the motion is not smooth on the coarse meshes), which
    the estimate (the finest combination against the next coarser one, / 3) allows for:
    within 3x above (measured 0.34 and 1.9 at rtol 1e-5 and 1e-6); the error falls as
    rtol does."""
    model, state = cantilever
    errors = {}
    for rtol in (1e-5, 1e-6):
        res = pf.simulate(model, T_END, n_outputs=2, progress=False, state=state, rtol=rtol)
        assert "extrapolated" in res.metadata
        errors[rtol] = float(np.abs(_tip(res, model) - reference).max())
        assert rtol * model.length_scale / 30.0 <= errors[rtol] <= 3.0 * rtol * model.length_scale, (rtol, errors)
    assert errors[1e-6] < errors[1e-5]


def test_newton_tolerance_follows_rtol(cantilever):
    """Each step's Newton tolerance is its share of the request (at rtol 1e-4 here below
    5e-6 model sizes): a looser newton_tol given is only a cap (the same run), a tighter one
    costs iterations."""
    model, state = cantilever
    run = lambda **o: pf.simulate(model, T_END, n_outputs=2, progress=False, state=state, **o)
    base = run(rtol=1e-4, newton_tol=1e-5)
    capped = run(rtol=1e-4, newton_tol=1e-3)
    assert np.array_equal(base.x, capped.x) and base.stats["newton_iterations"] == capped.stats["newton_iterations"]
    tight = run(rtol=1e-4, newton_tol=1e-13)
    per_step = lambda r: r.stats["newton_iterations"] / r.stats["steps"]
    assert per_step(tight) > 1.5 * per_step(base)


def test_the_steps_follow_the_motion(cantilever):
    """The flow switched on at t = 0 rings the stiff modes (short steps); the control
    lengthens the step after, and the output times are met exactly."""
    model, state = cantilever
    res = pf.simulate(model, T_END, n_outputs=11, progress=False, state=state, rtol=1e-4)
    assert res.stats["largest_step"] >= 5.0 * res.stats["smallest_step"]
    assert np.allclose(res.t, np.linspace(0.0, T_END, 11), rtol=0, atol=1e-14)
    assert res.metadata["step"] == res.stats["largest_step"]


def test_atol_is_an_absolute_floor(cantilever):
    model, state = cantilever
    loose = pf.simulate(model, T_END, n_outputs=2, progress=False, state=state, rtol=1e-6, atol=1e-3)
    tight = pf.simulate(model, T_END, n_outputs=2, progress=False, state=state, rtol=1e-6)
    assert loose.stats["steps"] < tight.stats["steps"]
    assert loose.stats["error_estimate"] <= 1e-6 * model.length_scale + 1e-3


def test_bodies_meet_the_request():
    """A 2-body FFRF cantilever with flow (hinge-free chain clamped at the ground) swinging
    under a tip force: its frames' rotations are controlled at the model size."""
    section = pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0, EA=1e5, GJ=8.0, rotary_inertia=(1e-3, 0.0, 0.0))
    b = MultibodyBuilder()
    j0 = b.add_body(flexible_body(length=0.5, n_elements=4, section=section, internal_modes=2),
                    position=(0.25, 0.0, 0.0))
    j1 = b.add_body(flexible_body(length=0.5, n_elements=4, section=section, internal_modes=2),
                    position=(0.75, 0.0, 0.0))
    b.fix(j0, "start")
    b.rigid(j0, "end", j1, "start")
    b.add_load(j1, "end", force=(0.0, 1.5, 0.0))
    system = b.build(mass_flow=10.0)
    t_end = 0.3
    runs = [pf.simulate(system, t_end, n_outputs=2, progress=False, integrator="generalized_alpha", step=h,
                        newton_tol=1e-13) for h in (2e-4, 1e-4)]
    tips = [r.node_position(1, "end")[-1] for r in runs]
    ref = tips[1] + (tips[1] - tips[0]) / 3.0
    assert np.abs(tips[1] - tips[0]).max() / 3.0 < 1e-6
    rtol = 1e-4
    res = pf.simulate(system, t_end, n_outputs=2, progress=False, rtol=rtol)
    err = float(np.abs(res.node_position(1, "end")[-1] - ref).max())
    assert err <= 3.0 * rtol * system.length_scale, err
    assert res.stats["error_estimate"] <= rtol * system.length_scale * (1 + 1e-12)


@pytest.mark.parametrize("options, match", [
    ({"rtol": 0.0}, "rtol"), ({"rtol": float("nan")}, "rtol"), ({"rtol": -1e-3}, "rtol"),
    ({"atol": 1e-6}, "rtol too"), ({"rtol": 1e-3, "atol": -1.0}, "atol"),
])
def test_bad_tolerances_are_refused(cantilever, options, match):
    model, state = cantilever
    with pytest.raises(ValueError, match=match):
        pf.simulate(model, 0.01, n_outputs=2, progress=False, state=state, integrator="generalized_alpha", **options)


def test_extrapolate_with_rtol_is_refused(cantilever):
    model, state = cantilever
    with pytest.raises(ValueError, match="error-controlled"):
        pf.simulate(model, 0.01, n_outputs=2, progress=False, state=state, rtol=1e-3, extrapolate=True)


def test_ida_keeps_its_own_rtol(cantilever):
    model, state = cantilever
    res = pf.simulate(model, 0.002, n_outputs=2, progress=False, state=state, integrator="ida", rtol=1e-5)
    assert res.metadata["integrator"] == "ida" and "error_estimate" not in res.stats


def test_a_tolerance_that_needs_a_step_below_min_step_fails_with_where(cantilever):
    model, state = cantilever
    with pytest.raises(pf.ConvergenceError, match="error control failed at t = .*min_step") as err:
        pf.simulate(model, 0.1, n_outputs=2, progress=False, state=state, rtol=1e-4, step=0.02, min_step=1e-2)
    assert 0.0 <= err.value.time < 0.1 and err.value.mass_flow == pytest.approx(FLOW)


def test_extrapolation_falls_back_to_the_controlled_run(limit_cycle, monkeypatch, caplog):
    """A coarse mesh whose run differs from the halved one by more than a discretisation
    error (frames 0.16 rad apart at rtol_mesh 0.18) is not extrapolated: the second-order
    run at rtol is returned (logged), still within 3x of the request."""
    from pipeflex.analysis import transient

    monkeypatch.setattr(transient, "MESH_FACTOR", 0.18 / 1e-5 ** transient.MESH_EXPONENT)  # rtol_mesh 0.18
    monkeypatch.setattr(transient, "MAX_MESH_RTOL", 1.0)
    model, state, ref = limit_cycle
    rtol = 1e-5
    with caplog.at_level("INFO", logger="pipeflex"):
        res = pf.simulate(model, 2.0, n_outputs=2, progress=False, state=state, rtol=rtol)
    assert "extrapolation over the controlled mesh failed" in caplog.text
    assert "extrapolated" not in res.metadata and res.metadata["rtol"] == rtol
    assert abs(res.x[-1, -1, 1] - ref) <= 3.0 * rtol * model.length_scale
