"""The peer's side of the critical-flow scene of benchmarks/bench_peer.py: Exudyn's ALE-ANCF pipe,
the flutter flow found by an eigenvalue scan over the flow velocity.

UNTESTED: written to the pattern of `exudyn_scene.py` on a machine without Exudyn; no number of
it has been run. Check it against `pf.critical_mass_flow` before trusting a comparison.

The scene: the cantilevered pipe of `pf.scenes.cantilever_pipe` (L = 1 m, EI = 10 N m^2,
pipe + fluid 10 kg/m, beta = M / (M + m) the fluid's share), `exudyn_scene.build` with
physicsMovingMassFactor = beta. At each flow velocity U the system is linearised about the straight
pipe (`exudyn.solver.ComputeLinearizedSystem`, projected on the constraints' null space: M, K, D)
and the eigenvalues of the first-order form [[0, I], [-M^-1 K, -M^-1 D]] are scanned for one with
a positive real part; the first crossing is bisected to `tol`. Mass flow = M U (M = beta 10 kg/m).

Build Exudyn as `exudyn_scene.py` says.
"""
import time

import numpy as np

import exudyn_scene
from exudyn_scene import _quiet, load

TOTAL_MASS, EI, L = 10.0, 10.0, 1.0


def growth(n_elements, beta, velocity, *, ea=1e5):
    """Largest real part [1/s] of the linearised pipe's eigenvalues at flow velocity [m/s]."""
    exu = load()
    from exudyn.solver import ComputeLinearizedSystem
    exudyn_scene.FLUID_SHARE, exudyn_scene.MASS_PER_LENGTH, exudyn_scene.TIP_FORCE = beta, TOTAL_MASS, 0.0
    sc, mbs, tip, flow = exudyn_scene.build(n_elements, ea=ea)
    mbs.SetObjectParameter(flow, "offset", velocity)
    v = mbs.systemData.GetODE2Coordinates_t(configuration=exu.ConfigurationType.Initial)
    v[0] = velocity
    mbs.systemData.SetODE2Coordinates_t(v, configuration=exu.ConfigurationType.Initial)
    s = exu.SimulationSettings()
    _quiet(s)
    M, K, D = ComputeLinearizedSystem(mbs, s, projectIntoConstraints=True)
    n = M.shape[0]
    Minv = np.linalg.inv(M)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ K, -Minv @ D]])
    return float(np.linalg.eigvals(A).real.max())


def critical_mass_flow(n_elements, beta, *, du=0.25, u_max=60.0, tol=1e-10):
    """(critical mass flow [kg/s], solve seconds): scan the velocity in steps du [m/s], bisect the first
    velocity with a growing eigenvalue to a relative tol."""
    t0 = time.perf_counter()
    M = beta * TOTAL_MASS
    lo, hi = 0.0, du
    while growth(n_elements, beta, hi) <= 1e-9:
        lo, hi = hi, hi + du
        if hi > u_max:
            raise RuntimeError(f"no flutter up to U = {u_max} m/s")
    while hi - lo > tol * hi:
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if growth(n_elements, beta, mid) > 1e-9 else (mid, hi)
    return M * 0.5 * (lo + hi), time.perf_counter() - t0


if __name__ == "__main__":
    for beta in (0.2, 0.5):
        for n in (2, 4, 8):
            mdot, sec = critical_mass_flow(n, beta)
            print(f"beta = {beta}, {n} elements: critical mass flow {mdot:.9f} kg/s in {sec:.2f} s")
