"""The builder's bulk path: a line or arc of elements equals the same elements added one by
one (the same structure, the same numbers to a few ulps), and a bad element in the middle of
a line is named (nothing is added)."""
import numpy as np
import pytest

import pipeflex as pf
from helpers import assert_close_ulps
from pipeflex import _core
from pipeflex.rotation import skew

SEC = pf.PipeSection(EI=7.0, EIz=11.0, EA=3e3, GJ=5.0, GAy=900.0, GAz=700.0, pipe_mass=1.3, fluid_mass=0.7,
                     kv=1.1, rotary_inertia=(0.02, 0.01, 0.015))
FIELDS = ("l0", "EA", "GJ", "EIy", "EIz", "Phi_y", "Phi_z", "strain0", "offset_p", "offset_q", "pipe_mass",
          "fluid_mass", "kv", "rotary_inertia", "flow_factor", "end_terms_p", "end_terms_q")
# what the core derives from l0, Ep, Eq (strain0, Phi, r, J) amplifies their ulps: 4 ulps in
# them gave up to 17 ulps (of the array's largest entry) in strain0 and the residual (measured)
ULPS_DERIVED = 64


def assert_same_model(a, b):
    """Nodes, element records, the core's element data and matrices: the same structure
    exactly, the same numbers to a few ulps.

    Not bit for bit: the bulk path computes the triads and lengths on (n, 3) arrays, the
    one-by-one path on (1, 3) arrays and the test's geometry with scalar formulas, and
    numpy's loops may round these differently by CPU and version (on AVX-512 CPUs its SVML
    loops for the transcendental functions: 1-2 ulps in l0, Ep, Eq reported)."""
    def close(x, y, what, ulps=4):
        x, y = np.asarray(x), np.asarray(y)
        assert x.dtype == y.dtype, what
        if x.dtype.kind in "biu":  # indices and flags: exact
            assert np.array_equal(x, y), what
            return
        # entries that cancel to ~0 (triad components, residual entries) carry the round-off
        # of the array's largest ones
        assert_close_ulps(x, y, ulps=ulps, scale=np.abs(x).max(initial=0.0), what=what)

    close(a.positions, b.positions, "positions")
    assert a.dof_labels == b.dof_labels
    ea, eb = a._description["_elements"], b._description["_elements"]
    assert len(ea) == len(eb)
    for x, y in zip(ea, eb):
        assert (x["p"], x["q"], x["flow_factor"], x["fluid_end_terms"]) == (y["p"], y["q"], y["flow_factor"],
                                                                         y["fluid_end_terms"])
        for key in ("l0", "Ep", "Eq"):
            close(x[key], y[key], key)
    for i in range(len(ea)):
        da, db = a.core.pipe(i), b.core.pipe(i)
        for f in FIELDS:
            close(getattr(da, f), getattr(db, f), f"element {i}: {f}", ULPS_DERIVED)
    rng = np.random.default_rng(0)
    sa, sb = a.initial_state(), b.initial_state()
    dq = 1e-3 * rng.standard_normal(sa.q.shape)
    for s in (sa, sb):
        s.q = s.q + dq
        s.v = np.full(s.v.shape, 0.1)
    ra, ta = _core.assemble(a.core, sa, a.load_state(), 1.0, 1.0, 0.3, 0.7)
    rb, tb = _core.assemble(b.core, sb, b.load_state(), 1.0, 1.0, 0.3, 0.7)
    close(ra, rb, "residual", ULPS_DERIVED)
    assert len(ta) == len(tb)
    for k, (x, y) in enumerate(zip(ta, tb)):
        close(x, y, f"tangent triplets[{k}]", ULPS_DERIVED)


def _finish(b, n0):
    b.hinge(n0, (0.3, 0.4, 0.5))
    return b.build(mass_flow=1.5)


@pytest.mark.parametrize("options", [{}, dict(up=(0.2, 0.1, 1.0), flow_factor=-0.5, fluid_end_terms=False),
                                     dict(length=0.5), dict(tangent_p=(1.0, 0.6, 0.2))])
def test_line_equals_its_elements_one_by_one(options):
    x0, x1, n = np.array([0.1, -0.2, 0.3]), np.array([1.1, 0.3, 0.5]), 7
    b = pf.ModelBuilder()
    n0 = b.add_node(x0)
    b.add_line(n0, x1, n, SEC, **options)
    one = pf.ModelBuilder()
    nodes = [one.add_node(x0)]
    for k in range(1, n + 1):
        nodes.append(one.add_node(x0 + (x1 - x0) * k / n))
        one.add_pipe(nodes[-2], nodes[-1], SEC, **options)
    assert_same_model(_finish(b, n0), _finish(one, nodes[0]))


