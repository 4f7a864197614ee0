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


def test_mechanism_is_reported_as_singular():
    b = pf.ModelBuilder()
    n0 = b.add_node((0, 0, 0))
    nodes = b.add_line(n0, (1, 0, 0), 2, pf.PipeSection(EI=1.0, pipe_mass=1.0))
    b.pin(n0)  # free to rotate about the pin: a mechanism
    b.add_load(nodes[-1], force=(0.0, 1.0, 0.0))
    model = b.build()
    with pytest.raises(pf.ConvergenceError, match="load factor.*singular"):
        pf.static_equilibrium(model, max_bisections=1)
