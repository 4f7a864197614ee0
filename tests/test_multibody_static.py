"""The multibody statics' mechanism machinery (the core's one frame Gram matrix), the step
acceptance test (the floating frame's small elastic deformation), the absolute floor of the
driven check and the one Newton iteration default."""
import inspect

import numpy as np
import pytest

import pipeflex as pf
from pipeflex import coupled
from pipeflex.analysis import static as element_static
from pipeflex.multibody import MultibodyBuilder, analysis, flexible_body, static_equilibrium

L, EI = 0.8, 50.0  # m, N m^2


def _body(EI=EI, length=L, mu=2.0):
    return flexible_body(length=length, n_elements=4, section=pf.PipeSection(EI=EI, pipe_mass=mu))


def _one_body(support, force=(0.0, 0.0, 0.0)):
    """One body along x, its start fixed, on a ground hinge about z or on a spherical joint;
    ``force`` [N] at its end."""
    b = MultibodyBuilder()
    j = b.add_body(_body(), position=(L / 2, 0.0, 0.0))
    if support == "fix":
        b.fix(j, "start")
    elif support == "hinge":
        b.hinge(j, "start", (0.0, 0.0, 1.0))
    else:
        b.spherical(j, "start")
    b.add_load(j, "end", force=force)
    return b.build()


@pytest.mark.parametrize("support, count", [("fix", 0), ("hinge", 1), ("spherical", 3)])
def test_free_motions_count_the_rigid_motions_the_joints_leave_free(support, count):
    """The core's frame Gram matrix (FrameGram): |S| - rank C_S of the frames' constraint
    columns, the mechanism test of the statics."""
    s = _one_body(support)
    st = s.initial_state()
    assert s.core.free_motions(st.r, st.R, st.eta, st.lam, 0.0, 0.0)["count"] == count


def test_free_motion_force_is_the_projection_on_the_hinge_rotation():
    """A force F along y at the end of a body on a hinge about z: the free motion turns the
    frame (at the body's middle) about the hinge, v = (0, L/2, 0, 0, 0, 1) in the frame's
    coordinates; the force's projection on it (the metric of the penalty, uniform in the
    frame's coordinates) is v (v . f) / (v . v), v . f = F L/2 + F L/2 (the force and its
    moment about the frame), with the residual's sign (internal minus applied forces);
    rotations reported divided by the length scale (L here). A clamped body: nothing free."""
    F = 3.0
    s = _one_body("hinge", (0.0, F, 0.0))
    assert s.length_scale == pytest.approx(L)
    st = s.initial_state()
    g = s.core.free_motions(st.r, st.R, st.eta, st.lam, 0.0, 0.0)["force"]
    v = np.array([0.0, L / 2, 0.0, 0.0, 0.0, 1.0])
    expected = v * (F * L) / (v @ v)
    expected[3:] /= L
    np.testing.assert_allclose(-g[0], expected, rtol=1e-10, atol=1e-14 * F)
    s = _one_body("fix", (0.0, F, 0.0))
    st = s.initial_state()
    assert np.abs(s.core.free_motions(st.r, st.R, st.eta, st.lam, 0.0, 0.0)["force"]).max() < 1e-12 * F


def test_static_newton_reports_the_free_motions_of_its_end_state():
    """The static solve with the mechanism penalty reports the free motions of its converged
    state (the Python driven check reads them); they agree with a fresh evaluation."""
    s = _one_body("hinge", (0.0, 0.0, -2.0))  # out of the hinge's plane: not driven
    st = s.initial_state()
    system = s.system(st)
    out = pf._core.static_equilibrium(system, 0.0, 1.0, 1e-10, 30, mechanism=True)
    assert out["converged"] and out["free"]["count"] == 1
    r, R, eta, _, _, lam, _ = system.body_state
    fresh = s.core.free_motions(r, R, eta, lam, 0.0, 0.0)
    assert np.abs(out["free"]["force"]).max() < 1e-10 and np.abs(fresh["force"]).max() < 1e-10
    assert out["free"]["reaction"] == pytest.approx(fresh["reaction"], rel=1e-6)
    assert fresh["reaction"] == pytest.approx(2.0, rel=1e-6)  # the hinge's force along z (its moment: 2 N L/2)


