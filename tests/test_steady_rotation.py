"""steady_rotation through the core's static Newton (omega as its border)."""
import numpy as np
import pytest

import pipeflex as pf
from pipeflex.analysis._assembly import residual_and_tangent


def test_omega_balances_the_hinge_and_does_not_depend_on_the_path():
    """Independent checks of the core's omega: the hinge row of the residual (the balance
    of moments about the axis), evaluated by the assembler at the returned rotating state,
    is zero, and the continuation's steps change neither omega nor the shape."""
    model = pf.scenes.sprinkler(EI=100.0)
    s = pf.steady_rotation(model)
    hinge = model.node_dofs(s.hinge_node)[0]
    r, _ = residual_and_tangent(model, s.state, model.load_state(), matrix=False)
    assert abs(r[hinge]) < 1e-9 * model.force_scale()
    for steps in (1, 2, 8):
        other = pf.steady_rotation(model, continuation_steps=steps)
        assert other.omega == pytest.approx(s.omega, rel=1e-10)
        assert np.allclose(other.state.q, s.state.q, rtol=0, atol=1e-10)


def test_iterations_do_not_grow_with_the_mesh():
    """Newton's iterations are the mesh's, not its size's: 8 and 64 elements of the arm
    take as many (within one per continuation step)."""
    coarse = pf.steady_rotation(pf.scenes.sprinkler(EI=100.0, n_elements=8))
    fine = pf.steady_rotation(pf.scenes.sprinkler(EI=100.0, n_elements=64))
    assert fine.iterations <= coarse.iterations + 4
    assert fine.omega == pytest.approx(coarse.omega, rel=1e-2)  # the mesh changes omega by 0.3 %


def test_no_convergence_names_the_step():
    model = pf.scenes.sprinkler(EI=10.0)
    with pytest.raises(pf.ConvergenceError, match=r"flow step 1/4 .*omega = ") as e:
        pf.steady_rotation(model, max_iterations=1)
    assert e.value.mass_flow == pytest.approx(model.mass_flow / 4)
    assert e.value.iteration == 1


def test_a_guess_far_from_the_first_steps_rate_converges():
    """omega_guess is the first flow step's start (a quarter of the flow: about 2.3 rad/s);
    9 rad/s is four times that (the Python loop's damped Newton failed there)."""
    model = pf.scenes.sprinkler(EI=100.0)
    assert pf.steady_rotation(model, omega_guess=9.0).omega == pytest.approx(pf.steady_rotation(model).omega,
                                                                             rel=1e-11)


def test_a_jump_to_another_branch_is_bisected():
    """Seed 004's semicircular pipe of only two elements: in 4 (or 2) equal flow steps
    unchecked Newton lands on other branches of steady states (0.11 and -6.1 rad/s; 6 or
    more steps: 4.92 rad/s, beside the finer meshes' 5.1-5.2). A step whose omega falls more
    than half its prediction away is bisected, so these step counts give the one path. (The
    first step has no prediction to be checked against: in one or two steps, from the rigid
    balance at the full or half flow, Newton still lands elsewhere.)"""
    from pipeflex.seeds.seed004.studies import element_curved_model

    model = element_curved_model(0.9585e9, n_elements=2)
    fine = pf.steady_rotation(model, continuation_steps=16).omega
    for steps in (3, 4, 6):
        assert pf.steady_rotation(model, continuation_steps=steps).omega == pytest.approx(fine, rel=1e-10)
    assert fine == pytest.approx(4.9179, rel=1e-4)


def test_bodies_follow_the_same_continuation():
    """The bodies' and coupled systems' steady rotations run the same flow continuation: a
    failed first step is bisected and named like the elements' (one Newton iteration
    cannot converge)."""
    system, _, _ = pf.scenes.sprinkler_on_hub()
    with pytest.raises(pf.ConvergenceError, match=r"flow step 1/4 .*failed solves") as e:
        pf.steady_rotation(system, max_iterations=1)
    assert e.value.mass_flow == pytest.approx(system.model.mass_flow / 4)
