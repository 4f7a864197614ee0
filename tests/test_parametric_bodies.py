"""pf.parametric_stability and pf.instability_chart on floating-frame bodies: the pipe of
seed 004 (EI = 10 N m^2, 8 + 2 kg/m, EA = 2.5e4 N) as chains of bodies against the element
model of the same pipe, and the linearisation in the flow's rate that they need.

The bodies' Floquet matrices come from the same driver as the element model's (the
polynomial in mdot and mdot' from linearisations about the quasi-static equilibrium,
reduced with the mean-flow equilibrium's null-space basis). The fluid acceleration's axial
force N = -mdot' (L - x) stiffens each body through the body kernel's rate geometric
stiffness (tests/test_ffrf_rate_stiffness.py), so one body has the element model's tongue
and the independent Galerkin-Floquet solver's to well within 1 %.

Cost ~15 s on a busy 2-core machine.
"""
import numpy as np
import pytest
from scipy.optimize import brentq

import pipeflex as pf
from galerkin_floquet import Pipe
from pipeflex.analysis import parametric
from pipeflex.multibody import MultibodyBuilder, flexible_body
from pipeflex.seeds.seed004 import scenes

EPS = np.finfo(float).eps
#: seed 004's cantilever section (scenes.ffrf_cantilever_pipe's)
SECTION = scenes.ffrf_cantilever_pipe(n_bodies=1).bodies[0].section
#: the cantilever at u = mdot L / sqrt(M EI) = 4.5, below its flutter flow (~25 kg/s): the flow damps
CANT_FLOW = 20.0
#: the clamped-clamped pipe at a third of its buckling flow 2 pi sqrt(M EI) / L = 28.1 kg/s
CC_FLOW = 10.0


def element_pipe(n_elements, *, clamped_outlet=False):
    b = pf.ModelBuilder()
    root = b.add_node((0.0, 0.0, 0.0))
    nodes = b.add_line(root, (1.0, 0.0, 0.0), n_elements, SECTION)
    b.clamp(root)
    if clamped_outlet:
        b.clamp(nodes[-1])
    return b.build()


def clamped_chain(n_bodies, *, elements_per_body=4, internal_modes=2):
    body = flexible_body(length=1.0 / n_bodies, n_elements=elements_per_body, section=SECTION,
                         internal_modes=internal_modes)
    b = MultibodyBuilder()
    ids = [b.add_body(body, position=((k + 0.5) / n_bodies, 0.0, 0.0)) for k in range(n_bodies)]
    for k in range(n_bodies - 1):
        b.rigid(ids[k], "end", ids[k + 1], "start")
    b.fix(ids[0], "start")
    b.fix(ids[-1], "end")
    return b.build()


def test_linearize_takes_the_flow_rate_for_bodies():
    bodies = scenes.ffrf_cantilever_pipe(n_bodies=2, elements_per_body=4, internal_modes=2)
    eq = pf.static_equilibrium(bodies, mass_flow=CANT_FLOW)
    K = [pf.linearize(bodies, eq, mass_flow=CANT_FLOW, mass_flow_rate=r).unreduced[2].toarray()
         for r in (0.0, 1.0, 3.0)]
    change = K[1] - K[0]
    # the fluid's acceleration sddot reaches the bodies' stiffness, linearly
    assert np.abs(change).max() > 1e-3 * np.abs(K[0]).max() * EPS ** 0.5
    np.testing.assert_allclose(K[2] - K[0], 3 * change, rtol=0, atol=64 * EPS * np.abs(K[0]).max())
    with pytest.raises(ValueError, match="mass_flow_rate"):
        pf.linearize(bodies, eq, mass_flow=CANT_FLOW, mass_flow_rate=np.nan)


def tongue(model, mu, *, modes=8):
    """(omega_1, omega_2, the principal tongue of the second bending mode at amplitude mu:
    its edges [rad/s], largest modulus at 2 omega_2) of the cantilever at CANT_FLOW."""
    flow = parametric._FlowModel(model, CANT_FLOW)
    mats = flow.project(modes)
    w = parametric._frequencies(mats)  # the bending pairs: omega_1 twice, then omega_2 twice
    centre = 2 * w[2]
    g = lambda W: parametric._largest(mats, W, [mu], None)[0] - 1.0 - 1e-6
    # (the tongue leans to lower frequencies: its middle at 0.95 times 2 omega_2)
    edges = brentq(g, 0.7 * centre, 0.95 * centre, xtol=1e-7 * centre), \
        brentq(g, 0.95 * centre, 1.3 * centre, xtol=1e-7 * centre)
    return w[0], w[2], edges, mats


