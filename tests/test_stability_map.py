"""pipeflex.stability_map: the cantilevered pipe's critical flow speed and frequency against
the mass ratio, against the continuous beam's characteristic determinant
(pipeflex.references.continuous_pipe, no pipeflex finite-element code), and the jumps of the map.

Cost (~15 s on a busy 2-core machine): the determinant solver ~1-1.5 s per point (6 points);
the element model 0.1-0.5 s per point. All sweeps run in this process (executor="serial":
no pool to start); tests/test_sweep.py covers the pool and Dask, the notebook
notebooks/stability_map.ipynb runs the map on both.
"""
import numpy as np
import pytest

import pipeflex as pf
from pipeflex.references import continuous_pipe as cp
from pipeflex.analysis.stability_map import cantilever, critical_point

pytest.importorskip("xarray")


# ---------------------------------------------------------------------------------------
# the independent solver, checked before it is trusted

def test_determinant_gives_the_cantilever_frequencies_without_flow():
    # Euler-Bernoulli clamped-free beam: omega_bar = lambda_n^2, cos(lambda) cosh(lambda) = -1,
    # lambda_n = 1.87510407, 4.69409113, 7.85475744 (e.g. Blevins, "Formulas for natural
    # frequency and mode shape", Table 8-1)
    for guess, lam in zip((3.5, 22.0, 61.7), (1.87510407, 4.69409113, 7.85475744)):
        w = cp.eigenvalue(lambda x: cp.delta_roots(x, 0.0, 0.3), guess)
        assert w == pytest.approx(lam ** 2, rel=2e-8)


def test_the_two_forms_of_the_determinant_have_the_same_roots():
    # exponentials with the Vandermonde factor vs. the transfer matrix: the same function
    # up to a constant factor (their ratio does not depend on omega)
    u, beta = 6.0, 0.4
    ws = (3.0 + 1.0j, 15.0 - 2.0j, 40.0 + 5.0j)
    ratios = [cp.delta_roots(w, u, beta) / cp.delta_transfer(w, u, beta) for w in ws]
    np.testing.assert_allclose(ratios, ratios[0], rtol=1e-9)
    w = cp.eigenvalue(lambda x: cp.delta_roots(x, u, beta), 14.0 + 1.0j)
    assert cp.eigenvalue(lambda x: cp.delta_transfer(x, u, beta), 14.0 + 1.0j) == pytest.approx(w, rel=1e-11)
    # with gravity the transfer matrix is a product of slices: converged by 64 of them
    w64 = cp.eigenvalue(lambda x: cp.delta_transfer(x, u, beta, 10.0, 64), 15.0 + 1.0j)
    w256 = cp.eigenvalue(lambda x: cp.delta_transfer(x, u, beta, 10.0, 256), 15.0 + 1.0j)
    assert w64 == pytest.approx(w256, rel=1e-10)


def test_without_coriolis_forces_the_pipe_is_becks_column():
    # beta = 0: the free end's momentum flux M U^2 is a follower force; the lowest two
    # modes coalesce (flutter) at u^2 = 20.05 (Beck 1952: P_cr = 20.05 EI / L^2)
    below = [cp.eigenvalue(lambda x: cp.delta_roots(x, np.sqrt(20.0), 0.0), g) for g in (10.0, 12.0)]
    above = cp.eigenvalue(lambda x: cp.delta_roots(x, np.sqrt(20.1), 0.0), 11.0 + 0.5j)
    assert max(abs(w.imag) for w in below) < 1e-9 and abs(below[0] - below[1]) > 0.5
    assert abs(above.imag) > 0.1


def test_determinant_solver_gives_the_published_critical_speed():
    # Gregory & Paidoussis (1966): u_cr = 5.6 at beta = 0.2 (read from their plot, ~1 %)
    uc, _ = cp.critical(0.2)
    assert uc == pytest.approx(5.6, rel=0.01)


# ---------------------------------------------------------------------------------------
# the element model against it

# The critical speed and frequency of the element model converge like n_elements^-4 (measured:
# the error falls by 15.5-16.3 from 16 to 32 elements at every point below, 2026-11-23). At 32
# elements the largest relative errors are 2.2e-5 (u_cr) and 5.0e-5 (omega_cr) at beta = 0.8,
# whose critical mode is the third (omega_bar ~ 45), 5e-7 to 1e-5 at the others.
RTOL_U, RTOL_W = 3e-5, 6e-5

