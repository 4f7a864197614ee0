"""Distributed loads on pipe and ANCF elements (``ModelBuilder.add_distributed_load``):
consistent like gravity, which carries them (cpp/src/assembly.cpp, distributed_gravity)."""
import numpy as np
import pytest

import pipeflex as pf
from pipeflex import _core

from helpers import residual_columns

L, EI, N_EL = 2.0, 40.0, 8  # [m], [N m^2], elements
MU = 1.5 + 0.5  # pipe + fluid mass per length [kg/m]
SECTION = pf.PipeSection(EI=EI, EA=4e7, GJ=30.0, pipe_mass=1.5, fluid_mass=0.5)
ANCF = pf.PipeSection(EI=EI, EA=4e7, pipe_mass=MU)


def cantilever(q=None, *, gravity=None, ancf=False, by_line=True, time_function=None, section=SECTION):
    """A cantilever along x clamped at x = 0, under the distributed load q [N/m] on all its
    elements and/or gravity g [m/s^2]; (model, tip node)."""
    b = pf.ModelBuilder()
    if ancf:
        nodes = b.add_ancf_beam((0.0, 0.0, 0.0), (L, 0.0, 0.0), N_EL, ANCF)
        b.clamp(nodes[0])
    else:
        root = b.add_node((0.0, 0.0, 0.0))
        nodes = b.add_line(root, (L, 0.0, 0.0), N_EL, section)
        b.clamp(root)
    if q is not None:
        if by_line:
            b.add_distributed_load(line=nodes, force_per_length=q, time_function=time_function)
        else:
            b.add_distributed_load(list(range(N_EL)), force_per_length=q, time_function=time_function)
    if gravity is not None:
        b.set_gravity(gravity)
    return b.build(), nodes[-1]


