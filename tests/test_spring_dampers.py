"""Spring-dampers as parts of an element model: the axial spring-damper between two nodes
(``ModelBuilder.add_spring``) and the ground spring-damper at one node
(``ModelBuilder.add_ground_spring``), through the element interface (cpp/src/axial_spring.cpp,
cpp/src/ground_spring.cpp), seen by the statics, the linearisation and both integrators."""
import pickle

import numpy as np
import pytest

import pipeflex as pf
from pipeflex import _core
from pipeflex.analysis import constrained
from pipeflex.model import SpringInfo
from pipeflex.rotation import rotation_exp
from pipeflex.state import as_core

from helpers import residual_columns

L, EI, N_EL = 2.0, 40.0, 4  # cantilever length [m], bending stiffness [N m^2], elements
SECTION = pf.PipeSection(EI=EI, EA=4e5, GJ=30.0, pipe_mass=1.5, fluid_mass=0.5, rotary_inertia=(1e-3, 1e-3, 1e-3))
M, K, C = 2.0, 50.0, 0.8  # point mass [kg], stiffness [N/m], damping [N s/m]
OMEGA = np.sqrt(K / M)  # [rad/s]


def cantilever(k, *, force=0.0, damping=(0.0, 0.0, 0.0)):
    """A pipe cantilever along x (clamped at node 0) whose tip is held along y by a ground
    spring of stiffness k [N/m]; a dead force [N] along y at the tip."""
    b = pf.ModelBuilder()
    root = b.add_node((0.0, 0.0, 0.0))
    nodes = b.add_line(root, (L, 0.0, 0.0), N_EL, SECTION)
    b.clamp(root)
    b.add_ground_spring(nodes[-1], stiffness=(0.0, k, 0.0), damping=damping)
    if force:
        b.add_load(nodes[-1], force=(0.0, force, 0.0))
    return b.build(), nodes[-1]


def oscillator(k=K, c=C, *, free=("ux",)):
    """A point mass m [kg] at one node on a ground spring-damper (k, c along every axis);
    only the coordinates ``free`` move."""
    b = pf.ModelBuilder()
    n = b.add_node((0.3, -0.2, 0.1))
    b.add_point_mass(n, M, (1e-3, 1e-3, 1e-3))
    b.add_ground_spring(n, stiffness=(k, k, k), damping=(c, c, c))
    b.fix(n, [x for x in ("ux", "uy", "uz", "rx", "ry", "rz") if x not in free])
    return b.build()


def displaced(model, u, *, node=0, axis=0):
    """The reference state with node ``node`` moved by u [m] along ``axis``."""
    s = model.initial_state()
    q = np.array(s.q)
    q[6 * node + axis] += u
    s.q = q
    return s


def test_cantilever_tip_on_a_ground_spring_is_the_parallel_stiffness():
    k, P = 25.0, 1e-4  # [N/m], [N]: small, so that the geometric nonlinearity is ~1e-10
    model, tip = cantilever(k, force=P)
    y = pf.static_equilibrium(model).state.q[6 * tip + 1]
    assert y == pytest.approx(P / (3.0 * EI / L**3 + k), rel=1e-6)
    assert abs(y - P * L**3 / (3.0 * EI)) > 0.1 * abs(y)  # without the spring: the beam alone


def test_damped_oscillator_eigenvalues():
    lam = pf.eigenvalues(pf.linearize(oscillator())).values
    z = C / (2 * M)
    expected = np.array([-z + 1j * np.sqrt(K / M - z * z), -z - 1j * np.sqrt(K / M - z * z)])
    assert len(lam) == 2
    for e in expected:
        assert np.min(np.abs(lam - e)) <= 1e-10 * abs(e)