POINTS = [(0.1, 0.0), (0.2, 0.0), (0.5, 0.0), (0.8, 0.0),
          (0.2, 10.0),    # hanging (Paidoussis 1970)
          (0.5, -5.0)]    # standing, below its self-buckling gamma = -7.84


@pytest.fixture(scope="module")
def continuous():
    return {p: cp.critical(p[0], gamma=p[1]) for p in POINTS}


def test_element_model_matches_the_continuous_beam(continuous):
    for gamma in (0.0, 10.0, -5.0):
        betas = [b for b, g in POINTS if g == gamma]
        ds = pf.stability_map(betas, gravity=gamma, n_elements=32, executor="serial", progress=False)
        assert ds.attrs["n_failed"] == 0 and list(ds.kind.values) == ["flutter"] * len(betas)
        uc, wc = np.array([continuous[(b, gamma)] for b in betas]).T
        np.testing.assert_allclose(ds.u_cr, uc, rtol=RTOL_U, err_msg=f"gamma = {gamma}")
        np.testing.assert_allclose(ds.omega_cr, wc, rtol=RTOL_W, err_msg=f"gamma = {gamma}")
        np.testing.assert_allclose(ds.mass_flow, ds.u_cr * np.sqrt(ds.mass_ratio), rtol=1e-14)


def test_the_error_falls_like_the_fourth_power_of_the_element_length(continuous):
    uc, wc = continuous[(0.5, 0.0)]
    err = {n: abs(critical_point(0.5, n_elements=n)["u_cr"] / uc - 1) for n in (16, 32)}
    assert 12.0 < err[16] / err[32] < 20.0


# ---------------------------------------------------------------------------------------
# the map

def test_the_map_jumps_where_the_critical_mode_changes():
    # Gregory & Paidoussis's S-shaped flutter branch: u_cr rises by 0.1-0.2 per 0.01 of beta
    # elsewhere, but by more than 1 across each window below (32 elements: jumps at beta =
    # 0.290-0.295, 0.690-0.695, 0.920-0.925; 12 elements, used here: 0.295-0.300, the others
    # the same), and the frequency jumps to another mode's (by 1.5 to 1.6 times).
    windows = [(0.285, 0.300), (0.685, 0.700), (0.915, 0.930)]
    ds = pf.stability_map([b for w in windows for b in w], n_elements=12, executor="serial", progress=False)
    u, w = ds.u_cr.values.reshape(-1, 2), ds.omega_cr.values.reshape(-1, 2)
    assert np.all(u[:, 1] - u[:, 0] > 1.0), u
    assert np.all(w[:, 1] / w[:, 0] > 1.4), w
    # smooth in between: a window of the same width away from the jumps
    flat = pf.stability_map([0.45, 0.465], n_elements=12, executor="serial", progress=False).u_cr.values
    assert 0.0 < flat[1] - flat[0] < 0.4


def test_gravity_maps_add_a_dimension_and_failed_points_are_recorded():
    ds = pf.stability_map([0.2], gravity=[-10.0, 10.0], n_elements=8, executor="serial", progress=False)
    assert ds.u_cr.dims == ("gravity", "mass_ratio")
    # gamma = -10: a standing pipe buckles under its own weight (gamma = -7.84) before any flow
    assert "already unstable" in ds.error.values[0, 0] and np.isnan(ds.u_cr.values[0, 0])
    assert ds.error.values[1, 0] == "" and ds.u_cr.values[1, 0] > 6.0  # hanging: tension stabilises
    assert ds.attrs["n_failed"] == 1


def test_the_dimensionless_cantilever():
    model = cantilever(0.3, n_elements=4, gravity=2.0)
    assert model.total_length == pytest.approx(1.0) and model.total_mass == pytest.approx(1.0)
    np.testing.assert_array_equal(model.gravity, [2.0, 0.0, 0.0])
    assert model.elements[0].section.fluid_mass == 0.3 and model.elements[0].section.EI == 1.0


@pytest.mark.parametrize("bad", [0.0, 1.0, -0.1, np.nan])
def test_mass_ratio_outside_zero_one_is_refused(bad):
    with pytest.raises(ValueError, match="mass_ratio"):
        pf.stability_map([0.2, bad], executor="serial")
