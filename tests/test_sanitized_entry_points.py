"""Small runs through the C++ entry points that the rest of the sanitizer's test selection
(tools/sanitize.sh) does not reach: the coupled element + body linearisation
(``_core.linear_matrices`` of a coupled system), the steady rotation
(``_core.steady_rotation``) of a coupled system and of bodies alone,
and the bindings that serve tests, benchmarks and helpers (the generic linearisation with
its differences, the fixed-pattern LU, the kernel timer, an FFRF body's forces, a time
table, per-node bases, the ANCF element's nodes and triad). Each checks a property of its
result, so it also guards the numbers, not only the memory.
tests/test_sanitize_coverage.py checks that the selection calls every bound function."""
import numpy as np
import pytest

import pipeflex as pf
from pipeflex import _core, scenes
from pipeflex.analysis import constrained
from pipeflex.multibody import MultibodyBuilder, flexible_body
from pipeflex.rotation import planar_triad
from pipeflex.state import as_core

from helpers import l_sprinkler

SEC = pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0, EA=1e5, rotary_inertia=(1e-3, 1e-3, 1e-3))


def arm_on_stiff_hub(mass_flow):
    """A floating 1 m arm (4 elements) rigidly joined to a short stiff body clamped to the
    ground: a CoupledSystem that behaves as the clamped arm."""
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    b.add_line(n0, (1.0, 0.0, 0.0), 4, SEC)
    arm = b.build(mass_flow=mass_flow, floating=True)
    mu = 3 * 10.0 / 0.2**3
    hub = pf.PipeSection(EI=1e6 * mu, pipe_mass=mu, rotary_inertia=(1.0, 1.0, 1.0))
    mb = MultibodyBuilder()
    j = mb.add_body(flexible_body(length=0.2, n_elements=2, section=hub), position=(-0.1, 0.0, 0.0))
    mb.fix(j, "start")
    cs = pf.CoupledSystem(arm, mb.build())
    cs.rigid(n0, j, "end")
    return cs


def test_coupled_linearization_without_flow_is_symmetric_and_stable():
    lin = pf.linearize(arm_on_stiff_hub(5.0), mass_flow=0.0)
    dense = [m.toarray() if hasattr(m, "toarray") else np.asarray(m) for m in (lin.M, lin.C, lin.K)]
    assert all(np.isfinite(m).all() for m in dense)
    assert abs(lin.M - lin.M.T).max() <= 1e-12 * abs(lin.M).max()
    assert abs(lin.K - lin.K.T).max() <= 1e-9 * abs(lin.K).max()
    assert abs(lin.C).max() <= 1e-12 * abs(lin.K).max()
    assert pf.stability(pf.eigenvalues(lin)) == "stable"


def test_coupled_steady_rotation_turns_as_the_element_sprinkler():
    """The arm clamped to a hub body hinged to the ground turns as the element sprinkler
    hinged itself (the hub's inertia does not enter a steady rotation)."""
    alone = pf.steady_rotation(scenes.sprinkler(EI=100.0, n_elements=4))
    system, _, _ = scenes.sprinkler_on_hub(hub_inertia=0.01, n_elements=4)
    got = pf.steady_rotation(system)
    assert isinstance(got, pf.SystemSteadyRotation)
    assert got.omega == pytest.approx(alone.omega, rel=1e-8)
    assert got.residual < 1e-6 * 100.0


def test_bodies_steady_rotation_of_an_l_shaped_sprinkler():
    """Two bodies (a standing one and an arm), rigidly joined, hinged to the ground about
    z at the inlet: the flow turns them at a finite positive rate, the axis is z."""
    got = pf.steady_rotation(l_sprinkler(100.0))  # 4 elements a body
    assert np.isfinite(got.omega) and abs(got.omega) > 0.0
    np.testing.assert_allclose(np.abs(got.axis), [0.0, 0.0, 1.0], atol=1e-12)


def test_generic_linearization_agrees_with_its_differences():
    """_core.linear_matrices on an element model's system: its K by the generic route,
    against its own central differences (relative 1e-6: the differences' truncation)."""
    model = scenes.cantilever_pipe(n_elements=2)
    st = pf.static_equilibrium(model)
    out = _core.linear_matrices(model.system(as_core(model, st.state), mass_flow=1.0), 1.0, 1e-6)
    K = constrained.from_core(out)[0].toarray()
    assert np.abs(K - out["differences"]).max() <= 1e-6 * np.abs(K).max()