def test_axial_spring_damper_eigenvalues():
    """A mass on an axial spring-damper to a clamped node, moving along the spring's
    axis (not a global axis): the same oscillator."""
    b = pf.ModelBuilder()
    a = b.add_node((0.0, 0.0, 0.0))
    n = b.add_node((0.6, 0.8, 0.0))
    b.add_point_mass(n, M)
    b.add_spring(a, n, stiffness=K, damping=C)
    b.clamp(a)
    b.fix(n, ["rx", "ry", "rz"])
    b.axial_support(n, (0.0, 0.0, 1.0))
    b.axial_support(n, (-0.8, 0.6, 0.0))
    model = b.build()
    lam = pf.eigenvalues(pf.linearize(model)).values
    z = C / (2 * M)
    assert np.min(np.abs(lam - (-z + 1j * np.sqrt(K / M - z * z)))) <= 1e-10 * OMEGA


@pytest.mark.parametrize("integrator, options", [("generalized_alpha", dict(step=1e-3, rho_inf=1.0)),
                                                 ("ida", dict(rtol=1e-9, atol=1e-12))])
def test_free_decay_envelope(integrator, options):
    u0, t_end = 0.01, 6.0  # [m], [s]: about 7 periods
    model = oscillator()
    res = pf.simulate(model, t_end, state=displaced(model, u0), integrator=integrator, n_outputs=301, **options)
    z = C / (2 * M)
    wd = np.sqrt(K / M - z * z)
    u, ud = res.x[:, 0, 0] - model.positions[0, 0], res.xd[:, 0, 0]
    # the amplitude of x(t) = A exp(-z t) cos(wd t + phase): exact along the motion
    envelope = np.hypot(u, (ud + z * u) / wd)
    expected = u0 * np.hypot(1.0, z / wd) * np.exp(-z * res.t)
    assert np.abs(envelope - expected).max() <= 1e-5 * u0
    assert envelope[-1] < 0.35 * envelope[0]  # it decays: the check can fail without damping


def test_energy_conserved_without_damping_and_decreasing_with_it():
    u0 = 0.01
    undamped = oscillator(c=0.0)
    res = pf.simulate(undamped, 3.0, state=displaced(undamped, u0), integrator="generalized_alpha", step=1e-3,
                      rho_inf=1.0, n_outputs=151)
    E = res.kinetic + res.elastic
    assert E[0] == pytest.approx(0.5 * K * u0**2, rel=1e-12)  # the spring's U
    assert np.abs(E - E[0]).max() <= 1e-10 * E[0]
    assert res.kinetic.max() > 0.9 * E[0]  # it swings
    damped = oscillator()
    res = pf.simulate(damped, 3.0, state=displaced(damped, u0), integrator="generalized_alpha", step=1e-3,
                      rho_inf=1.0, n_outputs=151)
    E = res.kinetic + res.elastic
    assert (np.diff(E) < 0.0).all()
    assert E[-1] < 0.5 * E[0]


def tangent_model():
    """A cantilever whose tip is joined to a node D by an axial spring-damper, D held by
    a ground spring-damper at an anchor away from it (prestressed), a load and gravity."""
    b = pf.ModelBuilder()
    root = b.add_node((0.0, 0.0, 0.0))
    nodes = b.add_line(root, (L, 0.0, 0.0), N_EL, SECTION)
    d = b.add_node((L + 0.2, 0.5, 0.1))
    b.clamp(root)
    b.fix(d, ["rx", "ry", "rz"])
    b.add_point_mass(d, 0.3)
    b.add_spring(nodes[-1], d, stiffness=300.0, damping=7.0)
    b.add_ground_spring(d, stiffness=(80.0, 120.0, 60.0), damping=(3.0, 5.0, 2.0), anchor=(L + 0.25, 0.45, 0.1))
    b.add_ground_spring(nodes[-1], rotational_stiffness=(20.0, 35.0, 50.0), rotational_damping=(0.5, 0.8, 1.1))
    b.add_load(nodes[-1], force=(0.0, 2.0, -1.0))
    b.set_gravity((0.0, 0.0, -9.81))
    return b.build()


