"""The peer's side of the spin-up scene of benchmarks/bench_peer.py: Exudyn with ANCFCable2D.

UNTESTED: written to the pattern of `exudyn_scene.py` on a machine without Exudyn; no number of
it has been run. Check it against `bench_peer.spin_up_scene()` before trusting a comparison.

The scene: seed 002's Table 1 beam of ref. 21 (L = 8 m, rho A = 2.767e3 * 7.299e-5 kg/m,
EI = 6.895e10 * 8.214e-9 N m^2, EA = 6.895e10 * 7.299e-5 N), 2 elements, clamped at the hub's
centre (hub radius 0), the hub angle prescribed by seed 002's eq. 13 (Omega = 4 rad/s reached in
T = 15 s); quantity: the tip's deflection in the rotating frame at 20 s (the tip position
projected on the rotating frame's transverse direction, the beam lying along x at rest).

In Exudyn: `ObjectANCFCable2D` elements on `NodePoint2DSlope1` nodes; the clamp to the rotating
hub prescribes the first node's four coordinates (x = y = 0, slope = (cos theta, sin theta))
with `CoordinateConstraint`s whose `offsetUserFunction` gives theta(t).

Build Exudyn as `exudyn_scene.py` says.
"""
import time

import numpy as np

from exudyn_scene import _quiet, load

L, N_ELEMENTS, T_END = 8.0, 2, 20.0
RHO_A = 2.767e3 * 7.299e-5
EI, EA = 6.895e10 * 8.214e-9, 6.895e10 * 7.299e-5
OMEGA, SPIN_UP_TIME = 4.0, 15.0


def hub_angle(t):
    """theta(t) [rad] of seed 002's eq. 13: smooth spin-up to OMEGA over SPIN_UP_TIME, then constant rate."""
    T = SPIN_UP_TIME
    if t < T:
        return OMEGA / T * (t**2 / 2 + (T / (2 * np.pi))**2 * (np.cos(2 * np.pi * t / T) - 1))
    return OMEGA * (t - T / 2)


def build(n_elements=N_ELEMENTS):
    """Assembled (SC, mbs, tip node)."""
    exu = load()
    from exudyn.itemInterface import Cable2D, CoordinateConstraint, MarkerNodeCoordinate, NodePointGround, Point2DS1
    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    ground = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=mbs.AddNode(NodePointGround(referenceCoordinates=[0, 0, 0])),
                                                coordinate=0))
    le = L / n_elements
    nodes = [mbs.AddNode(Point2DS1(referenceCoordinates=[i * le, 0, 1, 0])) for i in range(n_elements + 1)]
    for i in range(n_elements):
        mbs.AddObject(Cable2D(physicsLength=le, physicsMassPerLength=RHO_A, physicsBendingStiffness=EI,
                              physicsAxialStiffness=EA, nodeNumbers=[nodes[i], nodes[i + 1]]))
    # offsets relative to the reference coordinates (0, 0, 1, 0): displacement of x, y, slope x, slope y
    offsets = (lambda t: 0.0, lambda t: 0.0, lambda t: np.cos(hub_angle(t)) - 1.0, lambda t: np.sin(hub_angle(t)))
    for coordinate, f in enumerate(offsets):
        mbs.AddObject(CoordinateConstraint(
            markerNumbers=[ground, mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=nodes[0], coordinate=coordinate))],
            offsetUserFunction=lambda mbs_, t, item, offset, f=f: f(t)))
    mbs.Assemble()
    return sc, mbs, nodes[-1]


def tip_deflection(mbs, tip, t):
    """The tip's deflection [m] normal to the rotating beam axis at time t."""
    exu = load()
    p = np.asarray(mbs.GetNodeOutput(tip, exu.OutputVariableType.Position))[:2]
    th = hub_angle(t)
    return float(-np.sin(th) * p[0] + np.cos(th) * p[1])


def run(step, solver="generalized_alpha", rel_tol=1e-6, modified_newton=True, *, linear_solver="dense", rho=1.0,
        t_end=T_END, **newton):
    """(tip deflection at t_end [m], solve seconds, stats) of one fixed-step run from rest."""
    import exudyn_scene
    exu = load()
    sc, mbs, tip = build()
    s = exudyn_scene.settings(step, solver=solver, rel_tol=rel_tol, modified_newton=modified_newton,
                              linear_solver=linear_solver, rho=rho, t_end=t_end, **newton)
    _quiet(s)
    kind = getattr(exu.DynamicSolverType, "TrapezoidalIndex2" if solver == "trapezoidal" else "GeneralizedAlpha")
    t0 = time.perf_counter()
    exu.SolveDynamic(mbs, s, solverType=kind)
    seconds = time.perf_counter() - t0
    it = mbs.sys["dynamicSolver"].it
    stats = dict(steps=it.currentStepIndex, newton_iterations=it.newtonStepsCount, jacobians=it.newtonJacobiCount)
    return tip_deflection(mbs, tip, t_end), seconds, stats


def reference(steps=(5e-4, 2.5e-4, 1.25e-4)):
    """(converged tip deflection at 20 s, spread of the two Richardson extrapolations): generalised-alpha
    rho = 1, full Newton, relative tolerance 1e-10, three halved steps."""
    y = [run(h, rel_tol=1e-10, abs_tol=1e-12, modified_newton=False)[0] for h in steps]
    r1, r2 = y[1] + (y[1] - y[0]) / 3, y[2] + (y[2] - y[1]) / 3
    return r2, abs(r2 - r1)


if __name__ == "__main__":
    y, sec, stats = run(5e-3)
    print(f"spin-up, h = 5 ms: tip deflection at 20 s = {y:.9f} m in {sec:.3f} s, {stats}")
