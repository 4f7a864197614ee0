"""Seed 000, section 3.3: the semicircular rotating pipe (garden sprinkler)."""
import numpy as np
import pytest

import pipeflex as pf
from pipeflex.convergence import richardson
from pipeflex.seeds.seed000 import references as ref000, validation as val000
from conftest import FAST


@pytest.mark.parametrize("EI", [10.0, 100.0, 1000.0, "rigid"])
def test_final_angular_velocity_by_direct_solver(EI):
    """Seed 000 sec. 3.3: 5.218466, 9.009825, 9.882486 and 10.0 rad/s."""
    model = pf.scenes.sprinkler(EI=1.0, rigid=True) if EI == "rigid" else pf.scenes.sprinkler(EI=EI)
    s = pf.steady_rotation(model)
    assert s.omega == pytest.approx(ref000.SPRINKLER[EI], rel=val000.TOL_SPRINKLER)
    assert s.residual < 1e-6 * model.force_scale()


def test_steady_state_is_a_solution_of_the_dynamics():
    """The rotating deformed state has zero residual with its own velocities and
    accelerations, and a flexible pipe straightens (its tip moves outward)."""
    m = pf.scenes.sprinkler(EI=100.0)
    s = pf.steady_rotation(m)
    tip0 = np.linalg.norm(m.positions[-1])
    tip = np.linalg.norm(s.state.q[6 * (m.n_nodes - 1): 6 * (m.n_nodes - 1) + 3])
    assert tip > tip0  # straightened by the flow
    r, _ = pf.analysis._assembly.residual_and_tangent(m, s.state, m.load_state(), matrix=False)
    assert np.linalg.norm(r) < 1e-8 * m.force_scale()


def test_transient_converges_to_the_direct_solution():
    """A long generalised-alpha transient settles at the direct solver's speed; its
    O(h^2) error is removed by Richardson extrapolation over two step sizes."""
    EI = 1000.0 if FAST else 100.0
    m = pf.scenes.sprinkler(EI=EI)
    direct = pf.steady_rotation(m).omega
    t_end = 3.0 if FAST else 8.0
    w = [pf.simulate(m, t_end, integrator="generalized_alpha", step=h, n_outputs=4, progress=False).omega[-1, 0, 2]
         for h in (1e-3, 5e-4)]
    assert abs(w[1] - direct) < 1e-5 * direct
    assert richardson(w[0], w[1], order=2) == pytest.approx(direct, rel=2e-7)


def test_reverse_sprinkler_hardly_moves():
    """Sucking from a still reservoir: 'almost no motion occurs' (seed 000, sec. 3.3)."""
    fwd = pf.simulate(pf.scenes.sprinkler(EI=100.0), 1.0, integrator="generalized_alpha", step=1e-3,
                      n_outputs=21, progress=False)
    rev = pf.simulate(pf.scenes.sprinkler(EI=100.0, suck=True), 1.0, integrator="generalized_alpha", step=1e-3,
                      n_outputs=21, progress=False)
    assert np.abs(fwd.omega[:, 0, 2]).max() > 8.0
    assert np.abs(rev.omega[:, 0, 2]).max() < 1e-3 * np.abs(fwd.omega[:, 0, 2]).max()
    assert abs(rev.angle(0)[-1]) < 1e-3


def test_steady_rotation_needs_one_hinge():
    with pytest.raises(ValueError, match="exactly one hinge"):
        pf.steady_rotation(pf.scenes.cantilever_pipe(n_elements=2))


def test_steady_rotation_sparse_and_dense_solves_agree(monkeypatch):
    """steady_rotation solves its Newton systems densely below DENSE_BELOW coordinates and
    sparsely above (linear in the model size): both give the same rotation rate and shape."""
    from pipeflex.analysis import steady

    model = pf.scenes.sprinkler(EI=100.0, n_elements=16)
    dense = pf.steady_rotation(model)
    monkeypatch.setattr(steady, "DENSE_BELOW", 0)
    sparse = pf.steady_rotation(model)
    assert sparse.omega == pytest.approx(dense.omega, rel=1e-11)
    assert np.allclose(sparse.state.q, dense.state.q, rtol=0, atol=1e-11)


def test_steady_rotation_accepts_round_off_stall():
    """A tolerance below round-off (1e-17) is met as the static solvers meet it: the
    correction stops halving within 1e3 tolerances (the core's static_newton), rather than
    omega's last digits wandering (which left the 4096-element sprinkler unconverged)."""
    model = pf.scenes.sprinkler(EI=100.0)
    usual = pf.steady_rotation(model)
    strict = pf.steady_rotation(model, tol=1e-17)
    assert strict.omega == pytest.approx(usual.omega, rel=1e-12)