@pytest.mark.parametrize("angle,n", [(-np.pi, 8), (2.5, 5), (2 * np.pi, 13)])
def test_arc_equals_its_curved_elements_one_by_one(angle, n):
    """add_arc against add_pipe with each element's end tangents (the arc's geometry written out)."""
    x0, c = np.array([0.3, 0.1, -0.2]), np.array([0.2, 0.9, 0.4])
    r0 = x0 - c
    k = np.cross(r0, (0.1, 0.2, 1.0))
    k /= np.linalg.norm(k)
    b = pf.ModelBuilder()
    n0 = b.add_node(x0)
    b.add_arc(n0, center=c, angle=angle, normal=k, n_elements=n, section=SEC, flow_factor=0.5)
    k = k / np.linalg.norm(k)  # add_arc's unit normal
    K, dth = skew(k), angle / n

    def point(i):  # from the centre to node i, as add_arc's Rodrigues' formula
        return (np.eye(3) + np.sin(dth * i) * K + (1 - np.cos(dth * i)) * K @ K) @ r0

    one = pf.ModelBuilder()
    nodes = [one.add_node(x0)]
    for i in range(1, n + 1):
        nodes.append(one.add_node(c + point(i)))
        one.add_pipe(nodes[-2], nodes[-1], SEC, up=k, tangent_p=np.sign(angle) * np.cross(k, point(i - 1)),
                     tangent_q=np.sign(angle) * np.cross(k, point(i)), flow_factor=0.5)
    assert_same_model(_finish(b, n0), _finish(one, nodes[0]))


def test_bad_element_in_the_middle_of_a_line_is_named_and_nothing_is_added():
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    n1 = b.add_node((1e308, 0.0, 0.0))
    with pytest.raises(ValueError, match=r"position must be finite, got \[inf  0.  0.\] \(new node 4\)"):
        with np.errstate(over="ignore"):
            b.add_line(n1, (1.7e308, 0.0, 0.0), 4, SEC)  # overflows at the third new node
    assert len(b._positions) == 2 and not b._elements
    with pytest.raises(ValueError, match=r"up vector .* is parallel to the element axis .* \(element 0->2\)"):
        b.add_line(n0, (0.0, 0.0, 1.0), 3, SEC, up=(0.0, 0.0, -2.0))
    assert len(b._positions) == 2 and not b._elements


@pytest.mark.parametrize("points,options,match", [
    ([(0, 0, 0), (1, 0, 0), (2, 0, 0), (2, 0, 0), (3, 0, 0)], {},
     r"element 2->3 has zero length: nodes 2 and 3 coincide"),
    ([(0, 0, 0), (1, 0, 0), (1, 0, 1), (2, 0, 1)], dict(up=(0, 0, 1)),
     r"up vector \[0. 0. 1.\] is parallel to the element axis \[0. 0. 1.\] \(element 1->2\)"),
    ([(0, 0, 0), (0.5, 0, 0), (2.5, 0, 0), (3, 0, 0)], dict(length=0.8),
     r"length l0 = 0.8 must not be shorter than the chord 2.0 \(element 1->2\)"),
    ([(0, 0, 0), (1, 0, 0), (2, 0, 0), (3, 0, 0)], dict(tangent_p=np.array([(1, 0, 0), (0, 0, 0), (1, 0, 0)])),
     r"tangent_p must be a non-zero vector, got \[0. 0. 0.\] \(row 1\)"),
])
def test_bulk_names_the_first_bad_element(points, options, match):
    """The bulk path checks each rule once for all elements and names the first that breaks it."""
    b = pf.ModelBuilder()
    nodes = [b.add_node(x) for x in points]
    with pytest.raises(ValueError, match=match):
        b._add_pipes(np.array(nodes[:-1]), np.array(nodes[1:]), SEC, **options)
    assert not b._elements


def test_core_bulk_calls_refuse_bad_arrays_before_changing_the_model():
    core = _core.Model()
    core.add_nodes(np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]))
    one = dict(l0=[1.0], EA=[1.0], GJ=[1.0], EIy=[1.0], EIz=[1.0], Phi_y=[0.0], Phi_z=[0.0],
               offset_p=np.eye(3)[None], offset_q=np.eye(3)[None], pipe_mass=[1.0], fluid_mass=[0.0], kv=[1.0],
               rotary_inertia=[[0.0, 0.0, 0.0]], flow_factor=[1.0], end_terms_p=[True], end_terms_q=[True])
    with pytest.raises(ValueError, match=r"q must be a node index in \[0, 2\), got 5"):
        core.add_pipes([0], [5], **one)
    with pytest.raises(ValueError, match="offset_q must have 9 entries for each of the 1 rows, got 3"):
        core.add_pipes([0], [1], **{**one, "offset_q": [1.0, 0.0, 0.0]})
    with pytest.raises(ValueError, match=r"positions must be an \(n, 3\) array"):
        core.add_nodes(np.zeros((2, 2)))
    with pytest.raises(ValueError, match=r"index must be in \[0, 1\)"):
        core.set_shared_bases([np.eye(6)], [0, 1])
    core.add_pipes([0], [1], **one)
    core.set_shared_bases([np.eye(6)], [0, 0])
    core.finalize()
    assert (core.n_nodes, core.n_dofs) == (2, 12) and core.pipe(0).l0 == 1.0
    with pytest.raises(ValueError):
        core.pipe(1)