def moving_state(model):
    """Displaced and moving, the cantilever tip's frame re-based to 1.3 rad from the
    reference (its rotation from the reference: through the logarithm of exp(phi) R_ref)."""
    rng = np.random.default_rng(7)
    s = model.initial_state()
    frames = np.array(s.frames)
    frames[N_EL] = rotation_exp(np.array([0.7, -0.9, 0.6]))
    s.frames = frames
    _core.add_increment(model.core, s, 0.05 * rng.standard_normal(model.n_dofs), "q")
    _core.add_increment(model.core, s, 0.5 * rng.standard_normal(model.n_dofs), "v")
    return s


def test_stiffness_matches_the_differences_oracle():
    """K (with the damping force's dependence on the positions through the spring's
    direction) against the core's central differences of the residual, column by column."""
    model = tangent_model()
    out = _core.linear_matrices(model.system(as_core(model, moving_state(model))), 0.0, 1e-6)
    Kc = constrained.from_core(out)[0].toarray()
    D = out["differences"]
    col = np.abs(Kc).max(axis=0)
    assert (np.abs(Kc - D).max(axis=0) / col).max() < 1e-6
    # the oracle can fail: without the damping's position dependence the columns of D differ
    still = model.initial_state()
    still.q = moving_state(model).q
    K0 = constrained.from_core(_core.linear_matrices(model.system(as_core(model, still)), 0.0, 1e-6))[0].toarray()
    assert (np.abs(K0 - D).max(axis=0) / col).max() > 1e-3


def test_damping_matrix_matches_differences_in_the_velocities():
    model = tangent_model()
    s = moving_state(model)
    load = model.load_state()
    n, h = model.n_dofs, 1e-3  # the residual is at most quadratic in v: central differences are exact

    def matrix(wK, wC):
        _, (i, j, v) = _core.assemble(model.core, s, load, 1.0, wK, wC, 0.0)
        X = np.zeros((n, n))
        np.add.at(X, (i, j), v)
        return X

    Cm = matrix(0.0, 1.0)
    Cfd = residual_columns(model, s, load, "v", h)
    assert np.abs(Cm).max() > 1.0  # the dashpots' c e e^T and diag(c)
    assert np.abs(Cm - Cfd).max() <= 1e-7 * np.abs(Cm).max()
    # the combined tangent is the weighted sum
    Km = matrix(1.0, 0.0)
    assert np.abs(matrix(2.0, 3.0) - (2.0 * Km + 3.0 * Cm)).max() <= 1e-14 * np.abs(Km).max()


def test_linearize_sees_the_damping():
    model, tip = cantilever(25.0, damping=(0.0, 4.0, 0.0))
    lin = pf.linearize(model)
    i = model.dof_index(tip, "uy")
    assert lin.C[i, i] == pytest.approx(4.0, rel=1e-14)
    decay = pf.eigenvalues(lin).values.real
    assert decay.max() <= 0.0 and (decay < -1.0).sum() >= 2  # the modes that move the tip along y decay
    assert np.abs(pf.eigenvalues(pf.linearize(cantilever(25.0)[0])).values.real).max() < 1e-9  # undamped


def test_springs_survive_pickles_and_copies():
    import copy

    model = tangent_model()
    assert [s.kind for s in model.springs] == ["axial", "ground", "ground"]
    assert isinstance(model.springs[1], SpringInfo) and model.springs[1].anchor == (L + 0.25, 0.45, 0.1)
    s = moving_state(model)
    r0, _ = _core.assemble(model.core, s, model.load_state(), 1.0, 1.0, 1.0, 0.0)
    for other in (pickle.loads(pickle.dumps(model)), copy.deepcopy(model)):
        assert other.springs == model.springs
        r1, _ = _core.assemble(other.core, s, other.load_state(), 1.0, 1.0, 1.0, 0.0)
        assert np.array_equal(r0, r1)
    assert "springs" in repr(model)


def test_ground_springs_support_a_model():
    """A pipe on spring supports only (no clamp): it builds and stands; a part of springs
    and nodes without elements counts as connected."""
    b = pf.ModelBuilder()
    a = b.add_node((0.0, 0.0, 0.0))
    nodes = b.add_line(a, (L, 0.0, 0.0), N_EL, SECTION)
    for n in (nodes[0], nodes[-1]):
        b.add_ground_spring(n, stiffness=(1e3, 1e3, 1e3))
    b.fix_rotation(nodes[0], (1.0, 0.0, 0.0))  # the torsion about the line's axis
    b.set_gravity((0.0, 0.0, -9.81))
    model = b.build()
    z = pf.static_equilibrium(model).state.q[2::6]
    weight = L * (SECTION.pipe_mass + SECTION.fluid_mass) * 9.81
    assert z[0] + z[-1] == pytest.approx(-weight / 1e3, rel=1e-3)


