"""The peer's side of the critical-flow scene of benchmarks/bench_peer.py: Exudyn 1.11's ALE-ANCF pipe,
the flutter flow found by an eigenvalue scan over the flow velocity.

The scene: the cantilevered pipe of `pf.scenes.cantilever_pipe` (L = 1 m, EI = 10 N m^2,
EA = 1e5 N, pipe + fluid 10 kg/m, beta = M / (M + m) the fluid's share), `exudyn_scene.build`
with physicsMovingMassFactor = beta and no tip force. At each flow velocity U the ALE node's
velocity is set to U, the system is linearised about the straight pipe
(`exudyn.solver.ComputeLinearizedSystem`: M, K and D, the flow's gyroscopic and U^2 terms in D
and K), the ALE coordinate (the flow held at U) and the clamped coordinates (x, y and the
slope's y of the first node) are removed, and the eigenvalues of the first-order form
[[0, I], [-M^-1 K, -M^-1 D]] are scanned for one with a positive real part; the first crossing is
bisected to `tol`. Mass flow = M U (M = beta 10 kg/m).

Measured: mdot_cr [kg/s] and its relative error against `pipeflex.references.continuous_pipe`
(25.0055206 kg/s at beta = 0.2, 65.9194529 kg/s at beta = 0.5):

    elements      2                     4                     8                     16                    32
    beta = 0.2    24.9627310 -1.7e-3   25.0547310 +2.0e-3   25.0089106 +1.4e-4   25.0057375 +8.7e-6   25.0055342 +5.5e-7
    beta = 0.5    78.9694165 +2.0e-1   66.8142020 +1.4e-2   65.9923649 +1.1e-3   65.9242934 +7.3e-5   65.9197601 +4.7e-6

The error falls by about 16 per halving (fourth order, the cubic Hermite elements), and at every
mesh the peer's mdot_cr equals `pf.critical_mass_flow`'s on the same mesh to 2e-10 relative: the
two codes discretise the pipe alike.

Build Exudyn as `exudyn_scene.py` says.

    PYTHONPATH=EXUDYN/main/pythonDev python benchmarks/peer/exudyn_critical_flow.py   # scene check
"""
import time

import numpy as np

import exudyn_scene
from exudyn_scene import _quiet, load

TOTAL_MASS, EI, L = 10.0, 10.0, 1.0


# coordinates of `exudyn_scene.build` removed from the linearised system: the ALE node's (added first; the
# flow is held at U) and the clamped x, y, slope y of the first cable node (coordinates 1, 2, 4)
HELD = (0, 1, 2, 4)


def eigenvalues(n_elements, beta, velocity, *, ea=1e5):
    """Eigenvalues [1/s] of the pipe linearised about its straight state at flow velocity [m/s]."""
    exu = load()
    from exudyn.solver import ComputeLinearizedSystem
    exudyn_scene.FLUID_SHARE, exudyn_scene.MASS_PER_LENGTH, exudyn_scene.TIP_FORCE = beta, TOTAL_MASS, 0.0
    sc, mbs, tip, flow = exudyn_scene.build(n_elements, ea=ea)
    mbs.SetObjectParameter(flow, "offset", velocity)
    v = mbs.systemData.GetODE2Coordinates_t(configuration=exu.ConfigurationType.Initial)
    v[0] = velocity  # the ALE velocity enters D (gyroscopic) and K (U^2 terms)
    mbs.systemData.SetODE2Coordinates_t(v, configuration=exu.ConfigurationType.Initial)
    s = exu.SimulationSettings()
    _quiet(s)
    M, K, D = ComputeLinearizedSystem(mbs, s)
    keep = [i for i in range(M.shape[0]) if i not in HELD]
    M, K, D = (np.asarray(A)[np.ix_(keep, keep)] for A in (M, K, D))
    n = len(keep)
    Minv = np.linalg.inv(M)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ K, -Minv @ D]])
    return np.linalg.eigvals(A)


def growth(n_elements, beta, velocity, *, ea=1e5):
    """Largest real part [1/s] of the linearised pipe's eigenvalues at flow velocity [m/s] > 0 (the flow's
    Coriolis terms damp every mode below the flutter flow, so its sign decides; at U = 0 it is round-off)."""
    return float(eigenvalues(n_elements, beta, velocity, ea=ea).real.max())


def critical_mass_flow(n_elements, beta, *, du=0.25, u_max=60.0, tol=1e-10):
    """(critical mass flow [kg/s], solve seconds): scan the velocity in steps du [m/s], bisect the first
    velocity with a growing eigenvalue to a relative tol."""
    t0 = time.perf_counter()
    M = beta * TOTAL_MASS
    lo, hi = 0.0, du
    while growth(n_elements, beta, hi) <= 0.0:
        lo, hi = hi, hi + du
        if hi > u_max:
            raise RuntimeError(f"no flutter up to U = {u_max} m/s")
    while hi - lo > tol * hi:
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if growth(n_elements, beta, mid) > 0.0 else (mid, hi)
    return M * 0.5 * (lo + hi), time.perf_counter() - t0


if __name__ == "__main__":
    for beta in (0.2, 0.5):
        for n in (2, 4, 8):
            mdot, sec = critical_mass_flow(n, beta)
            print(f"beta = {beta}, {n} elements: critical mass flow {mdot:.9f} kg/s in {sec:.2f} s")