def test_fixed_pattern_lu_solves_a_banded_system():
    rng = np.random.default_rng(3)
    n = 20
    rows, cols = np.nonzero(np.abs(np.subtract.outer(np.arange(n), np.arange(n))) <= 2)
    vals = rng.standard_normal(rows.size) + 10.0 * (rows == cols)
    A = np.zeros((n, n))
    A[rows, cols] = vals
    b = rng.standard_normal(n)
    for band_first in (True, False):
        storage, ok, x = _core._fixed_pattern_lu(n, rows.tolist(), cols.tolist(), vals.tolist(), b, 100, band_first)
        assert ok and storage in ("dense", "band", "sparse")
        np.testing.assert_allclose(A @ x, b, rtol=0, atol=1e-12 * np.abs(b).max())


def test_kernel_timer_runs_every_kernel():
    sec = pf.PipeSection(EI=7.0, EA=3e3, GJ=5.0, pipe_mass=1.3, fluid_mass=0.7, rotary_inertia=(0.02, 0.01, 0.015))
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    b.add_line(n0, (1.0, 0.0, 0.0), 1, sec)
    b.clamp(n0)
    model = b.build()
    q = np.concatenate([model.positions[0], np.zeros(3), model.positions[1], np.zeros(3)])
    load = _core.LoadState()
    load.mass_flow = 2.5
    seconds = _core._bench_pipe_kernels(model.core.pipe(0), np.eye(3), np.eye(3), load, q, np.zeros(12),
                                        np.zeros(12), 3)
    assert {"residual", "tangent", "tangent_ad", "mass_matrix", "fluid_forces"} <= set(seconds)
    assert all(np.isfinite(t) and t >= 0.0 for t in seconds.values())


def test_ffrf_body_at_rest_carries_its_weight():
    """FfrfBodyData.forces of an undeformed body at rest under gravity: the residual's
    translation rows are the weight, m g (10 kg: pipe 8 + fluid 2 kg/m over 1 m)."""
    body = flexible_body(length=1.0, n_elements=2, section=SEC)
    d = body.data
    n, m = d.M.shape[0], len(d.eta0)
    r, t = d.forces(np.eye(3), np.zeros(3), np.zeros(n), d.eta0, np.zeros(m), 0.0, 0.0, np.array([0.0, 0.0, -9.81]))
    np.testing.assert_allclose(r[:3], [0.0, 0.0, body.mass * 9.81], rtol=1e-12, atol=1e-12 * body.mass * 9.81)
    assert t.shape == (n, n) and np.isfinite(t).all()


def test_time_table_value_and_rate():
    table = _core.TimeTable()
    table.t, table.value = [0.0, 1.0, 3.0], [0.0, 2.0, 0.0]
    assert table.at(0.5) == pytest.approx(1.0, rel=1e-15)
    assert table.rate(0.5) == pytest.approx(2.0, rel=1e-15)
    assert table.rate(2.0) == pytest.approx(-1.0, rel=1e-15)


def test_per_node_bases_set_the_reduced_coordinates():
    core = _core.Model()
    core.add_nodes(np.zeros((2, 3)))
    core.set_bases([np.eye(6), np.eye(6)[:, :3]])
    core.finalize()
    assert core.n_dofs == 9
    extra = _core.Model()
    extra.add_nodes(np.zeros((2, 3)))
    extra.set_bases([np.eye(6)] * 3)  # a basis for a node that is not there: refused at finalize
    with pytest.raises(ValueError, match="2 nodes but 3 bases"):
        extra.finalize()


def test_ancf_element_nodes_and_planar_triad():
    b = pf.ModelBuilder()
    n0 = b.add_ancf_node((0.0, 0.0, 0.0))
    b.add_ancf_beam(n0, (1.0, 0.0, 0.0), 2, pf.PipeSection(EI=10.0, pipe_mass=1.0, EA=1e5))
    b.clamp(n0)
    model = b.build()
    assert model.core.ancf_nodes(0) == (0, 1) and model.core.ancf_nodes(1) == (1, 2)
    T = planar_triad([1.0, 1.0, 0.0])
    np.testing.assert_allclose(T.T @ T, np.eye(3), atol=1e-15)
    np.testing.assert_allclose(T[:, 0], [2**-0.5, 2**-0.5, 0.0], rtol=1e-15)
    np.testing.assert_allclose(T[:, 2], [0.0, 0.0, 1.0], atol=1e-15)
