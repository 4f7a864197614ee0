"""Error-controlled generalised-alpha: ``pf.simulate(model, t_end, rtol=...)``.

Each step's local error estimate (Zienkiewicz & Xie's (beta - 1/6) h^2 (a' - a)) is kept
below (rtol L + atol) h / T, so the estimates of a run add up to at most rtol L + atol.
Checked against converged references computed by the library's fixed-step integrator
(Richardson-extrapolated from two fine steps with a tight Newton tolerance): the error
meets the request, shrinks in proportion to rtol, is below the reported estimate, and the
steps follow the motion (short while a step start of the flow rings, long after). The
same on floating-frame bodies (their rotations counted at the model size)."""
import numpy as np
import pytest

import pipeflex as pf
from pipeflex.multibody import MultibodyBuilder, flexible_body

T_END = 0.5
FLOW = 30.0  # kg/s, above the 4-element cantilever's flutter flow (~25 kg/s): a growing motion


@pytest.fixture(scope="module")
def cantilever():
    """Seed 000's cantilever (4 elements, polar inertia for time integration) with a tip
    force, from its static deflection without flow, the flow switched on at t = 0."""
    sec = pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0, EA=1e5, rotary_inertia=(1e-3, 0.0, 0.0))
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    nodes = b.add_line(n0, (1.0, 0.0, 0.0), 4, sec)
    b.clamp(n0)
    b.add_load(nodes[-1], force=(0.0, 1.5, 0.0))
    model = b.build(mass_flow=FLOW)
    return model, pf.static_equilibrium(model, mass_flow=0.0).state


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
        # the request: within rtol L (the estimates add up to at most it)
        assert err <= rtol * L, (rtol, err)
        # the estimate reported bounds the error and stays within the request
        assert err <= res.stats["error_estimate"] <= rtol * L * (1 + 1e-12)
        assert res.stats["failed_steps"] <= 0.25 * res.stats["steps"]  # steps redone for their error
    # tolerance proportionality: ten times tighter, about ten times smaller (error per unit step)
    assert 3.0 <= errors[1e-3] / errors[1e-4] <= 30.0


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
    assert err <= rtol * system.length_scale, err
    assert err <= res.stats["error_estimate"]


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
        pf.simulate(model, 0.1, n_outputs=2, progress=False, state=state, rtol=1e-12, min_step=1e-5)
    assert 0.0 <= err.value.time < 0.1 and err.value.mass_flow == pytest.approx(FLOW)
