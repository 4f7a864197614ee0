"""The one system object: every formulation (element model, bodies, coupled) builds a
``_core.System``, and each analysis is bound once over it (static equilibrium, linear
matrices, generalised-alpha, the flow map with its tangent)."""

import numpy as np
import pytest

import pipeflex as pf
from pipeflex import _core
from pipeflex.seeds.seed004.coupled_scenes import sprinkler_on_hub


@pytest.fixture(scope="module")
def element():
    return pf.scenes.cantilever_pipe(n_elements=3, polar_inertia=1e-4)


@pytest.fixture(scope="module")
def bodies():
    return pf.scenes.ffrf_cantilever_pipe(n_bodies=2, elements_per_body=4, tip_force=1.5)


@pytest.fixture(scope="module")
def coupled():
    return sprinkler_on_hub(n_elements=4, mass_flow=10.0)[0]


def test_every_formulation_builds_one_system_type(element, bodies, coupled):
    systems = [element.system(), bodies.system(), coupled.system()]
    assert all(type(s) is _core.System for s in systems)
    assert [s.n_coordinates for s in systems] == [element.n_dofs, bodies.n_coordinates, coupled.n_coordinates]
    assert [s.n_constraints for s in systems] == [0, bodies.n_constraints, coupled.n_constraints]
    assert systems[0].body_state is None and systems[0].coupling_multipliers is None
    assert systems[1].body_state is not None and systems[1].coupling_multipliers is None
    assert systems[2].coupling_multipliers is not None


def test_each_analysis_is_bound_once_and_the_per_formulation_entry_points_are_gone():
    for name in ("static_equilibrium", "linear_matrices", "integrate", "flow_map"):
        assert callable(getattr(_core, name))
    for gone in ("static_newton", "coupled_static", "coupled_linear_matrices", "element_linear_matrices",
                 "integrate_coupled", "integrate_generalized_alpha", "integrate_ida", "generalized_alpha_flow_map"):
        assert not hasattr(_core, gone), gone
    for gone in ("static_newton", "linear_matrices", "integrate"):
        assert not hasattr(_core.MultibodySystemCore, gone), gone


def test_the_model_length_scale_is_defined_once(element, bodies, coupled):
    """One definition in the core: the largest extent of the reference positions, at least
    1 mm; a coupled system's is the larger of its parts'."""
    assert element.length_scale == pytest.approx(float(np.ptp(element.positions, axis=0).max()), rel=1e-15)
    assert element.system().length_scale == element.length_scale
    tiny = pf.ModelBuilder()
    a = tiny.add_node((0.0, 0.0, 0.0))
    tiny.add_line(a, (1e-4, 0.0, 0.0), 2, pf.PipeSection(EI=1e-9, EA=1e-3, GJ=1e-9, pipe_mass=1e-6))
    tiny.clamp(a)
    assert tiny.build().length_scale == 1e-3
    assert coupled.system().length_scale == max(coupled.model.length_scale, coupled.bodies.length_scale)


def test_ida_runs_on_a_system_with_joints(bodies):
    """The one IDA on any system's equations (the stabilised index-2 form with joints)."""
    out = _core.integrate(bodies.system(), _core.TimeTable(), _core.TimeTable(), [0.0, 1e-3],
                          _core.TransientOptions(), None, "ida")
    assert out["steps"] > 0 and out["jacobians"] > 0 and out["t"][-1] == 1e-3


def test_one_counter_vocabulary_for_every_formulation(element, bodies, coupled):
    """A transient's stats have the same names whatever the system (results.COUNTERS)."""
    from pipeflex.results import COUNTERS

    runs = [pf.simulate(element, 0.01, step=1e-3, n_outputs=3, progress=False),
            pf.multibody.simulate(bodies, 0.01, step=1e-3, n_outputs=3),
            pf.coupled.simulate(coupled, 0.01, step=1e-3, n_outputs=3, progress=False)]
    for r in runs:
        assert set(COUNTERS) <= set(r.stats), sorted(r.stats)
        assert r.stats["steps"] >= 10 and r.stats["newton_iterations"] >= r.stats["steps"]


def test_coupled_transient_reports_the_bodies_constraint_drift(coupled):
    r = pf.coupled.simulate(coupled, 0.02, step=1e-3, n_outputs=3, progress=False)
    assert np.all(np.isfinite(r.bodies.drift)) and r.bodies.drift.max() < 1e-3


def test_flow_map_tangent_equals_central_differences():
    """The flow map bound once over the system: its tangent-linear map against central
    differences of the flow map (seed 000's Fig. 3 cantilever in 3D at 30 kg/s, in the
    chart of its static equilibrium; tests/test_periodic.py checks the planar one's
    monodromy)."""
    from pipeflex.seeds.seed000.limit_cycle import limit_cycle_model

    element, _ = limit_cycle_model(n_elements=3, tip_force=1.5, planar=False, EA=1e5)
    rng = np.random.default_rng(7)
    opt = _core.TransientOptions()
    opt.newton_tol, opt.max_newton = 1e-14, 30
    mdot = element.mass_flow
    base = pf.static_equilibrium(element).state.to_core(element)
    n = element.n_dofs

    def flow(z, v, sens=False):
        return _core.flow_map(element.system(base.copy(), mass_flow=mdot), mdot, z, v, 0.02, 20, sens, opt)

    z0, v0 = 1e-4 * rng.standard_normal(n), 1e-2 * rng.standard_normal(n)
    out = flow(z0, v0, True)
    D = rng.standard_normal((2 * n, 4))
    got = out["tangent"].apply(D)
    eps = 1e-6
    fd = np.zeros_like(got)
    for j in range(D.shape[1]):
        hi, lo = flow(z0 + eps * D[:n, j], v0 + eps * D[n:, j]), flow(z0 - eps * D[:n, j], v0 - eps * D[n:, j])
        fd[:, j] = np.r_[hi["z"][-1] - lo["z"][-1], hi["v"] - lo["v"]] / (2 * eps)
    assert np.abs(got - fd).max() <= 1e-6 * np.abs(fd).max()
    assert np.abs(out["monodromy"] @ D - got).max() <= 1e-10 * np.abs(got).max()


@pytest.mark.parametrize("kind", ["bodies", "coupled"])
def test_flow_maps_of_floating_frames_run(kind, bodies, coupled):
    """Systems with floating frames have flow maps too (re-based every step; their tangent
    is checked in tests/test_body_orbits.py): from rest at zero flow the state stays."""
    system = bodies.system() if kind == "bodies" else coupled.system()
    n = system.n_coordinates
    out = _core.flow_map(system, 0.0, np.zeros(n), np.zeros(n), 0.01, 10, False, _core.TransientOptions())
    assert out["z"].shape == (11, n) and np.all(np.isfinite(out["z"]))
