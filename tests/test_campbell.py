"""Campbell diagrams: branches followed by mode shape (MAC), crossings with omega = k Omega."""
import importlib
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

import pipeflex as pf
from pipeflex.analysis.campbell import Campbell, mac, rotating_modes


@pytest.fixture(scope="module")
def ancf():
    beam = pf.scenes.rotating_cantilever()
    return beam, pf.campbell(beam, gamma=np.linspace(0.0, 8.0, 17), n_modes=4)


def test_mac_of_known_vectors():
    a = np.array([1.0, 0.0, 0.0])
    b = np.array([1.0, 1.0, 0.0])
    assert mac(a, b)[0, 0] == pytest.approx(0.5, abs=1e-15)
    assert mac(a, 2j * a)[0, 0] == pytest.approx(1.0, abs=1e-15)  # scale and phase do not matter
    assert mac(a, np.array([0.0, 0.0, 1.0]))[0, 0] == 0.0


def test_crossing_with_omega_equals_Omega_is_the_resonance_speed(ancf):
    """Berzeri & Shabana, Sec. 7: omega_1 = Omega at gamma = 3.876 (docs/user_guide.md)."""
    beam, c = ancf
    g_res = pf.resonance_speed(beam)
    assert g_res == pytest.approx(3.876, abs=5e-4)
    assert c.family[0] == "in-plane"
    w0 = beam.info["omega0"]
    assert c.crossing(1, 0) / w0 == pytest.approx(g_res, rel=1e-6)  # cubic spline between gamma 3.5 and 4
    k, b, s, w = [x for x in c.crossings if x[0] == 1 and x[1] == 0][0]
    assert w == pytest.approx(s)  # on the line omega = Omega
    # the lines 2 Omega and 3 Omega are crossed earlier, at lower speeds
    assert c.crossing(3, 0) < c.crossing(2, 0) < c.crossing(1, 0)
    assert np.isnan(c.crossing(1, 3))  # the fourth in-plane mode is far above Omega up to gamma = 8


def test_frequencies_are_those_of_rotating_frequencies(ancf):
    beam, c = ancf
    r = pf.rotating_frequencies(beam, gamma=c.gamma, n_modes=4)
    np.testing.assert_allclose(c.frequencies / beam.info["omega0"], r.transverse, rtol=1e-12)
    assert c.mac.shape == (16, 4) and c.mac.min() > 0.999


def test_branches_stay_continuous_through_a_veering():
    """N = 4, R/L = 5: the second in-plane mode veers away from the first axial one near
    gamma = 6.15; with steps of 0.01 each branch turns smoothly into the other's shape."""
    beam = pf.scenes.rotating_cantilever(tip_mass_ratio=4, hub_radius_ratio=5)
    g = np.linspace(6.0, 6.4, 41)
    c = pf.campbell(beam, gamma=g, n_modes=4)
    assert c.mac.min() > 0.9
    lower = int(np.flatnonzero(c.family == "in-plane")[1])   # the branch that comes from below
    upper = int(np.flatnonzero(c.family == "axial")[0])
    radial = c.share[:, :, 0]
    assert radial[0, lower] < 0.01 and radial[-1, lower] > 0.95     # in-plane -> axial
    assert radial[0, upper] > 0.95 and radial[-1, upper] < 0.05     # axial -> in-plane
    gap = c.frequencies[:, upper] - c.frequencies[:, lower]
    assert gap.min() > 0  # they veer, never cross
    # continuous: each step of the two branches is smaller than the narrowest gap between
    # them (a jump to the other branch would be at least that)
    steps = np.abs(np.diff(c.frequencies[:, [lower, upper]], axis=0))
    assert steps.max() < 0.95 * gap.min()
    # no two of the four branches change order in this window
    assert np.all(np.argsort(c.frequencies, axis=1) == np.argsort(c.frequencies[0]))


def test_pipe_element_families_and_flapwise_branches():
    """3D pipe element (steady-state linearisation): in-plane and flapwise branches start
    together at rest and split; the flapwise ones are those of rotating_frequencies'
    out_of_plane, and the flapwise mode 1 never meets omega = Omega (its Southwell
    coefficient exceeds 1), the in-plane one does, near the ANCF resonance speed."""
    beam = pf.scenes.rotating_cantilever(formulation="pipe")
    g = np.linspace(0.0, 6.0, 13)
    c = pf.campbell(beam, gamma=g, n_modes=4)
    assert c.linearization == "steady_state"
    assert sorted(c.family) == ["flapwise", "flapwise", "in-plane", "in-plane"]
    r = pf.rotating_frequencies(beam, gamma=g, n_modes=2, linearization="steady_state")
    w0 = beam.info["omega0"]
    np.testing.assert_allclose(c.frequencies[:, c.family == "flapwise"] / w0, r.out_of_plane, rtol=1e-10)
    np.testing.assert_allclose(c.frequencies[:, c.family == "in-plane"] / w0, r.transverse, rtol=1e-10)
    flap = np.flatnonzero(c.family == "flapwise")
    assert np.all(c.share[:, flap, 2] > 0.99)
    assert np.isnan(c.crossing(1, flap[0]))
    inplane = int(np.flatnonzero(c.family == "in-plane")[0])
    assert c.crossing(1, inplane) / w0 == pytest.approx(pf.resonance_speed(pf.scenes.rotating_cantilever()),
                                                        rel=2e-3)


