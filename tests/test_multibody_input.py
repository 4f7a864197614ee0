"""Bad input to the floating-frame (seed 004) API: a clear ValueError naming the
parameter and the rule, never a crash, a hang or a silent NaN."""
import dataclasses

import numpy as np
import pytest

import pipeflex as pf
from pipeflex import ConvergenceError, scenes
from pipeflex.seeds.seed004.studies import final_angular_velocity
from pipeflex.multibody import MultibodyBuilder, flexible_body, simulate, static_equilibrium


@pytest.fixture(scope="module")
def cantilever():
    return scenes.ffrf_cantilever_pipe(n_bodies=2, elements_per_body=4)


@pytest.mark.parametrize("kwargs, match", [
    (dict(n_bodies=float("nan")), "n_bodies must be finite"),
    (dict(n_bodies=float("inf")), "n_bodies must be finite"),
    (dict(n_bodies=0), "n_bodies must be a positive integer"),
    (dict(n_bodies=2, elements_per_body=3), "elements_per_body must be even"),
    (dict(n_bodies=2, internal_modes=-1), "internal_modes must be a non-negative integer"),
    (dict(n_bodies=2, internal_modes=float("nan")), "internal_modes must be finite"),
    (dict(n_bodies=2, tip_force=float("nan")), "tip_force must be finite"),
    (dict(n_bodies="2"), "n_bodies must be a real number"),
])
def test_cantilever_scene_rejects(kwargs, match):
    with pytest.raises(ValueError, match=match):
        scenes.ffrf_cantilever_pipe(**kwargs)


@pytest.mark.parametrize("kwargs, match", [
    (dict(E=-1.0), "E must be > 0"),
    (dict(E="1e9"), "E must be a real number"),
    (dict(E=1e9, n_bodies=1), "n_bodies must be >= 2"),
    (dict(E=1e9, flow_speed=float("nan")), "flow_speed must be finite"),
])
def test_curved_scene_rejects(kwargs, match):
    with pytest.raises(ValueError, match=match):
        scenes.ffrf_curved_pipe(**kwargs)


def test_node_and_body_indices_are_checked(cantilever):
    """A node or body index out of range, or a state of the wrong size, is a ValueError
    naming the rule (the C++ core would read out of bounds)."""
    st = cantilever.initial_state()
    with pytest.raises(ValueError, match="node must be an index 0..4"):
        cantilever.node_kinematics(st, 0, 10**5)
    with pytest.raises(ValueError, match=r"body must be in \[0, 2\)"):
        cantilever.node_position(st, 9, 0)
    with pytest.raises(ValueError, match="body must be a non-negative integer"):
        cantilever.body_slice(-1)
    short = dataclasses.replace(st, eta=st.eta[:-3])
    with pytest.raises(ValueError, match="n_coordinates"):
        cantilever.core.node(short.r, short.R, short.eta, 0, 0)
    with pytest.raises(ValueError, match=r"state.eta must have shape"):
        cantilever.energy(short)


def test_states_are_checked(cantilever):
    st = cantilever.initial_state()
    bad = st.copy()
    bad.eta[7] = np.nan
    with pytest.raises(ValueError, match="state.eta must be finite"):
        simulate(cantilever, 0.01, step=1e-3, state=bad)
    bad = st.copy()
    bad.R[0] = 2.0 * bad.R[0]
    with pytest.raises(ValueError, match="state.R must hold rotation matrices"):
        static_equilibrium(cantilever, state=bad)


def test_static_and_simulate_options(cantilever):
    with pytest.raises(ValueError, match="max_iterations must be a positive integer"):
        static_equilibrium(cantilever, max_iterations=0)
    with pytest.raises(ValueError, match="t must be finite"):
        static_equilibrium(cantilever, t=float("nan"))
    with pytest.raises(ValueError, match="steps to t_end"):  # would run for days inside C++
        simulate(cantilever, 1e6, step=1e-9)
    res = simulate(cantilever, 0.01, step=3e-3, n_outputs=2)
    assert res.stats["step"] == pytest.approx(0.01 / 4)  # the step actually used


def test_joint_to_ground_with_a_node_b():
    body = flexible_body(length=0.5, n_elements=4, section=pf.PipeSection(EI=10.0, pipe_mass=8.0))
    b = MultibodyBuilder()
    j = b.add_body(body, position=(0.25, 0.0, 0.0))
    with pytest.raises(ValueError, match="node_b = 'end' given without body_b"):
        b.hinge(j, "start", (0.0, 0.0, 1.0), node_b="end")


def test_critical_flow_refuses_mechanisms():
    """Seed 004's curved pipe spins freely on its hinge: no equilibrium to lose (the
    tip-loaded cantilever's critical flow: test_ffrf_loaded_flutter.py)."""
    with pytest.raises(ValueError, match="mechanism"):
        pf.critical_mass_flow(scenes.ffrf_curved_pipe(E=9.585e9, n_bodies=2, elements_per_body=4))


def test_final_angular_velocity_window():
    t = np.linspace(0.0, 1.0, 11)
    assert final_angular_velocity(t, -2.0 * np.ones(11), window=0.25) == 2.0
    for window in (-1.0, float("nan")):
        with pytest.raises(ValueError, match="window"):
            final_angular_velocity(t, np.ones(11), window=window)
    with pytest.raises(ValueError, match="equal-length"):
        final_angular_velocity(t, np.ones(5))


def test_a_failed_run_says_when(cantilever):
    """ConvergenceError.time: the simulated time of the failure, read by until_failure."""
    loaded = scenes.ffrf_cantilever_pipe(n_bodies=2, elements_per_body=4, tip_force=1.5)
    # one iteration cannot show 1e-15: the step is halved to 1e-12 s, then it gives up
    with pytest.raises(ConvergenceError, match=r"at t = [0-9.e-]+ s: Newton did not converge") as err:
        simulate(loaded, 0.01, step=1e-3, max_newton=1, newton_tol=1e-15, mass_flow=30.0)
    assert 0.0 <= err.value.time < 1e-3
    assert err.value.iteration is not None and err.value.residual is not None
