"""Winkler foundations and distributed loads on floating-frame bodies: a section's
``k_found`` on :func:`~pipeflex.multibody.flexible_body` (cpp/src/ffrf_body.cpp,
ffrf_foundation_forces) and :meth:`MultibodyBuilder.add_distributed_load` (the weight
term's consistent load), checked against their energy, central differences, the element
models and beam theory."""
from dataclasses import replace

import numpy as np
import pytest

import pipeflex as pf
from pipeflex.multibody import MultibodyBuilder, flexible_body, static_equilibrium
from pipeflex.multibody.system import _foundation_energy
from pipeflex.rotation import rotation_exp

from helpers import part_of

G = 9.81  # [m/s^2]


def section(k_found=0.0, **extra):
    return pf.PipeSection(EI=50.0, EA=2e4, GJ=40.0, pipe_mass=2.0, k_found=k_found, **extra)


def two_bodies(k_found):
    """A straight body and a curved one (preimposed eta0), turned and placed apart,
    jointed; the foundation (if any) under both."""
    b = MultibodyBuilder()
    j0 = b.add_body(flexible_body(length=1.0, n_elements=4, internal_modes=2, section=section(k_found)),
                    position=(0.5, 0.0, 0.0))
    arc = flexible_body(length=0.8, n_elements=4, section=section(k_found), curvature=0.6)
    j1 = b.add_body(arc, position=(1.6, 0.3, 0.1), rotation=rotation_exp([0.2, -0.3, 0.4]))
    b.fix(j0, "start")
    b.add_spring(j0, "end", j1, "start", stiffness=10.0)  # (the system needs no joint for the foundation)
    return b.build()


def moved(system, seed=3, scale=1.0):
    rng = np.random.default_rng(seed)
    st = system.initial_state()
    for j in range(len(system.bodies)):
        st.r[j] += 0.05 * scale * rng.standard_normal(3)
        st.R[j] = rotation_exp(0.3 * scale * rng.standard_normal(3)) @ st.R[j]
        e = system.eta(st, j)
        e += 1e-2 * scale * rng.standard_normal(e.size)
    return st


@pytest.fixture(scope="module")
def systems():
    return two_bodies(300.0), two_bodies(0.0)


def test_no_force_in_the_reference_placement(systems):
    sys1, sys0 = systems
    F, _ = part_of(sys1, sys0, sys1.initial_state(), tangent=False)
    assert np.abs(F).max() <= 1e-12 * 300.0


def test_tangent_matches_central_differences(systems):
    sys1, sys0 = systems
    st = moved(sys1)
    F, K = part_of(sys1, sys0, st, wK=1.0, wC=0.0)
    h = 1e-6
    D = np.empty_like(K)
    for k in range(K.shape[1]):
        dq = np.zeros(K.shape[1])
        dq[k] = h
        plus, minus = st.copy(), st.copy()
        sys1.increment(plus, dq)
        sys1.increment(minus, -dq)
        D[:, k] = (part_of(sys1, sys0, plus, tangent=False)[0] -
                   part_of(sys1, sys0, minus, tangent=False)[0]) / (2 * h)
    scale = np.abs(K).max()
    assert scale > 10.0 and np.abs(F).max() > 1.0  # the foundation is there, and loaded
    assert np.abs(K - D).max() <= 1e-7 * scale


def test_forces_are_the_gradient_of_the_foundation_energy(systems):
    """The residual is dV/dq of V = k/2 int |r - r_ref|^2 ds (spatial increments), and the
    energy is the system's (energy())."""
    sys1, sys0 = systems
    st = moved(sys1, seed=7)
    F = part_of(sys1, sys0, st, tangent=False)[0]
    st0 = sys1.initial_state()

    def V(s):
        return sum(_foundation_energy(b.foundation, s.r[j], s.R[j], st0.r[j], st0.R[j], sys1.eta(s, j))
                   for j, b in enumerate(sys1.bodies))

    h = 1e-6
    grad = np.empty_like(F)
    for k in range(F.size):
        dq = np.zeros(F.size)
        dq[k] = h
        plus, minus = st.copy(), st.copy()
        sys1.increment(plus, dq)
        sys1.increment(minus, -dq)
        grad[k] = (V(plus) - V(minus)) / (2 * h)
    assert np.abs(F - grad).max() <= 1e-7 * np.abs(F).max()
    assert V(st) > 0.0 and V(st0) == pytest.approx(0.0, abs=1e-12)
    assert sys1.energy(st) - sys0.energy(st) == pytest.approx(V(st), rel=1e-10)


