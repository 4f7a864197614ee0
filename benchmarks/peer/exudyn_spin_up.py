"""The peer's side of the spin-up scene of benchmarks/bench_peer.py: Exudyn 1.11 with ANCFCable2D.

The scene: seed 002's Table 1 beam of ref. 21 (L = 8 m, rho A = 2.767e3 * 7.299e-5 kg/m,
EI = 6.895e10 * 8.214e-9 N m^2, EA = 6.895e10 * 7.299e-5 N), clamped at the hub's centre (hub
radius 0), the hub angle prescribed by seed 002's eq. 13 (Omega = 4 rad/s reached in T = 15 s);
quantity: the tip's deflection in the rotating frame at 20 s (the tip position projected on the
rotating frame's transverse direction, the beam lying along x at rest).

In Exudyn: `ObjectANCFCable2D` elements on `NodePoint2DSlope1` nodes in the inertial frame; the
clamp to the rotating hub prescribes the first node's four coordinates (x = y = 0, slope =
(cos theta, sin theta)) with `CoordinateConstraint`s whose `offsetUserFunction` gives theta(t).

Mesh: 16 elements, not pipeflex's 2. Exudyn's cable element converges more slowly in this
scene: the tip deflection at 20 s (generalised-alpha rho_inf = 1, h = 2.5 ms, both codes) is

    elements        2          4          8          16
    Exudyn      +0.003635  -0.006548  -0.007123  -0.007143  m
    pipeflex    -0.007143  -0.007226  -0.007166  -0.007145  m

so the peer's 2-element model misses the scene's (pipeflex's 2-element) reference -0.0071425 m
by 1.1e-2 m = 1.3e-3 L. At 16 elements the peer's converged value (`reference()`: -0.0071376 m)
is 4.9e-6 m = 6e-7 L from it, below every target of the benchmark, so the peer's work-precision
runs measure its time-step error. The trajectory agrees too (lag at 7.5 s: -0.52086 m Exudyn, -0.52084 m
pipeflex, 16 elements each).

Newton: the residual is a force [N]. In the first steps the motion is ~t^4 and the residual
starts near round-off, so the absolute criterion decides; round-off of the axial forces
(EA = 5.0e6 N) puts the residual's floor between 1e-9 and 1e-8 N (2 elements), 1e-8 and 1e-7 N (16), so
`exudyn_scene.settings`' absoluteTolerance 1e-10 is never met and SolveDynamic stops at the
first step. ABS_TOL = 1e-6 N for the sweeps, REFERENCE_ABS_TOL = 1e-7 N for the reference (1e-6
moves it by 1e-8 m). Step size: at rho_inf = 1 the undamped axial modes (about 1e4 rad/s at
16 elements) make Newton fail at h >= 5 ms (16 elements); the sweeps use RHO_INF = 0.8,
pipeflex's fixed-step default, and run at 10 ms and below. The reference (h <= 1 ms) uses 1.

Build Exudyn as `exudyn_scene.py` says.

    PYTHONPATH=EXUDYN/main/pythonDev python benchmarks/peer/exudyn_spin_up.py   # scene check
"""
import time

import numpy as np

from exudyn_scene import load

L, N_ELEMENTS, T_END = 8.0, 16, 20.0
RHO_A = 2.767e3 * 7.299e-5
EI, EA = 6.895e10 * 8.214e-9, 6.895e10 * 7.299e-5
OMEGA, SPIN_UP_TIME = 4.0, 15.0
ABS_TOL, REFERENCE_ABS_TOL = 1e-6, 1e-7  # [N] Newton residual; see the module docstring
RHO_INF = 0.8  # the sweeps' spectral radius (pipeflex's fixed-step default); see the module docstring


def hub_angle(t):
    """theta(t) [rad] of seed 002's eq. 13: smooth spin-up to OMEGA over SPIN_UP_TIME, then constant rate."""
    T = SPIN_UP_TIME
    if t < T:
        return OMEGA / T * (t**2 / 2 + (T / (2 * np.pi))**2 * (np.cos(2 * np.pi * t / T) - 1))
    return OMEGA * (t - T / 2)


def build(n_elements=N_ELEMENTS):
    """Assembled (SC, mbs, tip node) of the beam in `n_elements` equal cable elements."""
    exu = load()
    from exudyn.itemInterface import Cable2D, CoordinateConstraint, MarkerNodeCoordinate, NodePointGround, Point2DS1
    if int(n_elements) != n_elements or n_elements < 1:
        raise ValueError(f"n_elements must be a positive integer, got {n_elements!r}")
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


def run(step, solver="generalized_alpha", rel_tol=1e-6, modified_newton=True, *, abs_tol=ABS_TOL,
        n_elements=N_ELEMENTS, linear_solver="dense", rho=RHO_INF, t_end=T_END, **newton):
    """(tip deflection at t_end [m], solve seconds, stats) of one fixed-step run from rest."""
    import exudyn_scene
    exu = load()
    sc, mbs, tip = build(n_elements)
    s = exudyn_scene.settings(step, solver=solver, rel_tol=rel_tol, abs_tol=abs_tol, modified_newton=modified_newton,
                              linear_solver=linear_solver, rho=rho, t_end=t_end, **newton)
    kind = getattr(exu.DynamicSolverType, "TrapezoidalIndex2" if solver == "trapezoidal" else "GeneralizedAlpha")
    t0 = time.perf_counter()
    exu.SolveDynamic(mbs, s, solverType=kind)
    seconds = time.perf_counter() - t0
    it = mbs.sys["dynamicSolver"].it
    stats = dict(steps=it.currentStepIndex, newton_iterations=it.newtonStepsCount, jacobians=it.newtonJacobiCount)
    return tip_deflection(mbs, tip, t_end), seconds, stats


def reference(steps=(1e-3, 5e-4, 2.5e-4), n_elements=N_ELEMENTS):
    """(converged tip deflection at 20 s [m], spread of the two Richardson extrapolations [m]): generalised-alpha
    rho_inf = 1, full Newton, relative tolerance 1e-10, absolute REFERENCE_ABS_TOL, three halved steps."""
    y = [run(h, rel_tol=1e-10, abs_tol=REFERENCE_ABS_TOL, modified_newton=False, n_elements=n_elements, rho=1.0)[0]
         for h in steps]
    r1, r2 = y[1] + (y[1] - y[0]) / 3, y[2] + (y[2] - y[1]) / 3
    return r2, abs(r2 - r1)


if __name__ == "__main__":
    y, sec, stats = run(5e-3)
    print(f"spin-up, {N_ELEMENTS} elements, h = 5 ms: tip deflection at 20 s = {y:.9f} m in {sec:.3f} s, {stats}")
    t0 = time.perf_counter()
    ref, spread = reference()
    print(f"reference {ref:.12f} m (extrapolations differ by {spread:.1e} m) in {time.perf_counter() - t0:.1f} s")