def rotor(kt, ct, J=0.02):
    """A node turning about z only, with inertia J [kg m^2] about z, on a rotational
    spring-damper kt [N m/rad], ct [N m s/rad] about z (and stiff ones about x, y that the
    motion does not load)."""
    b = pf.ModelBuilder()
    n = b.add_node((0.0, 0.0, 0.0))
    b.add_point_mass(n, 1.0, (1e-3, 1e-3, J))
    b.add_ground_spring(n, rotational_stiffness=(5.0, 5.0, kt), rotational_damping=(0.0, 0.0, ct))
    b.fix(n, ["ux", "uy", "uz", "rx", "ry"])
    return b


def turned(model, angle):
    s = model.initial_state()
    q = np.array(s.q)
    q[5] = angle
    s.q = q
    return s


def test_rotational_spring_is_exact_at_large_rotations():
    kt, ct, J = 3.0, 0.01, 0.02
    # static: a moment M turns the node by M / kt, exactly, up to nearly pi
    b = rotor(kt, ct, J)
    b.add_load(0, moment=(0.0, 0.0, 2.5 * kt))
    q = pf.static_equilibrium(b.build()).state
    assert np.arctan2(q.rotation(0)[1, 0], q.rotation(0)[0, 0]) == pytest.approx(2.5, rel=1e-10)
    # eigenvalues of J th'' + ct th' + kt th = 0
    model = rotor(kt, ct, J).build()
    lam = pf.eigenvalues(pf.linearize(model)).values
    z = ct / (2 * J)
    assert np.min(np.abs(lam - (-z + 1j * np.sqrt(kt / J - z * z)))) <= 1e-10 * np.sqrt(kt / J)
    # a swing of 2.5 rad (re-based on the way): the linear oscillator's solution, energy conserved
    undamped = rotor(kt, 0.0, J).build()
    w = np.sqrt(kt / J)
    res = pf.simulate(undamped, 1.0, state=turned(undamped, 2.5), integrator="generalized_alpha", step=2e-4,
                      rho_inf=1.0, n_outputs=101)
    theta = np.arctan2(res.R[:, 0, 1, 0], res.R[:, 0, 0, 0])
    assert np.abs(theta - 2.5 * np.cos(w * res.t)).max() <= 5e-5 * 2.5
    assert res.stats["rebases"] > 0  # the rotation from the reference passes through the re-based frames
    E = res.kinetic + res.elastic
    assert E[0] == pytest.approx(0.5 * kt * 2.5**2, rel=1e-12)
    assert np.abs(E - E[0]).max() <= 1e-12 * E[0]
    res = pf.simulate(model, 1.0, state=turned(model, 2.5), integrator="ida", rtol=1e-9, atol=1e-12, n_outputs=101)
    theta = np.arctan2(res.R[:, 0, 1, 0], res.R[:, 0, 0, 0])
    wd = np.sqrt(kt / J - z * z)
    expected = 2.5 * np.exp(-z * res.t) * (np.cos(wd * res.t) + z / wd * np.sin(wd * res.t))
    assert np.abs(theta - expected).max() <= 1e-6 * 2.5