#: The foundation holds the centre line, not the twist about it: a torsional ground spring
#: [N m/rad] at the middle node holds that.
TWIST = 30.0


def test_energy_of_a_turned_deformed_arc_converges_to_the_integral():
    """An independent check of the constants (the products int N_j^T N_l of different
    axes among them): a preimposed arc (unreduced, so eta0 is the arc's nodal values),
    bent by u_z = c s^3 (exact in the Hermite shapes) and turned about a skew axis, has
    V -> k/2 int |R X(s) - X0(s)|^2 ds of the exact arc at the h^2 of the axial
    interpolation."""
    k, L, kappa, c = 300.0, 1.0, 1.0, 0.4
    x, w = np.polynomial.legendre.leggauss(200)
    s = 0.5 * L * x
    X0 = np.stack([np.sin(kappa * s) / kappa, (1.0 - np.cos(kappa * s)) / kappa, 0.0 * s])
    X = X0 + np.stack([0.0 * s, 0.0 * s, c * s**3])
    R = rotation_exp(0.3 * np.array([1.0, 2.0, 3.0]) / np.sqrt(14.0))
    d = R @ X - X0
    exact = 0.5 * k * np.sum(0.5 * L * w * np.sum(d * d, axis=0))
    errors = []
    for n in (16, 32):
        body = flexible_body(length=L, n_elements=n, section=pf.PipeSection(EI=5.0, pipe_mass=1.0, k_found=k),
                             curvature=kappa, reduction="full")
        U = np.zeros(6 * (n + 1))
        U[2::6] = c * body.nodes_s**3
        U[4::6] = -3.0 * c * body.nodes_s**2  # theta_y = -du_z/ds
        V = _foundation_energy(body.foundation, np.zeros(3), R, np.zeros(3), np.eye(3), body.eta0 + body.basis.T @ U)
        errors.append(abs(V / exact - 1.0))
    assert errors[1] < 3e-4 and 3.5 < errors[0] / errors[1] < 4.5


