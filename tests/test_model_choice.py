"""pipeflex.seeds.seed004.model_choice: accuracy against cost of FFRF bodies and seed 000's element."""
import numpy as np
import pytest

from pipeflex.seeds.seed000 import references as ref000, validation as val000
from pipeflex.seeds.seed004 import model_choice as mc, studies as fs


def test_straight_candidates_n_bodies_equal_2n_elements():
    c = mc.straight_pipe_candidates(bodies=(1, 2), modes=(0,), elements=(2, 4), repeats=1)
    by = {x.label: x for x in c}
    for nb in (1, 2):
        ffrf, el = by[f"FFRF {nb} b."], by[f"element {2 * nb} el."]
        assert ffrf.value == pytest.approx(el.value, rel=1e-7)
        assert ffrf.value == pytest.approx(ref000.TABLE2[2 * nb], rel=val000.TOL_TABLE2)
        assert ffrf.size == el.size  # 12 n_bodies independent DOF, first-order state twice that
        assert ffrf.error == pytest.approx(abs(ffrf.value / mc.CRITICAL_FLOW_REFERENCE - 1.0))
    assert all(x.wall_time > 0 for x in c)


def test_choose_picks_the_cheapest_within_tolerance():
    c = [mc.Candidate("a", "coarse", 10, 0.01, 1.0, 1e-2), mc.Candidate("a", "fine", 40, 0.10, 1.0, 1e-4),
         mc.Candidate("b", "other", 20, 0.05, 1.0, 5e-4)]
    assert mc.choose(c, (1e-1, 1e-3, 1e-5)) == {1e-1: "coarse", 1e-3: "other", 1e-5: None}
    assert mc.choose(c, (1e-3,), cost="size") == {1e-3: "other"}
    with pytest.raises(ValueError):
        mc.choose(c, (1e-3,), cost="money")
    with pytest.raises(ValueError):
        mc.choose(c, (-1e-3,))
    assert "coarse" in mc.format_candidates(c, unit="kg/s")


def test_element_curved_model_is_the_studies_model():
    E = 9.585e9
    m = mc.element_curved_model(E, n_elements=4)
    assert m.n_dofs == 4 * 6 + 1  # 5 nodes x 6, the hinge leaves one rotation at the inlet
    import pipeflex as pf

    assert pf.steady_rotation(m).omega == pytest.approx(fs.element_curved_pipe(E, n_elements=4), rel=1e-12)


def test_curved_candidates_short_run():
    c = mc.curved_pipe_candidates(9.585e9, reference=9.036, bodies=(2,), elements=(2,), t_end=0.6, step=2e-3,
                                  repeats=1)
    assert [x.family for x in c] == ["FFRF, transient", "seed-000 element, steady solver",
                                     "seed-000 element, transient"]
    assert all(np.isfinite(x.value) and x.value > 0 and x.wall_time > 0 for x in c)
    assert c[0].size == 2 * 25  # 2 bodies: 2 x 18 coordinates - 6 (rigid) - 5 (hinge) constraints


def test_best_time_and_bad_input():
    calls = []
    out, wall = mc.best_time(lambda: calls.append(1) or 7, repeats=3, budget=10.0)
    assert out == 7 and len(calls) == 3 and wall >= 0
    calls.clear()
    mc.best_time(lambda: calls.append(1), repeats=3, budget=0.0)
    assert len(calls) == 1
    with pytest.raises(ValueError):
        mc.best_time(lambda: None, repeats=0)
    with pytest.raises(ValueError):
        mc.element_curved_model(-1.0)
    with pytest.raises(ValueError):
        mc.error_cost_figure([], title="x", cost="money")



def test_reduced_coordinates_labels_and_basis_per_node():
    """The basis (reduced -> nodal coordinates) and the dof labels, node by node, for a
    tilted hinge (one "combined" rotation), a pin, two fixed components and free nodes
    (Model reads each distinct nodal basis once and shares it among its nodes)."""
    import numpy as np

    import pipeflex as pf

    sec = pf.PipeSection(EI=10.0, pipe_mass=1.0, fluid_mass=0.5, EA=1e5)
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    nodes = b.add_line(n0, (1.0, 0.0, 0.0), 6, sec)
    b.hinge(n0, (0.0, 0.6, 0.8))
    b.pin(nodes[3])
    b.fix(nodes[5], ["uz", "rx"])
    m = b.build()
    eye = np.eye(6)
    want = {0: np.array([[0.0, 0.0, 0.0, 0.0, 0.6, 0.8]]).T, nodes[3]: eye[:, 3:], nodes[5]: eye[:, [0, 1, 4, 5]]}
    first = list(m.core.first_dof) + [m.n_dofs]
    B = m.basis.toarray()
    labels = []
    for n in range(m.n_nodes):
        T = want.get(n, eye)
        block = B[6 * n:6 * n + 6, first[n]:first[n + 1]]
        assert block.shape == T.shape
        np.testing.assert_allclose(np.abs(block), np.abs(T), atol=1e-15)  # a column's sign is free
        assert not np.any(np.delete(B[6 * n:6 * n + 6], np.arange(first[n], first[n + 1]), axis=1))
        labels += [(n, "combined" if np.count_nonzero(T[:, j]) > 1 else pf.model.COMPONENTS[np.flatnonzero(T[:, j])[0]])
                   for j in range(T.shape[1])]
    assert m.dof_labels == tuple(labels)
