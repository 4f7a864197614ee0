"""The elastic (Winkler) foundation per unit length, PipeSection.k_found [N/m^2], of the 3D
pipe element and the planar ANCF beam: tangents against differences of the residual,
the simply supported beam's frequencies and the long beam's point-load deflection against
their closed forms, the flow path, energy conservation and zero stiffness."""
import numpy as np
import pytest

import pipeflex as pf
from pipeflex import _core

from helpers import residual_columns
from helpers import assembled_matrix as matrix, assembled_residual as residual, moving_state as moving


def arc(**extra):
    """A clamped quarter arc of three pipe elements with flow."""
    sec = pf.PipeSection(EI=7.0, EIz=11.0, EA=3e3, GJ=5.0, pipe_mass=1.3, fluid_mass=0.7, kv=1.1,
                         rotary_inertia=(0.02, 0.01, 0.015), **extra)
    b = pf.ModelBuilder()
    n0 = b.add_node((0.1, -0.2, 0.3))
    b.add_arc(n0, center=(0.1, 0.8, 0.3), angle=np.pi / 2, normal=(0, 0, 1), n_elements=3, section=sec)
    b.clamp(n0)
    return b.build(mass_flow=1.5)


@pytest.mark.parametrize("bad", [-1.0, np.nan, np.inf])
def test_bad_stiffness_is_refused_by_name(bad):
    with pytest.raises(ValueError, match="k_found"):
        pf.PipeSection(EI=1.0, pipe_mass=1.0, k_found=bad)


def test_the_floating_frame_body_takes_it():
    """(Its forces, tangent and frequencies: tests/test_body_foundation.py.)"""
    from pipeflex.multibody import flexible_body
    body = flexible_body(length=1.0, n_elements=2, section=pf.PipeSection(EI=1.0, pipe_mass=1.0, k_found=3.0))
    assert body.foundation["kL"] == 3.0


def test_pipe_tangent_matches_differences_of_the_residual():
    """K on a moving, rotated curved arc with flow and viscous damping: the foundation's
    force depends on the node rotations through the Hermite slopes."""
    model = arc(k_found=40.0, c_ext=0.3)
    s = moving(model)
    K = matrix(model, s, 1.0, 0.0)
    Kd = residual_columns(model, s, model.load_state(), "q", 1e-6)
    col = np.abs(K).max(axis=0)
    assert (np.abs(K - Kd).max(axis=0) / col).max() < 1e-6
    # the differences can tell: the foundation's own terms are far above that tolerance
    dK = K - matrix(arc(c_ext=0.3), s, 1.0, 0.0)
    assert (np.abs(dK).max(axis=0) / col).max() > 1e-2
    # several weight sets at once (pipe_tangents) agree with one at a time
    both = matrix(model, s, 0.3, 0.7, 0.2)
    assert np.abs(both - (0.3 * K + 0.7 * matrix(model, s, 0.0, 1.0) + 0.2 * matrix(model, s, 0.0, 0.0, 1.0))).max() \
        <= 1e-12 * np.abs(both).max()


def test_pipe_hand_tangent_equals_forward_ad_of_the_residual():
    model = arc(k_found=40.0)
    d = model.core.pipe(1)
    assert d.k_found == 40.0
    rng = np.random.default_rng(3)
    x = model.positions
    q = np.concatenate([x[1] + 0.02 * rng.standard_normal(3), 0.3 * rng.standard_normal(3),
                        x[2] + 0.02 * rng.standard_normal(3), 0.3 * rng.standard_normal(3)])
    v, a = rng.standard_normal(12), rng.standard_normal(12)
    ld = _core.LoadState()
    frames = model.initial_state().frames
    r, J = _core.pipe_tangent(d, frames[1], frames[2], ld, q, v, a, 1.0, 0.0, 0.0)
    r_ad, J_ad = _core.pipe_tangent_ad(d, frames[1], frames[2], ld, q, v, a, 1.0, 0.0, 0.0)
    assert np.abs(r - r_ad).max() <= 1e-13 * np.abs(r).max()
    assert np.abs(J - J_ad).max() <= 1e-12 * np.abs(J).max()


@pytest.mark.parametrize("elastic", ["A", "0"])
def test_ancf_tangent_matches_differences(elastic):
    def model_of(k):
        b = pf.ModelBuilder()
        nodes = b.add_ancf_beam((0, 0, 0), (1.2, 0.3, 0), 3, pf.PipeSection(EI=2.0, EA=4e3, pipe_mass=0.8, k_found=k),
                                elastic=elastic)
        b.fix(nodes[0], ["ux", "uy"])
        return b.build()

    model = model_of(5e3)
    s = moving(model, seed=5)
    K = matrix(model, s, 1.0, 0.0)
    Kd = residual_columns(model, s, model.load_state(), "q", 1e-6)
    assert np.abs(K - Kd).max() <= 1e-6 * np.abs(K).max()
    assert np.abs(K - matrix(model_of(0.0), s, 1.0, 0.0)).max() > 1e-2 * np.abs(K).max()
    # at the reference the foundation exerts no force (e0 = the built coordinates)
    s0 = model.initial_state()
    assert np.array_equal(residual(model, s0), residual(model_of(0.0), s0))


def simply_supported(k_found, *, n_elements=32, L=1.0, EI=2.0, m=1.5):
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    nodes = b.add_line(n0, (L, 0.0, 0.0), n_elements,
                       pf.PipeSection(EI=EI, pipe_mass=m, EA=1e6, GJ=1.0, k_found=k_found))
    b.pin(nodes[0])
    b.pin(nodes[-1])
    b.fix_rotation(nodes[0], (1.0, 0.0, 0.0))  # no free twist
    return b.build()


