"""Static equilibrium: linear limit, large rotations (a full circle), failure reports."""
import numpy as np
import pytest

import pipeflex as pf


def cantilever(n, *, EI=2.0, L=1.0):
    b = pf.ModelBuilder()
    n0 = b.add_node((0, 0, 0))
    nodes = b.add_line(n0, (L, 0, 0), n, pf.PipeSection(EI=EI, pipe_mass=1.0, EA=1e9))
    b.clamp(n0)
    return b, nodes


def test_small_tip_force_gives_beam_theory_deflection():
    b, nodes = cantilever(4)
    b.add_load(nodes[-1], force=(0.0, 1e-6, 0.0))
    model = b.build()
    st = pf.static_equilibrium(model).state
    tip = st.q[6 * nodes[-1]: 6 * nodes[-1] + 3]
    assert tip[1] == pytest.approx(1e-6 / (3 * 2.0), rel=1e-6)  # P L^3 / (3 EI)


@pytest.mark.parametrize("follower", [False, True])
def test_tip_moment_rolls_the_beam_into_a_full_circle(follower):
    """M = 2 pi EI / L bends the cantilever into one full circle: the tip returns to the
    root after a full turn, far past the rotation vector's pi (re-based rotations). The
    element's bending strain is l0 sin(beta) per element, so the closure error falls
    with the square of the element size."""
    EI, L = 2.0, 1.0
    gaps = []
    for n in (24, 48):
        b, nodes = cantilever(n, EI=EI, L=L)
        b.add_load(nodes[-1], moment=(0.0, 0.0, 2 * np.pi * EI / L), follower=follower)
        st = pf.static_equilibrium(b.build(), load_steps=8).state
        gaps.append(np.linalg.norm(st.q[6 * nodes[-1]: 6 * nodes[-1] + 3]))
        # the tip's x axis has turned through a full circle (within the same error)
        assert np.allclose(st.rotation(nodes[-1])[:, 0], (1.0, 0.0, 0.0), atol=0.1 * (24 / n) ** 2)
        # half-way the beam points backwards
        assert np.allclose(st.rotation(nodes[n // 2])[:, 0], (-1.0, 0.0, 0.0), atol=0.05 * (24 / n) ** 2)
    assert gaps[1] < 5e-3 * L
    assert gaps[0] / gaps[1] == pytest.approx(4.0, rel=0.05)


def test_static_failure_names_the_load_factor():
    # Newton on a huge follower moment in one step with one iteration allowed: fails, and
    # the message says at which load factor and why.
    b, nodes = cantilever(4)
    b.add_load(nodes[-1], moment=(0.0, 0.0, 50.0), follower=True)
    with pytest.raises(pf.ConvergenceError, match=r"load factor .* after 1 iterations: no convergence"):
        pf.static_equilibrium(b.build(), max_iterations=1, max_bisections=0)


def test_a_flow_without_equilibrium_near_rest_is_followed_from_rest():
    """A free semicircular pipe at 10 kg/s: its flow's forces, applied at once to the
    reference configuration, have no equilibrium near it (Newton diverges); the default
    then follows the flow from rest, reaching what from_mass_flow=0 reaches, in any number
    of steps (tip moved from (0, 1) to about (1.08, -1.02) m with 8 elements; 16: (1.10, -1.00))."""
    sec = pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0, EA=1e5, GJ=8.0, rotary_inertia=(1e-3, 1e-3, 1e-3))
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    b.add_arc(n0, center=(0.0, 0.5, 0.0), angle=np.pi, normal=(0, 0, 1), n_elements=8, section=sec)
    b.clamp(n0)
    m = b.build(mass_flow=10.0)
    with pytest.raises(pf.ConvergenceError, match="load factor .*Newton diverged"):
        pf.static_equilibrium(m, path="load")  # the full flow at once, without the fallback
    direct = pf.static_equilibrium(m, from_mass_flow=0.0)
    ramped = direct.state.q
    for steps in (1, 4):
        res = pf.static_equilibrium(m, load_steps=steps)
        assert np.abs(res.state.q - ramped).max() < 1e-9
        assert res.iterations > direct.iterations  # the failed first attempt's iterations counted too
    tip = np.asarray(ramped)[-6:-4]
    assert np.allclose(tip, (1.0835, -1.0236), atol=1e-3)


def test_mechanism_is_reported_as_singular():
    b = pf.ModelBuilder()
    n0 = b.add_node((0, 0, 0))
    nodes = b.add_line(n0, (1, 0, 0), 2, pf.PipeSection(EI=1.0, pipe_mass=1.0))
    b.pin(n0)  # free to rotate about the pin: a mechanism
    b.add_load(nodes[-1], force=(0.0, 1.0, 0.0))
    model = b.build()
    with pytest.raises(pf.ConvergenceError, match="load factor.*singular"):
        pf.static_equilibrium(model, max_bisections=1)


def test_self_weight_deflection():
    """Cantilever under its own weight: tip deflection q L^4 / (8 EI) (small load)."""
    EI, L, m, g = 50.0, 1.0, 0.2, 9.81
    b = pf.ModelBuilder()
    n0 = b.add_node((0, 0, 0))
    nodes = b.add_line(n0, (L, 0, 0), 8, pf.PipeSection(EI=EI, pipe_mass=m * 0.75, fluid_mass=m * 0.25, EA=1e10))
    b.clamp(n0)
    b.set_gravity((0.0, 0.0, -g * 1e-4))
    st = pf.static_equilibrium(b.build()).state
    w = st.q[6 * nodes[-1] + 2]
    assert w == pytest.approx(-m * g * 1e-4 * L**4 / (8 * EI), rel=1e-5)


def test_shear_flexible_cantilever_adds_shear_deflection():
    """Timoshenko cantilever with a tip force: P L^3 / (3 EI) + P L / (k G A), exact for
    the element's shear factors (eq. 7)."""
    EI, GA, L, P = 2.0, 30.0, 1.0, 1e-6
    b = pf.ModelBuilder()
    n0 = b.add_node((0, 0, 0))
    nodes = b.add_line(n0, (L, 0, 0), 3, pf.PipeSection(EI=EI, GAy=GA, GAz=GA, pipe_mass=1.0, EA=1e10))
    b.clamp(n0)
    b.add_load(nodes[-1], force=(0.0, P, P))
    st = pf.static_equilibrium(b.build()).state
    exact = P * L**3 / (3 * EI) + P * L / GA
    assert st.q[6 * nodes[-1] + 1] == pytest.approx(exact, rel=1e-6)
    assert st.q[6 * nodes[-1] + 2] == pytest.approx(exact, rel=1e-6)


def test_tip_torque_twists_by_TL_over_GJ():
    GJ, L, T = 4.0, 2.0, 1e-5
    b = pf.ModelBuilder()
    n0 = b.add_node((0, 0, 0))
    nodes = b.add_line(n0, (L, 0, 0), 2, pf.PipeSection(EI=1.0, GJ=GJ, pipe_mass=1.0))
    b.clamp(n0)
    b.add_load(nodes[-1], moment=(T, 0.0, 0.0))
    st = pf.static_equilibrium(b.build()).state
    assert st.q[6 * nodes[-1] + 3] == pytest.approx(T * L / GJ, rel=1e-6)


def test_pressure_coupling_stiffens_axially():
    from pipeflex.sections import pressure_coupling_factor

    kw = dict(outer_diameter=0.0508, inner_diameter=0.0472, E=208e9, G=80e9, density=8027.0, fluid_density=1000.0)
    plain = pf.PipeSection.tube(**kw)
    coupled = pf.PipeSection.tube(**kw, fluid_bulk_modulus=2.2e9)
    nu = 208 / 160 - 1
    t, r = 0.0018, 0.0245
    d = 5 - 4 * nu + 2 * 208e9 * t / (2.2e9 * r)
    assert coupled.EA / plain.EA == pytest.approx(1 / (1 - (1 - 2 * nu) ** 2 / d), rel=1e-12)
    # an incompressible fluid in a thin tube of an incompressible material adds nothing
    assert pressure_coupling_factor(E=1.0, G=1.0 / 3.0, wall=1.0, radius=1.0, bulk_modulus=1e300) == pytest.approx(1.0)
    assert coupled.EA > plain.EA
