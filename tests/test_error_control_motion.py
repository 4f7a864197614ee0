"""simulate(rtol=): each step's tolerance is rtol max(L, D) + atol, D the motion's size
(the largest node displacement from its reference position) once it outgrows the model
size L; a motion within the model keeps the steps of rtol L."""
import numpy as np
import pytest

import pipeflex as pf
from pipeflex.seeds.seed002 import scenes
from test_error_control import tip_loaded_cantilever

RTOL = 1e-2
# seed 002, Fig. 6: one ANCF element of Model 0 spun up to 10 rad/s diverges, its free node
# 8 km out (1000 L) at 16.33 s; to 16.28 s it reaches 6.4 km
T_DIVERGING = 16.28


@pytest.fixture(scope="module")
def diverging():
    model = scenes.spin_up_beam(reference="ref21", n_elements=1, elastic="0", omega=10.0)

    def run(**accuracy):
        return pf.simulate(model, T_DIVERGING, integrator="generalized_alpha", n_outputs=401, work=False,
                           progress=False, **accuracy)

    return model, run(rtol=RTOL), run(step=1e-4)


def test_a_diverging_motion_keeps_its_steps_and_its_relative_error(diverging):
    model, run, ref = diverging
    L = model.length_scale
    D = np.linalg.norm(ref.x - model.positions, axis=-1).max(axis=-1)  # per output
    assert D.max() > 500.0 * L  # the motion outgrows the model
    # measured: 30451 steps, none below 3.1e-5 s; at a tolerance of rtol L (the node's
    # error in metres whatever its motion) 178225 steps down to 2.3e-6 s
    assert run.stats["steps"] < 60000
    assert run.stats["smallest_step"] > 1e-5
    # the error relative to the motion (measured 6.1e-4; the fine step's own error ~2e-7 of it)
    err = np.linalg.norm(run.x - ref.x, axis=-1).max(axis=-1)
    assert np.all(err <= 3.0 * RTOL * np.maximum(L, D))


def test_a_diverging_run_fails_where_the_fine_step_does(diverging):
    model, _, _ = diverging
    with pytest.raises(pf.ConvergenceError, match="diverged") as fine:
        pf.simulate(model, 17.0, integrator="generalized_alpha", step=1e-4, n_outputs=2, work=False, progress=False)
    with pytest.raises(pf.ConvergenceError, match="diverged") as controlled:
        pf.simulate(model, 17.0, rtol=RTOL, n_outputs=2, work=False, progress=False)
    assert controlled.value.time == pytest.approx(fine.value.time, abs=0.01)


def test_a_motion_within_the_model_takes_the_steps_of_rtol_L():
    # the flutter of benchmarks/bench_limit_cycle.py (L = 1 m, the tip below 0.5 m): its
    # run at rtol 1e-2, pinned (the control per step; the motion_rate leaves it bit for bit)
    model, state = tip_loaded_cantilever(8)
    run = pf.simulate(model, 2.0, state=state, n_outputs=101, progress=False, integrator="generalized_alpha",
                      rtol=RTOL)
    D = np.linalg.norm(run.x - model.positions, axis=-1).max()
    assert D < model.length_scale
    assert run.stats["steps"] == 236
    assert float(run.x[-1, -1, 1]) == pytest.approx(-0.3896806630547417, rel=1e-9)