def test_seed004_cantilever_chains_converge_to_the_element_models_tongue():
    mu = 0.3
    w1, w2, ref, ref_mats = tongue(element_pipe(32), mu)
    assert ref[1] - ref[0] > 0.3 * w2  # a wide tongue to compare
    errors = []
    for n_bodies, per_body, modes in ((1, 20, 8), (4, 10, 2), (8, 4, 0)):
        chain = scenes.ffrf_cantilever_pipe(n_bodies=n_bodies, elements_per_body=per_body, internal_modes=modes)
        v1, v2, edges, mats = tongue(chain, mu)
        # the apices 2 omega_k: the frequencies of the flowing pipe agree (one body with 8
        # internal modes: 1.3e-3 and 2.9e-3; 8 bodies 1.2e-5, 1.5e-5)
        assert v1 == pytest.approx(w1, rel=3e-3) and v2 == pytest.approx(w2, rel=4e-3)
        errors.append(np.abs(np.array(edges) / np.array(ref) - 1.0).max())
        assert mats.fit_error < 0.03  # (the element model's: 0.01; this soft tube stretches)
        if n_bodies == 1:
            one_body = edges
    # measured: one body 4.9e-3, 4 bodies 4.3e-4, 8 bodies 2.2e-4 (without the rate's
    # geometric stiffness within each body: 0.18, 0.018, 0.0042)
    assert errors[0] < 1e-2 and errors[1] < 1e-3 and errors[2] < 5e-4
    # the independent Galerkin-Floquet solver (10 cantilever modes; its edges 25.537 and
    # 37.288 rad/s, the one body's 25.726 and 37.341): unstable 1.5 % inside the one
    # body's edges, stable 1.5 % outside
    oracle = Pipe("cantilever", EI=SECTION.EI, pipe_mass=SECTION.pipe_mass, fluid_mass=SECTION.fluid_mass,
                  n_modes=10)
    inside = [oracle.largest(CANT_FLOW, mu, f * W) for f, W in ((1.015, one_body[0]), (0.985, one_body[1]))]
    outside = [oracle.largest(CANT_FLOW, mu, f * W) for f, W in ((0.985, one_body[0]), (1.015, one_body[1]))]
    assert min(inside) > 1.01 and max(outside) < 0.99
    # the user's path on the 8 bodies: stable and unstable just outside and inside the
    # element model's edges (the chain's are within 0.03 % of them)
    W = [0.99 * ref[0], 1.01 * ref[0], 0.99 * ref[1], 1.01 * ref[1]]
    chart = pf.instability_chart(chain, mean_flow=CANT_FLOW, frequencies=W, amplitudes=[0.0, mu],
                                 executor="serial", progress=False)
    assert chart.unstable[:, 1].tolist() == [False, True, True, False]
    assert not chart.unstable[:, 0].any() and np.all(chart.largest[:, 0] <= 1.0 + 1e-10)
    assert chart.truncation_change < 3e-3  # (measured 1.2e-3 with up to 16 modes)


def test_clamped_chain_tongue_opens_from_zero_amplitude_as_the_element_models():
    chain = clamped_chain(4)
    r0 = pf.parametric_stability(chain, mean_flow=CC_FLOW, amplitude=0.0, frequency=10.0)
    # gyroscopic and undamped below the buckling flow: every multiplier on the unit circle
    assert r0.stable and len(r0.multipliers) == 16
    np.testing.assert_allclose(np.abs(r0.multipliers), 1.0, atol=1e-10)
    w1 = r0.natural_frequencies[0]
    element = pf.parametric_stability(element_pipe(16, clamped_outlet=True), mean_flow=CC_FLOW, amplitude=0.2,
                                      frequency=2 * w1)
    assert w1 == pytest.approx(element.natural_frequencies[0], rel=1e-3)
    W = np.array([0.98, 1.0, 1.02]) * 2 * w1
    chart = pf.instability_chart(chain, mean_flow=CC_FLOW, frequencies=W, amplitudes=[0.0, 0.02, 0.2],
                                 executor="serial", progress=False)
    np.testing.assert_allclose(chart.largest[:, 0], 1.0, atol=1e-10)
    # unstable at the apex however small mu, stable 2 % to either side at small mu
    assert chart.unstable[:, 1].tolist() == [False, True, False]
    assert chart.unstable[1, 2]
    # the growth at the apex, mu = 0.2 (measured: 1.04029 against 1.04059; 0.7 % of the growth)
    assert chart.largest[1, 2] == pytest.approx(element.largest, rel=1e-3)
    assert abs((chart.largest[1, 2] - 1) / (element.largest - 1) - 1) < 0.02
    # the chart's columns are parametric_stability's numbers
    one = pf.parametric_stability(chain, mean_flow=CC_FLOW, amplitude=0.2, frequency=W[1], check_modes=False)
    assert chart.largest[1, 2] == pytest.approx(one.largest, rel=64 * EPS)
    assert chart.fit_error < 0.03  # (the element model: 2e-3; the bodies 1.5e-2 at a rate 5 times the chart's)


def test_coupled_pipe_half_elements_half_bodies_matches_the_element_model():
    # the cantilever's root half as 8 elements, its outlet half as 4 bodies of 2 Hermite
    # elements each (boundary modes), joined rigidly: the same 16 elements' frequencies
    half = pf.ModelBuilder()
    root = half.add_node((0.0, 0.0, 0.0))
    nodes = half.add_line(root, (0.5, 0.0, 0.0), 8, SECTION)
    half.clamp(root)
    body = flexible_body(length=0.125, n_elements=4, section=SECTION, internal_modes=0)
    b = MultibodyBuilder()
    ids = [b.add_body(body, position=(0.5 + (k + 0.5) * 0.125, 0.0, 0.0)) for k in range(4)]
    for k in range(3):
        b.rigid(ids[k], "end", ids[k + 1], "start")
    coupled = pf.CoupledSystem(half.build(), b.build())
    coupled.rigid(nodes[-1], ids[0], "start")
    point = dict(mean_flow=CANT_FLOW, amplitude=0.3, frequency=30.0)  # inside the second mode's tongue
    ours = pf.parametric_stability(coupled, **point)
    theirs = pf.parametric_stability(element_pipe(16), **point)
    np.testing.assert_allclose(ours.natural_frequencies[:4], theirs.natural_frequencies[:4], rtol=1e-7)
    # measured 1.24869 against 1.24926 (0.2 % of the growth)
    assert not ours.stable and ours.largest == pytest.approx(theirs.largest, rel=1e-3)
    assert ours.fit_error < 0.01 and ours.truncation_change < 1e-2