def test_springs_at_ancf_nodes_in_series_and_parallel():
    """A planar ANCF cantilever (tip stiffness 3 EI / L^3) held at its tip by a ground
    spring (in parallel) and pulled through an axial spring to an ANCF node D (in series)."""
    k_ground, k_axial, P = 100.0, 50.0, 1e-4  # [N/m], [N/m], [N]
    b = pf.ModelBuilder()
    nodes = b.add_ancf_beam((0.0, 0.0, 0.0), (1.0, 0.0, 0.0), 4, pf.PipeSection(EI=10.0, EA=1e5, pipe_mass=1.0))
    b.clamp(nodes[0])
    b.add_ground_spring(nodes[-1], stiffness=(0.0, k_ground, 0.0), damping=(0.0, 1.0, 0.0))
    d = b.add_ancf_node((1.0, 0.5, 0.0))
    b.add_spring(nodes[-1], d, stiffness=k_axial, damping=0.5)
    b.fix(d, ["ux", "dx", "dy"])  # D moves along the spring (y) only: its slope belongs to no element
    b.add_load(d, force=(0.0, P, 0.0))
    model = b.build()
    q = pf.static_equilibrium(model).state.q
    tip = P / (3.0 * 10.0 / 1.0**3 + k_ground)
    assert q[6 * nodes[-1] + 1] == pytest.approx(tip, rel=1e-6)
    assert q[6 * d + 1] - 0.5 == pytest.approx(tip + P / k_axial, rel=1e-6)


def test_bad_input():
    b = pf.ModelBuilder()
    a, c = b.add_node((0.0, 0.0, 0.0)), b.add_node((1.0, 0.0, 0.0))
    same = b.add_node((1.0, 0.0, 0.0))
    for bad, rule in ((-1.0, "stiffness must be >= 0"), (np.nan, "stiffness must be finite")):
        with pytest.raises(ValueError, match=rule):
            b.add_spring(a, c, stiffness=bad)
    with pytest.raises(ValueError, match="damping must be >= 0"):
        b.add_spring(a, c, stiffness=1.0, damping=-0.1)
    with pytest.raises(ValueError, match="node_b refers to node 9"):
        b.add_spring(a, 9, stiffness=1.0)
    with pytest.raises(ValueError, match="coincide: an axial spring of zero length has no axis"):
        b.add_spring(c, same, stiffness=1.0)
    with pytest.raises(ValueError, match="both node 0"):
        b.add_spring(a, a, stiffness=1.0)
    with pytest.raises(ValueError, match=r"stiffness\[1\] must be >= 0"):
        b.add_ground_spring(a, stiffness=(1.0, -2.0, 0.0))
    with pytest.raises(ValueError, match=r"damping\[2\] must be finite"):
        b.add_ground_spring(a, stiffness=(1.0, 1.0, 1.0), damping=(0.0, 0.0, np.nan))
    with pytest.raises(ValueError, match="stiffness must be 3 numbers"):
        b.add_ground_spring(a, stiffness=5.0)
    with pytest.raises(ValueError, match="anchor must be finite"):
        b.add_ground_spring(a, stiffness=(1.0, 1.0, 1.0), anchor=(0.0, np.inf, 0.0))
    with pytest.raises(ValueError, match="needs a stiffness or a damping > 0"):
        b.add_ground_spring(a)
    with pytest.raises(ValueError, match=r"rotational_damping\[0\] must be >= 0"):
        b.add_ground_spring(a, rotational_damping=(-1.0, 0.0, 0.0))
    d = b.add_ancf_node((2.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="is an ANCF node: it has no rotation"):
        b.add_ground_spring(d, stiffness=(1.0, 1.0, 1.0), rotational_stiffness=(0.0, 0.0, 1.0))
    with pytest.raises(ValueError, match="node refers to node 5"):
        b.add_ground_spring(5, stiffness=(1.0, 1.0, 1.0))
    assert not b._springs  # nothing was added
    # the core refuses the same data
    core = _core.Model()
    n = core.add_node([0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="c must be a finite damping coefficient >= 0"):
        core.add_spring(n, core.add_node([1.0, 0.0, 0.0]), 1.0, -1.0)
    with pytest.raises(ValueError, match=r"damping\[0\] must be finite and >= 0"):
        core.add_ground_spring(n, [1.0, 1.0, 1.0], [np.nan, 0.0, 0.0])
    with pytest.raises(ValueError, match="node must be a node index"):
        core.add_ground_spring(7, [1.0, 1.0, 1.0], [0.0, 0.0, 0.0])