@pytest.mark.parametrize("F", [1e-307, 1e-200, 1e-30, 1e-17])
def test_negligible_load_on_a_hinge_converges(F):
    """A load that turns a free hinge but would bend the body by less than FORCE_FLOOR
    (1e3 eps) of its length (F < 1e3 eps EI / L^2 = 1.7e-11 N) is round-off: the hinge keeps
    its assembly angle (the relative rule alone, 0.8 of the applied level, would call
    1e-307..1e-17 N a load driving the mechanism)."""
    s = _one_body("hinge", (0.0, F, 0.0))
    res = static_equilibrium(s)
    np.testing.assert_array_equal(res.state.R[0], np.eye(3))


def test_small_but_real_load_on_a_hinge_still_raises():
    """1e-9 N turning the hinge is above the floor (1.7e-11 N): driven."""
    with pytest.raises(pf.SingularMatrixError, match="the loads drive a mechanism"):
        static_equilibrium(_one_body("hinge", (0.0, 1e-9, 0.0)))


def test_soft_cantilever_stretched_beyond_the_floating_frame_is_refused():
    """A clamped body under a tip force of 4000 N (64 EI / L^2, a linear tip deflection of
    17 body lengths): Newton converges at the full load (30 iterations) to a root of the
    floating-frame equations whose elastic deformation reaches 1.06 body lengths in the
    body's frame. The step acceptance test rejects every step beyond DEFORMATION_LIMIT
    (0.5) of the length; the halved steps stop at load factor 0.2 (0.51): a
    ConvergenceError that names the body and the assumption. A tenth of the force (0.28 of
    the length) is accepted."""
    with pytest.raises(pf.ConvergenceError, match=r"stretches body 0 elastically by [\d.]+ of its length .*"
                                                  r"small elastic deformation assumption is violated"):
        static_equilibrium(_one_body("fix", (0.0, 4000.0, 0.0)))
    s = _one_body("fix", (0.0, 400.0, 0.0))
    d, body = analysis._largest_deformation(s, static_equilibrium(s).state)
    assert 0.2 < d < analysis.DEFORMATION_LIMIT and body == 0


def test_soft_pipe_under_its_weight_from_the_fuzz_is_refused():
    """The fuzz's soft pipe (seed 0, multibody case 107: EI 0.01 N m^2, 2 kg/m, 1 m, clamped,
    gravity 20 m/s^2 across it): halved steps without the acceptance test converge after
    536 iterations to a state stretched 31.8 times the body's length (residual 5e-13 N);
    it is refused, naming the body."""
    b = MultibodyBuilder()
    j = b.add_body(flexible_body(length=1.0, n_elements=6, section=pf.PipeSection(EI=0.01, pipe_mass=1.0,
                                                                                   fluid_mass=1.0)),
                   position=(0.5, 0.0, 0.0))
    b.fix(j, "start")
    b.set_gravity((0.0, 20.0, 0.0))
    with pytest.raises(pf.ConvergenceError, match="stretches body 0 elastically"):
        static_equilibrium(b.build())


def test_one_max_iterations_default_passed_through():
    """30 iterations per load step by default on every static path (the multibody
    mechanisms' penalised Newton converges linearly in a free motion stiffer than the
    penalty; 25 cut some of them short), and pf.static_equilibrium passes the value on
    unchanged to a multibody system (max_iterations=2 stops after 2)."""
    for f in (element_static.static_equilibrium, coupled.static_equilibrium, static_equilibrium):
        assert inspect.signature(f).parameters["max_iterations"].default == 30
    s = _one_body("fix", (0.0, 40.0, 0.0))  # 4 iterations from the assembly
    for solve in (static_equilibrium, pf.static_equilibrium):
        with pytest.raises(pf.ConvergenceError, match="after 2 iterations"):
            solve(s, max_iterations=2, max_bisections=0, path="load")
        assert solve(s, max_iterations=4, max_bisections=0).iterations == 4


def test_failure_after_a_rejected_step_names_the_rejection():
    """A load stepping that fails by Newton after a step was rejected by the acceptance test
    (the fuzz's seed 0, case 268: a hinged two-body chain, the step to 0.5 stretched a body
    2.17 times its length, the halved step to 0.16 diverged) says so."""
    out = dict(singular=False, diverged=True, correction=106.0, iterations=3, residual=1.0)
    e = analysis._not_converged(0.16, out, None, 30, 0.0, (0.5, 2.17, 0))
    assert isinstance(e, pf.ConvergenceError)
    assert str(e) == ("static solve did not converge at load factor 0.16 (a correction beyond the model; last increment "
                      "106); the step to load factor 0.5 was rejected: it stretched body 0 elastically by 2.17 of its "
                      "length, more than DEFORMATION_LIMIT = 0.5 (the floating frame's small elastic deformation)")
