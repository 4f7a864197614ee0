"""An element type added through the element interface only: the linear axial spring
(``_core.Model.add_spring``, cpp/src/axial_spring.cpp), assembled, solved and integrated
together with pipe elements by the unchanged solvers."""
import numpy as np
import pytest

import pipeflex as pf
from pipeflex import _core

from helpers import residual_columns

L, EI, N_EL = 2.0, 40.0, 4  # cantilever length [m], bending stiffness [N m^2], elements
SECTION = pf.PipeSection(EI=EI, EA=4e5, GJ=30.0, pipe_mass=1.5, fluid_mass=0.5, rotary_inertia=(1e-3, 0.0, 0.0))
NO_MOMENT = np.zeros(3)


def spring_model(k, *, spring_end, load_node, force, gravity=(0.0, 0.0, 0.0)):
    """A cantilever pipe along x (nodes 0..N_EL, clamped at 0), and a node C at
    (L, h, 0) joined to the tip by an axial spring of stiffness k [N/m] along y.
    spring_end "free": C moves along y only (the spring in series with the pipe);
    "clamped": C is fixed (in parallel). A dead force [N] at load_node."""
    b = pf.ModelBuilder()
    root = b.add_node((0.0, 0.0, 0.0))
    b.add_line(root, (L, 0.0, 0.0), N_EL, SECTION)
    b.clamp(root)
    pipe = b.build()
    positions = np.vstack([pipe.positions, [L, 0.3, 0.0]])
    c = len(positions) - 1
    core = _core.Model()
    core.add_nodes(positions)
    for e in range(N_EL):
        core.add_pipe(e, e + 1, pipe.core.pipe(e))
    assert core.add_spring(N_EL, c, k) == 0
    core.add_load(load_node, force, NO_MOMENT, NO_MOMENT, NO_MOMENT)
    eye = np.eye(6)
    bases = [eye[:, []]] + [eye] * N_EL + [eye[:, [1]] if spring_end == "free" else eye[:, []]]
    core.set_bases(bases)
    core.finalize()
    model = pf.Model(core, positions, pipe.elements, bases, 0.0, np.array(gravity, dtype=float))
    return model, c


@pytest.mark.parametrize("spring_end", ["free", "clamped"])
def test_static_deflection_is_the_series_or_parallel_stiffness(spring_end):
    k, F = 120.0, 1e-3  # [N/m], [N]: small, so that the geometric nonlinearity is ~1e-9
    k_pipe = 3.0 * EI / L**3  # tip stiffness of the cantilever (Euler-Bernoulli: exact for cubic elements)
    load_node = N_EL + 1 if spring_end == "free" else N_EL  # C, or the pipe's tip
    model, c = spring_model(k, spring_end=spring_end, load_node=load_node, force=(0.0, F, 0.0))
    res = pf.static_equilibrium(model)
    x = np.asarray(res.state.q).reshape(-1, 6)[:, :3] - model.positions
    if spring_end == "free":  # the force at C goes through the spring, then the pipe
        expected, node = F * (1.0 / k + 1.0 / k_pipe), c
    else:  # pipe and spring both hold the tip
        expected, node = F / (k + k_pipe), N_EL
    assert x[node, 1] == pytest.approx(expected, rel=1e-7)
    # without the spring the deflection would be the pipe's alone: the check can fail
    assert abs(x[node, 1] - F / k_pipe) > 0.1 * expected


def test_tangent_matches_central_differences():
    k = 5e3
    model, c = spring_model(k, spring_end="free", load_node=N_EL + 1, force=(0.0, 2.0, 0.0), gravity=(0, 0, -9.81))
    rng = np.random.default_rng(3)
    s = model.initial_state()
    # a stretched and turned spring: its geometric stiffness N / l (I - e e^T) takes part
    _core.add_increment(model.core, s, 0.05 * rng.standard_normal(model.n_dofs), "q")
    load = model.load_state()
    r0, (i, j, v) = _core.assemble(model.core, s, load, 1.0, 1.0, 0.0, 0.0)
    n = model.n_dofs
    K = np.zeros((n, n))
    np.add.at(K, (i, j), v)
    Kfd = residual_columns(model, s, load, "q", 1e-6)
    scale = np.abs(K).max()
    assert np.abs(K - Kfd).max() <= 1e-6 * scale
    # the spring's own block: C's one coordinate (uy) against itself is k e_y^2 + N/l (1 - e_y^2)
    d = s.q[6 * c:6 * c + 3] - s.q[6 * N_EL:6 * N_EL + 3]
    length = np.linalg.norm(d)
    e = d / length
    N = k * (length - 0.3)
    assert K[-1, -1] == pytest.approx(k * e[1] ** 2 + N / length * (1 - e[1] ** 2), rel=1e-12)


def test_energy_is_conserved_in_a_transient_without_flow():
    """A step load on the tip held by a spring to the ground, from rest: kinetic plus
    elastic energy (the spring's included) equals the load's work."""
    k, F = 60.0, 0.5
    model, _ = spring_model(k, spring_end="clamped", load_node=N_EL, force=(0.0, F, 0.0))
    res = pf.simulate(model, 0.5, step=2e-4, rho_inf=1.0, n_outputs=51)
    balance = res.kinetic + res.elastic - res.load_work
    scale = res.load_work.max()
    spring = 0.5 * k * res.x[:, N_EL, 1] ** 2  # the spring's share of U (its stretch: the tip's uy)
    assert scale > 0 and spring.max() > 0.1 * res.elastic.max()
    assert np.abs(balance).max() <= 1e-4 * scale
    # the tip swings about the static deflection F / (k + 3 EI / L^3), to about twice it
    static = F / (k + 3 * EI / L**3)
    assert 1.5 * static < res.x[:, N_EL, 1].max() < 2.3 * static


def test_spring_input_and_type_access():
    core = _core.Model()
    a, b = core.add_node([0.0, 0.0, 0.0]), core.add_node([1.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="k must be a finite stiffness >= 0"):
        core.add_spring(a, b, -1.0)
    with pytest.raises(ValueError, match="node_b must be a node index"):
        core.add_spring(a, 5, 1.0)
    same = core.add_node([0.0, 0.0, 0.0])
    core.add_spring(a, same, 1.0)
    with pytest.raises(ValueError, match="nodes must be apart"):
        core.finalize()
    # the pipe and ANCF accessors count their own type only
    model, _ = spring_model(10.0, spring_end="free", load_node=N_EL + 1, force=(0.0, 1.0, 0.0))
    state = model.initial_state()
    model.core.add_spring(0, N_EL, 1.0)  # a change of the structure: refused until finalize()
    with pytest.raises(ValueError, match="not finalized"):
        _core.assemble(model.core, state, model.load_state(), 1.0, 1.0, 0.0, 0.0)
    model.core.finalize()
    assert model.core.pipe(N_EL - 1).l0 == pytest.approx(L / N_EL)
    with pytest.raises(ValueError, match=r"pipe element index must be in \[0, 4\)"):
        model.core.pipe(N_EL)
    with pytest.raises(ValueError, match=r"ANCF element index must be in \[0, 0\)"):
        model.core.ancf_nodes(0)
