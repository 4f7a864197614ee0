"""The rigid rotation's kinematics of an element model on a hub, as the core computes them
for the rotating state (``_core.rigid_rotation_rates``, ``_core.rigid_rotation_operators``)
and the rotating-frame analyses use them (``_Frame``), against the formulas written out
here with numpy: at phi = 0, with S = skew(a) of the unit hub axis a and x_c its centre,

    x_dot = w S (x - x_c),  x_ddot = w^2 S^2 (x - x_c)          (node positions)
    d_dot = w S d,          d_ddot = w^2 S^2 d                   (ANCF slopes)
    phi_dot = w a,          phi_ddot = 0                         (frame nodes' rotations)

and the rate operators per unit w and w^2 on the unconstrained model's coordinates
pinv(T_f) Av T_f, pinv(T_f) Aa T_f, Av and Aa block diagonal per node (S and S^2 for
positions and slopes, S/2 and S^2/6 for rotation vectors), with T_rel = pinv(T_f) T."""
import numpy as np
import pytest

from pipeflex import ModelBuilder, PipeSection, _core, scenes
from pipeflex.analysis.rotating import _Frame, rotating_state

EPS = np.finfo(float).eps


def _skew(a):
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def _ancf_off_centre():
    """A planar ANCF beam, oblique, on a hub about -z through an off-origin centre (a hub
    carries nodes of one kind, and a model on an ANCF hub no pipe: no model mixes them)."""
    b = ModelBuilder()
    nodes = b.add_ancf_beam((0.5, 0.0, 0.0), (1.5, 0.3, 0.0), 3, PipeSection(EI=2.0, EA=3e3, pipe_mass=1.5))
    b.rotating_hub(nodes[0], omega=0.0, center=(0.2, -0.1, 0.0), axis=(0.0, 0.0, -1.0))
    return b.build()


def _tilted_pipe():
    """A 3D pipe on a hub about a tilted axis through an off-origin centre."""
    b = ModelBuilder()
    n0 = b.add_node((0.3, 0.1, -0.2))
    nodes = b.add_line(n0, (1.3, 0.7, 0.4), 4, PipeSection(EI=2.0, EA=3e3, GJ=1.5, pipe_mass=1.5))
    b.rotating_hub(nodes[0], omega=0.0, center=(0.1, -0.2, 0.05), axis=(1.0, 2.0, 2.0))
    return b.build()


MODELS = {
    "ancf_cantilever": lambda: scenes.rotating_cantilever(n_elements=4, hub_radius_ratio=0.5),
    "pipe_cantilever": lambda: scenes.rotating_cantilever(n_elements=4, formulation="pipe", hub_radius_ratio=0.5),
    "ancf_off_centre": _ancf_off_centre,
    "tilted_pipe": _tilted_pipe,
}


def _deformed_state(model, rng):
    """The model's initial state moved by a random increment (slopes off their unit length)."""
    st = model.initial_state()
    _core.add_increment(model.core, st, 0.05 * rng.standard_normal(model.n_dofs), "q")
    return st


def _check_rates(model, st, omega):
    """st.v, st.a those of the rigid rotation at omega [rad/s] of st.q (the formulas above)."""
    a, c = np.asarray(model.hub.axis), np.asarray(model.hub.center)
    S = _skew(a)
    q = np.asarray(st.q).reshape(-1, 6)
    v, acc = np.asarray(st.v).reshape(-1, 6), np.asarray(st.a).reshape(-1, 6)
    ancf = np.zeros(model.n_nodes, bool)
    ancf[list(model.ancf_nodes)] = True
    r = q[:, :3] - c
    tol = 16 * EPS * max(abs(omega), omega**2) * max(1.0, np.abs(q).max() + np.abs(c).max())
    np.testing.assert_allclose(v[:, :3], omega * r @ S.T, rtol=0, atol=tol)
    np.testing.assert_allclose(acc[:, :3], omega**2 * r @ (S @ S).T, rtol=0, atol=tol)
    d = q[ancf, 3:]
    np.testing.assert_allclose(v[ancf, 3:], omega * d @ S.T, rtol=0, atol=tol)
    np.testing.assert_allclose(acc[ancf, 3:], omega**2 * d @ (S @ S).T, rtol=0, atol=tol)
    np.testing.assert_allclose(v[~ancf, 3:], np.broadcast_to(omega * a, v[~ancf, 3:].shape), rtol=0, atol=tol)
    assert not np.any(acc[~ancf, 3:])
    return ancf