@pytest.mark.parametrize("ancf", [False, True])
def test_total_force_is_q_times_length(ancf):
    q = np.array([3.0, -7.0, 0.0 if ancf else 2.0])
    model, _ = cantilever(q, ancf=ancf)
    f = _core.external_forces(model.core, model.initial_state(), 0.0).reshape(-1, 6)
    assert np.allclose(f[:, :3].sum(axis=0), q * L, rtol=1e-12, atol=1e-12 * np.abs(q).max() * L)
    # consistent: the end nodes carry q l / 2 and, along the beam, the interior ones q l
    l = L / N_EL
    assert np.allclose(f[0, :2], q[:2] * l / 2, rtol=1e-12)
    assert np.allclose(f[N_EL // 2, :2], q[:2] * l, rtol=1e-12)


@pytest.mark.parametrize("ancf", [False, True])
def test_cantilever_tip_deflection_is_q_l4_over_8_ei(ancf):
    q = -1e-5  # [N/m]: small, so the geometric nonlinearity is far below the tolerance
    model, tip = cantilever((0.0, q, 0.0), ancf=ancf)
    y = pf.static_equilibrium(model).state.q[6 * tip + 1]
    # cubic elements with consistent loads: the nodal deflections of Euler-Bernoulli theory
    assert y == pytest.approx(q * L**4 / (8 * EI), rel=1e-6)


@pytest.mark.parametrize("ancf", [False, True])
def test_equal_to_gravity_when_q_is_mu_g(ancf):
    g = np.array([0.0, -9.81, 0.0])
    by_gravity, tip = cantilever(gravity=g, ancf=ancf)
    by_load, _ = cantilever(MU * g, ancf=ancf, by_line=False if not ancf else True)
    a = pf.static_equilibrium(by_gravity).state.q
    b = pf.static_equilibrium(by_load).state.q
    assert abs(a[6 * tip + 1]) > 0.1 * L  # a large deflection: the load follows the geometry as gravity does
    assert np.allclose(a, b, rtol=0.0, atol=1e-12 * L)


def tangent(model, st):
    rows, cols, vals = _core.assemble(model.core, st, _core.LoadState(), 1.0, 1.0, 0.0, 0.0)[1]
    K = np.zeros((model.n_dofs, model.n_dofs))
    np.add.at(K, (rows, cols), vals)
    return K


def test_tangent_matches_central_differences():
    """The load's own stiffness (its moments on the elements' end slopes turn with them):
    the difference of the models with and without it, against central differences."""
    soft = pf.PipeSection(EI=EI, EA=4e3, GJ=30.0, pipe_mass=1.5, fluid_mass=0.5)  # (the elastic forces'
    with_load, _ = cantilever((100.0, -2000.0, 500.0), section=soft)            # round-off: small)
    without, _ = cantilever(None, section=soft)
    st = with_load.initial_state()
    q = np.array(st.q)
    q[6:] += 0.05 * np.random.default_rng(2).standard_normal(q.size - 6)  # turned and bent
    st.q = q
    Kq = tangent(with_load, st) - tangent(without, st)
    D = residual_columns(with_load, st, _core.LoadState(), "q", 1e-6) - \
        residual_columns(without, st, _core.LoadState(), "q", 1e-6)
    assert np.abs(Kq).max() > 1e-3  # there is one
    assert np.abs(Kq - D).max() <= 1e-6 * np.abs(Kq).max()


def test_time_function_and_load_work():
    """A load switched on by a ramp: the statics take s(0) = 0; a transient's energy balance
    counts its work."""
    ramp = ([0.0, 0.2, 10.0], [0.0, 1.0, 1.0])
    model, tip = cantilever((0.0, -2.0, 0.0), time_function=ramp)
    assert np.abs(pf.static_equilibrium(model).state.q[6 * tip:6 * tip + 3] - [L, 0.0, 0.0]).max() < 1e-12
    sec = pf.PipeSection(EI=EI, EA=4e7, GJ=30.0, pipe_mass=1.5, fluid_mass=0.5, rotary_inertia=(1e-3, 1e-3, 1e-3))
    b = pf.ModelBuilder()
    nodes = b.add_line(b.add_node((0.0, 0.0, 0.0)), (L, 0.0, 0.0), 4, sec)
    b.clamp(nodes[0])
    b.add_distributed_load(line=nodes, force_per_length=(0.0, -2.0, 0.0), time_function=ramp)
    res = pf.simulate(b.build(), 1.0, integrator="generalized_alpha", step=1e-3, rho_inf=1.0, n_outputs=101)
    assert res.load_work[-1] > 1e-3  # the load did work
    assert np.abs(res.energy_balance()).max() <= 1e-3 * res.load_work[-1]


def test_bad_input_names_the_argument(tmp_path):
    b = pf.ModelBuilder()
    nodes = b.add_line(b.add_node((0.0, 0.0, 0.0)), (L, 0.0, 0.0), 2, SECTION)
    b.clamp(nodes[0])
    with pytest.raises(ValueError, match="elements refers to pipe element 5"):
        b.add_distributed_load([5], force_per_length=(0.0, 1.0, 0.0))
    with pytest.raises(ValueError, match="line: no pipe or ANCF element joins nodes 0 and 2"):
        b.add_distributed_load(line=[0, 2], force_per_length=(0.0, 1.0, 0.0))
    with pytest.raises(ValueError, match="line refers to node 9"):
        b.add_distributed_load(line=[0, 9], force_per_length=(0.0, 1.0, 0.0))
    with pytest.raises(ValueError, match="force_per_length"):
        b.add_distributed_load([0], force_per_length=(0.0, np.nan, 0.0))
    with pytest.raises(ValueError, match="one of elements"):
        b.add_distributed_load([0], line=nodes, force_per_length=(0.0, 1.0, 0.0))
    with pytest.raises(ValueError, match="time_function"):
        b.add_distributed_load([0], force_per_length=(0.0, 1.0, 0.0), time_function="soon")
    b.add_distributed_load([0, 1], force_per_length=(0.0, 1.0, 0.0))
    # the refused calls left no load behind: the model file holds the one that was added
    text = pf.save_model(b.build(), tmp_path / "m.json").read_text()
    assert text.count('"force_per_length"') == 1


def test_distributed_loads_survive_pickles():
    import pickle

    model, tip = cantilever((0.0, -1e-3, 0.0), time_function=0.5)
    again = pickle.loads(pickle.dumps(model))
    a = pf.static_equilibrium(model).state.q[6 * tip + 1]
    assert a == pytest.approx(0.5 * -1e-3 * L**4 / (8 * EI), rel=1e-6)  # s(0) = 0.5 scales it
    assert pf.static_equilibrium(again).state.q[6 * tip + 1] == a
