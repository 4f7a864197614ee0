"""Critical mass flows: seed 000 Tables 1 and 2, and the analytic divergence flow."""
import numpy as np
import pytest

import pipeflex as pf
from pipeflex.convergence import observed_order, richardson
from pipeflex.seeds.seed000 import references as ref000, validation


@pytest.mark.parametrize("n", sorted(ref000.TABLE1))
def test_table1_simply_supported(n):
    """Seed 000, Table 1 (1, 2, 4, 8, 16 elements): 8 significant digits."""
    r = pf.critical_mass_flow(pf.scenes.simply_supported_pipe(n_elements=n))
    assert r.kind == "divergence"
    assert r.frequency == 0.0
    assert r.mass_flow == pytest.approx(ref000.TABLE1[n], rel=validation.TOL_TABLE1)


def test_table1_one_element_is_sqrt3():
    """One element: P = 12 EI / L^2 exactly, i.e. mdot = sqrt(3) for the seed's data."""
    r = pf.critical_mass_flow(pf.scenes.simply_supported_pipe(n_elements=1), tol=1e-12)
    assert r.mass_flow == pytest.approx(np.sqrt(3.0), rel=1e-12)


@pytest.mark.parametrize("n", sorted(ref000.TABLE2))
def test_table2_cantilever(n):
    """Seed 000, Table 2 (2..32 elements): within 2e-7; flutter (Hopf)."""
    r = pf.critical_mass_flow(pf.scenes.cantilever_pipe(n_elements=n))
    assert r.kind == "flutter"
    assert r.frequency > 0
    assert abs(r.eigenvalue.real) < 1e-8 * abs(r.eigenvalue)
    assert r.mass_flow == pytest.approx(ref000.TABLE2[n], rel=validation.TOL_TABLE2)


def test_table2_extrapolated_and_order_four():
    """Seed 000, Table 2 'extrapolated' 25.005520 within 2e-6; observed order ~4."""
    n = [4, 8, 16, 32]
    f = [pf.critical_mass_flow(pf.scenes.cantilever_pipe(n_elements=k)).mass_flow for k in n]
    ext = richardson(f[-2], f[-1])
    assert ext == pytest.approx(ref000.TABLE2_EXTRAPOLATED, rel=validation.TOL_TABLE2_EXTRAPOLATED)
    order = observed_order(n[:-1], np.abs(np.array(f[:-1]) - ext))
    assert order[-1] == pytest.approx(4.0, abs=0.5)


def test_divergence_flow_converges_to_euler_column_with_order_four():
    """Other data: mdot_cr = (pi/L) sqrt(rho_f A_f EI / k_v) as the mesh is refined."""
    L, EI, mf, kv = 2.0, 3.0, 0.5, 4.0 / 3.0
    exact = np.pi / L * np.sqrt(mf * EI / kv)
    n = [2, 4, 8, 16]
    f = np.array([pf.critical_mass_flow(pf.scenes.simply_supported_pipe(
        n_elements=k, length=L, EI=EI, pipe_mass=1.5, fluid_mass=mf, kv=kv)).mass_flow for k in n])
    err = np.abs(f - exact) / exact
    assert np.all(np.diff(err) < 0)
    assert err[-1] < 2e-6
    assert np.all(np.abs(observed_order(n, err) - 4.0) < 0.3)


def test_critical_flow_meets_rtol():
    m = pf.scenes.cantilever_pipe(n_elements=4)
    a = pf.critical_mass_flow(m, tol=1e-6).mass_flow
    b = pf.critical_mass_flow(m, tol=1e-12).mass_flow
    assert abs(a - b) <= 1e-6 * b
    # just below stable, just above flutter
    lo = pf.eigenvalues(pf.linearize(m, mass_flow=b * (1 - 1e-7)))
    hi = pf.eigenvalues(pf.linearize(m, mass_flow=b * (1 + 1e-7)))
    assert pf.stability(lo) == "stable"
    assert pf.stability(hi) == "flutter"


def test_no_instability_in_range_is_reported():
    m = pf.scenes.cantilever_pipe(n_elements=2)
    with pytest.raises(pf.ConvergenceError, match="no instability"):
        pf.critical_mass_flow(m, mass_flow_max=10.0)


def test_table2_cantilever_128_elements_converges_with_order_four():
    """128 elements (768 coordinates: the sparse path). No ConvergenceError (Newton's
    tolerance follows the round-off level of the size), and order-4 convergence holds
    on 32, 64, 128: the differences shrink ~16-fold (observed 15.7), and the 128-element
    flow is within ~2.4e-8 of the seed's extrapolated 25.005520 (itself truncated, 2.2e-8
    low; the 64/128 Richardson value is 25.00552055)."""
    r = pf.critical_mass_flow(pf.scenes.cantilever_pipe(n_elements=128))
    assert r.kind == "flutter"
    assert abs(r.eigenvalue.real) < 1e-8 * abs(r.eigenvalue)
    assert r.mass_flow == pytest.approx(ref000.TABLE2_EXTRAPOLATED, rel=4e-8)
    f32 = pf.critical_mass_flow(pf.scenes.cantilever_pipe(n_elements=32)).mass_flow
    f64 = pf.critical_mass_flow(pf.scenes.cantilever_pipe(n_elements=64)).mass_flow
    order = np.log2((f32 - f64) / (f64 - r.mass_flow))
    assert order == pytest.approx(4.0, abs=0.1)
    ext = richardson(f64, r.mass_flow)
    assert abs(r.mass_flow - ext) < 1e-7  # kg/s: 128 elements are converged to ~2e-9 relative