def element_frequencies(L, n, sec, count):
    eb = pf.ModelBuilder()
    nodes = eb.add_line(eb.add_node((-L / 2, 0.0, 0.0)), (L / 2, 0.0, 0.0), n, sec)
    eb.add_ground_spring(nodes[n // 2], rotational_stiffness=(TWIST, 0.0, 0.0))
    w = np.sort(np.abs(pf.eigenvalues(pf.linearize(eb.build())).values.imag))[::2]
    return w[:count]


def body_frequencies(bodies, count):
    """A chain of bodies along x, centred, rigidly joined; the twist spring at the middle
    (a node of the middle body, or the end of the body before it)."""
    b = MultibodyBuilder()
    x = -sum(bd.length for bd in bodies) / 2
    for k, bd in enumerate(bodies):
        b.add_body(bd, position=(x + bd.length / 2, 0.0, 0.0))
        x += bd.length
        if k:
            b.rigid(k - 1, "end", k, "start")
    middle = len(bodies) // 2
    b.add_ground_spring(middle, "center" if len(bodies) % 2 else "start", rotational_stiffness=(TWIST, 0.0, 0.0))
    return np.sort(np.abs(pf.eigenvalues(pf.linearize(b.build())).values.imag))[::2][:count]


def test_a_free_unreduced_body_on_a_foundation_has_the_element_models_frequencies():
    """No joint: the foundation holds the body (its rigid translations become modes of
    sqrt(k / mu))."""
    L, n, k, mu = 2.0, 10, 400.0, 1.5
    sec = pf.PipeSection(EI=50.0, EA=2e4, GJ=40.0, pipe_mass=mu, k_found=k, rotary_inertia=(2e-3, 1e-3, 1e-3))
    first = element_frequencies(L, n, sec, 12)
    assert np.isclose(first, np.sqrt(k / mu), rtol=1e-9).sum() >= 3  # the translations on the foundation
    w = body_frequencies([flexible_body(length=L, n_elements=n, section=sec, reduction="full")], 12)
    print("free body on a foundation: max rel. frequency difference", np.abs(w / first - 1.0).max())
    assert np.allclose(w, first, rtol=1e-6)


def test_a_chain_of_bodies_on_a_foundation_converges_to_the_element_model():
    L, n, k = 2.0, 16, 400.0
    sec = pf.PipeSection(EI=50.0, EA=2e4, GJ=40.0, pipe_mass=1.5, k_found=k, rotary_inertia=(2e-3, 1e-3, 1e-3))
    first = element_frequencies(L, n, sec, 10)
    unreduced = [flexible_body(length=L / 4, n_elements=n // 4, section=sec, reduction="full")] * 4
    w = body_frequencies(unreduced, 10)
    print("chain of 4 unreduced bodies: max rel. frequency difference", np.abs(w / first - 1.0).max())
    assert np.allclose(w, first, rtol=1e-6)
    # Craig-Bampton converges to it with the internal modes (12: all of them, the full body)
    errors = []
    for modes in (0, 6, 8, 12):
        bodies = [flexible_body(length=L / 4, n_elements=n // 4, section=sec, internal_modes=modes)] * 4
        errors.append(np.abs(body_frequencies(bodies, 10) / first - 1.0).max())
    print("chain of 4 Craig-Bampton bodies (0, 6, 8, 12 internal modes): max rel. frequency errors", errors)
    assert errors[0] < 1e-3 and np.all(np.diff(errors) < 0) and errors[2] < 1e-5 and errors[3] < 1e-10


# -- distributed loads ----------------------------------------------------------------


def cantilever(*, q=None, gravity=None, n_elements=8, modes=4, time_function=None):
    L = 1.0
    b = MultibodyBuilder()
    j = b.add_body(flexible_body(length=L, n_elements=n_elements, internal_modes=modes, section=section()),
                   position=(L / 2, 0.0, 0.0))
    b.fix(j, "start")
    if q is not None:
        b.add_distributed_load(j, force_per_length=q, time_function=time_function)
    if gravity is not None:
        b.set_gravity(gravity)
    return b.build()


def test_a_clamped_body_under_a_small_distributed_load_bends_by_q_l4_over_8_ei():
    q = 1e-4  # [N/m], small: linear
    system = cantilever(q=(0.0, 0.0, -q))
    res = static_equilibrium(system)
    w = system.node_position(res.state, 0, "end")[2]
    assert w == pytest.approx(-q * 1.0**4 / (8 * 50.0), rel=1e-6)


def test_a_distributed_load_of_mu_g_is_the_weight():
    mu = 2.0
    loaded = cantilever(q=(0.0, -0.3 * mu * G, -mu * G))
    heavy = cantilever(gravity=(0.0, -0.3 * G, -G))
    a, b = (static_equilibrium(s).state for s in (loaded, heavy))
    x_a, x_b = loaded.centre_line(a)[0], heavy.centre_line(b)[0]
    assert np.abs(x_b[-1, 1:]).max() > 1e-2  # a large deflection
    assert np.abs(x_a - x_b).max() <= 1e-12 * np.abs(x_b).max()


def test_a_distributed_load_follows_its_time_function_and_the_load_factor():
    q = np.array([0.0, 0.5, -2.0])
    system = cantilever(q=q, time_function=([0.0, 1.0], [0.0, 2.0]))  # s(0.5) = 1
    plain = cantilever(q=1.4 * q)
    st = replace(moved(system, seed=11, scale=0.2), t=0.5)
    F = system.evaluate(st, mass_flow=0.0, load_factor=0.7, tangent=False)[0]
    F2 = plain.evaluate(st, mass_flow=0.0, load_factor=0.5, tangent=False)[0]  # 0.7 s q = 0.5 (1.4 q)
    assert np.abs(F).max() > 0.1
    assert np.abs(F - F2).max() <= 1e-13 * np.abs(F).max()
    # its tangent (the frame turning under the dead load) against central differences
    K = system.evaluate(st, mass_flow=0.0, wK=1.0, wC=0.0)[3]
    h = 1e-6
    for k in (3, 4, 5, 7):
        dq = np.zeros(K.shape[1])
        dq[k] = h
        plus, minus = st.copy(), st.copy()
        system.increment(plus, dq)
        system.increment(minus, -dq)
        d = (system.evaluate(plus, mass_flow=0.0, tangent=False)[0] -
             system.evaluate(minus, mass_flow=0.0, tangent=False)[0]) / (2 * h)
        assert np.abs(K[:, k] - d).max() <= 1e-6 * np.abs(K).max()


def test_distributed_loads_and_foundations_survive_pickles():
    import pickle

    b = MultibodyBuilder()
    j = b.add_body(flexible_body(length=1.0, n_elements=4, section=section(200.0)), position=(0.0, 0.0, 0.0))
    b.add_distributed_load(j, force_per_length=(0.0, 0.0, -3.0), time_function=pf.Sine(envelope=1.0, omega=2.0))
    system = b.build()
    again = pickle.loads(pickle.dumps(system))
    st = moved(system, seed=2, scale=0.1)
    st = replace(st, t=0.3)
    F1 = system.evaluate(st, mass_flow=0.0, tangent=False)[0]
    F2 = again.evaluate(st, mass_flow=0.0, tangent=False)[0]
    assert np.array_equal(F1, F2)


def test_bad_input_names_the_argument():
    b = MultibodyBuilder()
    j = b.add_body(flexible_body(length=1.0, n_elements=4, section=section()), position=(0.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="body"):
        b.add_distributed_load(3, force_per_length=(0.0, 0.0, 1.0))
    with pytest.raises(ValueError, match="force_per_length"):
        b.add_distributed_load(j, force_per_length=(0.0, np.nan, 1.0))
    with pytest.raises(ValueError, match="time_function"):
        b.add_distributed_load(j, force_per_length=(0.0, 0.0, 1.0), time_function=([1.0, 0.0], [0.0, 1.0]))
    with pytest.raises(ValueError, match="no joints and no ground springs"):
        b.build()
    with pytest.raises(ValueError, match="k_found"):
        pf.PipeSection(EI=1.0, pipe_mass=1.0, k_found=-1.0)


def test_a_free_body_rocking_on_its_foundation_keeps_its_energy():
    """No joint, an initial rigid velocity: the foundation's forces are conservative, so
    the undamped generalised-alpha run (rho_inf = 1) keeps the energy (kinetic, elastic,
    the foundation's) to its time error."""
    sec = pf.PipeSection(EI=50.0, EA=2e4, GJ=40.0, pipe_mass=1.5, k_found=400.0, rotary_inertia=(2e-3, 1e-3, 1e-3))
    b = MultibodyBuilder()
    j = b.add_body(flexible_body(length=2.0, n_elements=6, section=sec, internal_modes=4), position=(0.0, 0.0, 0.0))
    b.add_ground_spring(j, "center", rotational_stiffness=(TWIST, 0.0, 0.0))
    system = b.build()
    st = system.initial_state()
    st.v[:6] = [0.1, 0.2, -0.3, 0.2, 0.1, 0.05]
    res = pf.simulate(system, 0.5, state=st, integrator="generalized_alpha", step=1e-3, rho_inf=1.0, n_outputs=6)
    E = np.array([system.energy(res.bodies.state(i)) for i in range(len(res.t))])
    assert np.abs(res.bodies.r[-1]).max() > 1e-3  # it moved
    assert np.abs(E / E[0] - 1.0).max() < 1e-5