def test_simply_supported_frequencies_match_the_closed_form():
    """omega_n^2 = (EI (n pi / L)^4 + k_f) / m for bending in both planes, 32 elements
    (measured: 1e-8, 8e-7, 5e-6 relative for n = 1, 2, 3)."""
    L, EI, m, k = 1.0, 2.0, 1.5, 900.0
    w = np.sort(pf.eigenvalues(pf.linearize(simply_supported(k, L=L, EI=EI, m=m))).frequencies)
    exact = np.sqrt((EI * (np.arange(1, 4) * np.pi / L) ** 4 + k) / m)
    bending = w[w < 1.01 * exact[-1]][:6]  # the torsional and axial modes lie far above
    np.testing.assert_allclose(bending, np.repeat(exact, 2), rtol=1e-4)
    # the foundation raises the first frequency visibly (by 40 % here)
    w0 = np.sort(pf.eigenvalues(pf.linearize(simply_supported(0.0, L=L, EI=EI, m=m))).frequencies)[0]
    assert bending[0] > 1.3 * w0


def test_long_beam_point_load_matches_hetenyi():
    """Half of a long beam (symmetry at the load: slope and axial motion held), point load
    P at its middle: w(0) = P beta / (2 k_f), beta = (k_f / (4 EI))^(1/4), beta L_half = 14
    (measured: 2.4e-7 relative with 160 elements, 3.9e-6 with 80)."""
    EI, k, P = 1.0, 1e4, 1e-3
    beta = (k / (4 * EI)) ** 0.25
    half = 14.0 / beta
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    b.add_line(n0, (half, 0.0, 0.0), 160, pf.PipeSection(EI=EI, pipe_mass=1.0, EA=1e6, GJ=1.0, k_found=k))
    b.fix(n0, ["ux", "uz", "rx", "ry", "rz"])
    b.add_load(n0, force=(0.0, -P / 2, 0.0))
    model = b.build()
    st = pf.static_equilibrium(model).state
    w = -np.asarray(st.q).reshape(-1, 6)[n0, 1]
    assert w == pytest.approx(P * beta / (2 * k), rel=1e-3)


def cantilever(k_found, n_elements=16):
    b = pf.ModelBuilder()
    root = b.add_node((0.0, 0.0, 0.0))
    b.add_line(root, (1.0, 0.0, 0.0), n_elements,
               pf.PipeSection(EI=1.0, pipe_mass=0.8, fluid_mass=0.2, k_found=k_found))
    b.clamp(root)
    return b.build()


def test_the_critical_flow_rises_with_the_foundation():
    # measured: 2.501, 2.609, 3.041 kg/s
    u = [pf.critical_mass_flow(cantilever(k), tol=1e-8).mass_flow for k in (0.0, 20.0, 80.0)]
    assert u[0] < u[1] < u[2]
    assert u[2] > 1.05 * u[0]


def test_energy_is_conserved_without_flow():
    """A free swing on a strong foundation: kinetic + elastic energy (the foundation's
    included) constant to the integrator's accuracy; the foundation's energy is a large
    part of it, so leaving it out would fail by far."""
    b = pf.ModelBuilder()
    n0 = b.add_node((0, 0, 0))
    nodes = b.add_line(n0, (1, 0, 0), 4, pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0, EA=1e4, GJ=8.0,
                                                        rotary_inertia=(1e-2, 1e-3, 1e-3), k_found=500.0))
    b.clamp(n0)
    model = b.build()
    st = model.initial_state()
    v = np.zeros(model.n_dofs)
    v[model.dof_index(nodes[-1], "uy")] = 1.0
    v[model.dof_index(nodes[-1], "uz")] = 0.5
    st.v = model.basis @ v
    r = pf.simulate(model, 1.0, integrator="ida", state=st, rtol=1e-10, atol=1e-12, n_outputs=50, progress=False)
    E = np.asarray(r.energy)
    assert np.abs(E - E[0]).max() <= 1e-6 * E[0]  # measured: 2e-8


def test_zero_stiffness_gives_the_numbers_without_a_foundation():
    """k_found = 0 is skipped: residual and tangents bit for bit those of no foundation, on
    the pipe element and on the ANCF beam; a foundation at rest in the reference adds no force."""
    model, zero = arc(), arc(k_found=0.0)
    s = moving(model)
    assert np.array_equal(residual(model, s), residual(zero, s))
    assert np.array_equal(matrix(model, s, 0.3, 0.7, 0.2), matrix(zero, s, 0.3, 0.7, 0.2))
    assert zero.core.pipe(0).k_found == 0.0
    ref = arc(k_found=40.0)
    s0 = ref.initial_state()
    assert np.abs(residual(ref, s0) - residual(model, s0)).max() <= 1e-12 * max(1.0, np.abs(residual(model, s0)).max())


def test_model_files_read_the_foundation(tmp_path):
    path = tmp_path / "m.yaml"
    path.write_text("sections:\n  s: {EI: 1.0, pipe_mass: 1.0, k_found: 25.0}\ngeometry:\n  - node: [0, 0, 0]\n"
                    "  - line: {start: 0, end: [1, 0, 0], n_elements: 4, section: s}\nsupports:\n  - clamp: 0\n")
    assert pf.load_model(path).core.pipe(0).k_found == 25.0
    path.write_text(path.read_text().replace("k_found: 25.0", "k_found: -1.0"))
    with pytest.raises(ValueError, match="k_found"):
        pf.load_model(path)