def test_shapes_follow_the_branch_not_the_order():
    """Where an in-plane branch passes the first axial mode in steps too coarse for the
    narrow veering, MAC keeps each on its own shape while sorting would swap them."""
    beam = pf.scenes.rotating_cantilever(tip_mass_ratio=4, hub_radius_ratio=5)
    c = pf.campbell(beam, gamma=np.linspace(4.0, 8.0, 9), n_modes=4)
    inplane, axial = int(np.flatnonzero(c.family == "in-plane")[1]), int(np.flatnonzero(c.family == "axial")[0])
    assert c.frequencies[0, inplane] < c.frequencies[0, axial] and c.frequencies[-1, inplane] > c.frequencies[-1, axial]
    assert np.all(c.share[:, inplane, 1] > 0.99) and np.all(c.share[:, axial, 0] > 0.9)
    assert c.mac.min() > 0.95


def test_save_load_and_executor(tmp_path, ancf):
    beam, c = ancf
    back = Campbell.load(c.save(tmp_path / "campbell"))
    assert back.family.tolist() == c.family.tolist() and back.crossings == c.crossings
    np.testing.assert_array_equal(back.modes, c.modes)
    with ThreadPoolExecutor(2) as ex:
        swept = pf.campbell(beam, gamma=np.linspace(0.0, 8.0, 17), n_modes=4, executor=ex)
    np.testing.assert_allclose(swept.frequencies, c.frequencies, rtol=1e-12)
    np.testing.assert_allclose(swept.crossing_speed, c.crossing_speed, rtol=1e-10)


def test_rotating_modes_at_one_speed():
    beam = pf.scenes.rotating_cantilever()
    m = rotating_modes(beam, omega=0.0)
    w = m["eigenvalue"].imag / beam.info["omega0"]
    inplane = w[np.argmax(m["share"], axis=1) == 1]
    assert inplane[0] == pytest.approx(3.5160, abs=5e-4)  # Table 2 of Berzeri & Shabana, N = 0
    assert m["shapes"].shape == (beam.n_dofs, len(w))


def test_bad_input():
    beam = pf.scenes.rotating_cantilever()
    with pytest.raises(ValueError, match="exactly one"):
        pf.campbell(beam)
    with pytest.raises(ValueError, match="exactly one"):
        pf.campbell(beam, gamma=[0, 1], omega=[0, 1])
    with pytest.raises(ValueError, match="ascending"):
        pf.campbell(beam, gamma=[1.0, 0.5])
    with pytest.raises(ValueError, match="small_deformation"):
        pf.campbell(pf.scenes.rotating_cantilever(formulation="pipe"), gamma=[0, 1], linearization="small_deformation")
    with pytest.raises(ValueError, match="rotating hub"):
        pf.campbell(pf.scenes.cantilever_pipe(n_elements=2), omega=[0, 1])


def test_sparse_path_equals_dense(monkeypatch):
    """From SPARSE_MIN_DOFS coordinates on each speed offers the 2 n_modes + 4 lowest modes
    (shift-invert Arnoldi) to the tracking: the same branches, MAC and crossings as with
    all modes (dense), serial and through the sweep (rotating_modes with n_modes)."""
    cb = importlib.import_module("pipeflex.analysis.campbell")  # pipeflex.analysis.campbell is the function
    beam = pf.scenes.rotating_cantilever(n_elements=64, tip_mass_ratio=4, hub_radius_ratio=5)
    assert beam.n_dofs >= cb.SPARSE_MIN_DOFS
    g = np.linspace(4.0, 8.0, 5)
    sparse = pf.campbell(beam, gamma=g, n_modes=4)
    with ThreadPoolExecutor(2) as ex:
        swept = pf.campbell(beam, gamma=g, n_modes=4, executor=ex)
    monkeypatch.setattr(cb, "SPARSE_MIN_DOFS", 10**9)
    dense = pf.campbell(beam, gamma=g, n_modes=4)
    for c in (sparse, swept):
        assert np.allclose(c.frequencies, dense.frequencies, rtol=1e-9, atol=0.0)
        assert np.allclose(c.mac, dense.mac, rtol=0.0, atol=1e-9)
        assert list(c.family) == list(dense.family)
        assert np.allclose(c.crossing_speed, dense.crossing_speed, rtol=1e-9, atol=0.0)
    assert len(rotating_modes(beam, omega=3.0, n_modes=5)["eigenvalue"]) == 5