@pytest.mark.parametrize("name", sorted(MODELS))
def test_rates_are_the_rigid_rotation_of_the_state(name):
    model = MODELS[name]()
    st = _deformed_state(model, np.random.default_rng(7))
    _Frame(model).rigid_rotation(st, -2.7)
    ancf = _check_rates(model, st, -2.7)
    assert ancf.all() if name.startswith("ancf") else not ancf.any()
    assert np.any(np.asarray(st.a))  # the check can fail: the state has rates


@pytest.mark.parametrize("name", sorted(MODELS))
def test_the_rotating_state_carries_the_rates_of_its_positions(name):
    """The core's rotating state: its rates those of the rigid rotation of its result."""
    model = MODELS[name]()
    st = rotating_state(model, 1.3, continuation_steps=2)
    assert np.abs(np.asarray(st.q) - np.asarray(model.initial_state().q)).max() > 1e-8  # deformed
    _check_rates(model, st, 1.3)


@pytest.mark.parametrize("name", sorted(MODELS))
@pytest.mark.parametrize("dense", [True, False])
def test_operators_are_the_rate_derivatives_on_the_unconstrained_coordinates(name, dense):
    model = MODELS[name]()
    fr = _Frame(model)
    fr.dense = dense
    a = np.asarray(model.hub.axis)
    S = _skew(a)
    S2 = S @ S
    ancf = set(model.ancf_nodes)
    Av = np.zeros((6 * model.n_nodes,) * 2)
    Aa = np.zeros_like(Av)
    for i in range(model.n_nodes):
        p, s = slice(6 * i, 6 * i + 3), slice(6 * i + 3, 6 * i + 6)
        Av[p, p], Aa[p, p] = S, S2
        Av[s, s], Aa[s, s] = (S, S2) if i in ancf else (S / 2, S2 / 6)
    T, Tf = model.basis.toarray(), fr.free.basis.toarray()
    Tfp = np.linalg.pinv(Tf)
    want = {"T_rel": Tfp @ T, "A": Tfp @ Av @ Tf, "B": Tfp @ Aa @ Tf}
    for key, X in want.items():
        got = getattr(fr, key)
        assert isinstance(got, np.ndarray) == dense, key
        got = got if dense else got.toarray()
        assert got.shape == X.shape, key
        np.testing.assert_allclose(got, X, rtol=0, atol=64 * EPS * max(1.0, np.abs(X).max()), err_msg=key)
    # the operators are those of the rates: A on the positions relative to the centre
    # gives the rigid rotation's velocities per unit w
    st = model.initial_state()
    fr.rigid_rotation(st, 1.0)
    x = np.asarray(st.q)
    pos = (np.arange(6 * model.n_nodes) % 6) < 3
    c = np.tile(np.r_[np.asarray(model.hub.center), np.zeros(3)], model.n_nodes)
    rel = Tfp @ np.where(pos, x - c, 0.0)
    A = fr.A if dense else fr.A.toarray()
    np.testing.assert_allclose((Tf @ (A @ rel))[pos], np.asarray(st.v)[pos], rtol=0,
                               atol=64 * EPS * max(1.0, np.abs(x).max() + np.abs(c).max()))


def test_planar_ancf_about_another_axis_is_refused():
    """(The model builder refuses such a hub first; the operators check on their own.)"""
    m = scenes.rotating_cantilever(n_elements=2)
    with pytest.raises(ValueError, match="planar ANCF nodes can only turn about the z axis"):
        _core.rigid_rotation_operators(m.core, m.free_model().core, [0.0, 1.0, 0.0])
    _core.rigid_rotation_operators(m.core, m.free_model().core, [0.0, 0.0, -1.0])


def test_operators_refuse_another_structure():
    m = scenes.rotating_cantilever(n_elements=3)
    other = scenes.rotating_cantilever(n_elements=4)
    with pytest.raises(ValueError, match="other nodes or elements"):
        _core.rigid_rotation_operators(m.core, other.free_model().core, [0.0, 0.0, 1.0])
