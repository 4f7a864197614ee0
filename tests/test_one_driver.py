"""One driver per analysis for every formulation (element model, bodies, coupled system):
one result type per analysis, one default per option (pipeflex._options)."""

import numpy as np
import pytest

import pipeflex as pf
from pipeflex import _options
from pipeflex.seeds.seed004.coupled_scenes import sprinkler_on_hub

from test_any_system import on_stiff_hub


# the three formulations' small scenes (fixtures element, bodies, coupled)
from test_system import bodies, coupled, element  # noqa: F401


def run(system, **options):
    return pf.simulate(system, 0.004, step=1e-3, n_outputs=3, progress=False, mass_flow=5.0, **options)


def test_simulate_returns_one_result_type_with_the_formulations_parts(element, bodies, coupled):
    alone, body, both = run(element), run(bodies), run(coupled)
    assert all(type(r) is pf.TransientResult for r in (alone, body, both))
    assert alone.bodies is None and alone.coupling_forces is None and alone.elements is alone
    assert isinstance(alone.final_state, pf.State)
    # bodies alone: no element arrays; the bodies' accessors on the result itself
    assert body.x is None and body.elements is None and isinstance(body.final_state, pf.multibody.MultibodyState)
    assert body.node_position(1, "end").shape == (3, 3)
    np.testing.assert_array_equal(body.drift, body.bodies.drift)
    assert body.final_state.t == pytest.approx(0.004)
    with pytest.raises(AttributeError):
        body.no_such_field
    # coupled: both parts and the couplings' forces; .elements carries the element model's end state
    assert both.x.shape[0] == 3 and both.bodies.r.shape[0] == 3 and both.coupling_forces.shape[0] == 3
    assert isinstance(both.elements.final_state, pf.State) and both.elements.bodies is None
    assert isinstance(both.final_state, pf.coupled.CoupledState)


def test_the_aliases_run_the_same_driver(bodies, coupled):
    times = dict(step=1e-3, n_outputs=5)
    a = pf.multibody.simulate(bodies, 0.004, mass_flow=5.0, **times)
    b = pf.simulate(bodies, 0.004, mass_flow=5.0, integrator="generalized_alpha", **times)
    np.testing.assert_array_equal(a.bodies.eta, b.bodies.eta)
    c = pf.coupled.simulate(coupled, 0.004, progress=False, **times)
    d = pf.simulate(coupled, 0.004, progress=False, **times)
    np.testing.assert_array_equal(c.x, d.x)
    np.testing.assert_array_equal(c.coupling_forces, d.coupling_forces)


@pytest.mark.parametrize("which", ["element", "bodies", "coupled"])
def test_one_default_per_option_for_every_formulation(which, request):
    """The defaults are pipeflex._options' for every formulation: a run without options
    equals one with them given, and differs from one with another rho_inf (so the
    comparison can fail)."""
    system = pf.scenes.sprinkler(EI=100.0) if which == "element" else request.getfixturevalue(which)  # (it moves)
    plain = run(system)
    given = run(system, rho_inf=_options.RHO_INF, newton_tol=_options.NEWTON_TOL, max_newton=_options.MAX_NEWTON)
    other = run(system, rho_inf=0.5)
    def pick(r):
        return r.x if r.x is not None else r.bodies.eta
    np.testing.assert_array_equal(pick(plain), pick(given))
    assert not np.array_equal(pick(plain), pick(other))


def test_linearize_and_steady_rotation_return_one_type(element, bodies):
    for system in (element, bodies, on_stiff_hub()):  # (about their static equilibria: no free hinge)
        lin = pf.linearize(system, mass_flow=1.0)
        assert type(lin) is pf.Linearization and lin.n_dofs == lin.K.shape[0] == system.n_dofs
        assert (lin.basis is None) == (system is element)
    assert pf.multibody.MultibodyLinearization is pf.Linearization is pf.coupled.CoupledLinearization
    spun = pf.steady_rotation(sprinkler_on_hub()[0])
    alone = pf.steady_rotation(pf.scenes.sprinkler(EI=100.0))
    assert type(spun) is type(alone) is pf.SteadyRotation is pf.SystemSteadyRotation
    assert spun.omega == pytest.approx(alone.omega, rel=1e-6)
    assert alone.body_state is None and alone.hinge == f"element node {alone.hinge_node}"


def test_auto_step_of_a_free_hinge_needs_no_static_solve(coupled):
    """"auto" chooses the step from the linearisation about the run's start: a coupled arm
    on a free hinge (no static equilibrium without the spin) is stepped, not refused."""
    res = pf.simulate(coupled, 0.01, n_outputs=3, progress=False)
    assert res.metadata["requested"] == "auto" and res.metadata["integrator"] == "generalized_alpha"
    assert 0.0 < res.metadata["step"] <= 0.005
