"""The peer's side of the peer scene (docs/performance.md): Exudyn 1.11 with its 2D ALE-ANCF pipe.

The scene of `bench_limit_cycle.scene()`: the seed-000 Fig. 3 cantilever, L = 1 m, 8 elements,
EI = 10 N m^2, EA = 1e5 N, pipe 8 kg/m + fluid 2 kg/m, a 1.5 N lateral tip force, 30 kg/s
(fluid velocity 15 m/s) from t = 0, starting from the static deflection under the tip force
without flow. Quantity: the tip's lateral displacement at t = 2 s.

In Exudyn: 8 `ObjectALEANCFCable2D` elements (physicsMassPerLength 10 kg/m, of which the share
physicsMovingMassFactor 0.2 moves with the fluid) on `NodePoint2DSlope1` nodes and one ALE node
(`NodeGenericODE2`, one coordinate: the fluid's axial displacement) whose velocity a velocity-
level `CoordinateConstraint` holds at `offset` (0 for the static solve, 15 m/s in the run).
The clamp fixes x, y and the slope's y component of the first node (the slope's x component,
the axial stretch there, stays free, as in Exudyn's examples); the tip force acts on the last
node's position.

Exudyn is not a dependency of pipeflex and is not on this machine's package index. Build it
from source (Exudyn 1.11.0, https://github.com/jgerstmayr/EXUDYN, commit e44aca1b):

    cd EXUDYN/main && python setup.py build_ext --inplace --noglfw --parallel --quiet

and put `EXUDYN/main/pythonDev` on PYTHONPATH (copy `build/lib*/exudyn/exudynCPP*.so` into
`pythonDev/exudyn/` if the build left them there). `exudynCPPfast` (no range checks) is used
when present (`fast=True`, the default), the checked `exudynCPP` otherwise.

    PYTHONPATH=EXUDYN/main/pythonDev python benchmarks/peer/exudyn_scene.py   # scene check
"""
import sys
import time

T_END = 2.0
L, N_ELEMENTS, EI, EA = 1.0, 8, 10.0, 1e5
MASS_PER_LENGTH, FLUID_SHARE = 10.0, 0.2  # pipe 8 + fluid 2 kg/m
FLUID_VELOCITY = 15.0  # 30 kg/s over 2 kg/m
TIP_FORCE = 1.5

# The peer's converged tip y at 2 s: `reference()` (trapezoidal, full Newton, relTol 1e-10, h = 1e-4, 5e-5,
# 2.5e-5 s; the two Richardson extrapolations differ by 8e-11 m; the steps' differences fall by 4.00 each halving).
REFERENCE = -0.3977901375455

SOLVERS = ("trapezoidal", "generalized_alpha", "newmark")
LINEAR_SOLVERS = ("dense", "sparse")

_exu = None


def load(fast=True):
    """Import exudyn once (fast=True: the variant without range checks, if built); ImportError if absent."""
    global _exu
    if _exu is None:
        if fast:
            sys.exudynFast = True
        import exudyn
        _exu = exudyn
    return _exu


def build(n_elements=N_ELEMENTS, *, ea=EA):
    """Assembled (SC, mbs, tip node, velocity constraint) with the flow off (ALE velocity 0)."""
    exu = load()
    from exudyn.itemInterface import (ALECable2D, CoordinateConstraint, LoadForceVector, MarkerNodeCoordinate,
                                      MarkerNodePosition, NodeGenericODE2, NodePointGround, Point2DS1)
    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    ground = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=mbs.AddNode(NodePointGround(referenceCoordinates=[0, 0, 0])),
                                                coordinate=0))
    n_ale = mbs.AddNode(NodeGenericODE2(numberOfODE2Coordinates=1, referenceCoordinates=[0], initialCoordinates=[0],
                                        initialCoordinates_t=[0]))
    flow = mbs.AddObject(CoordinateConstraint(markerNumbers=[ground, mbs.AddMarker(MarkerNodeCoordinate(
        nodeNumber=n_ale, coordinate=0))], offset=0.0, velocityLevel=True))
    le = L / n_elements
    nodes = [mbs.AddNode(Point2DS1(referenceCoordinates=[i * le, 0, 1, 0])) for i in range(n_elements + 1)]
    for i in range(n_elements):
        mbs.AddObject(ALECable2D(physicsLength=le, physicsMassPerLength=MASS_PER_LENGTH, physicsBendingStiffness=EI,
                                 physicsAxialStiffness=ea, physicsMovingMassFactor=FLUID_SHARE,
                                 nodeNumbers=[nodes[i], nodes[i + 1], n_ale]))
    for coordinate in (0, 1, 3):  # x, y, slope y of the clamped node
        mbs.AddObject(CoordinateConstraint(markerNumbers=[ground, mbs.AddMarker(MarkerNodeCoordinate(
            nodeNumber=nodes[0], coordinate=coordinate))]))
    mbs.AddLoad(LoadForceVector(markerNumber=mbs.AddMarker(MarkerNodePosition(nodeNumber=nodes[-1])),
                                loadVector=[0, TIP_FORCE, 0]))
    mbs.Assemble()
    return sc, mbs, nodes[-1], flow


def _quiet(settings):
    settings.solutionSettings.writeSolutionToFile = False
    settings.solutionSettings.writeInitialValues = False
    settings.solutionSettings.sensorsWritePeriod = 1e9
    settings.displayStatistics = False
    settings.displayComputationTime = False
    settings.timeIntegration.verboseMode = 0
    settings.staticSolver.verboseMode = 0
    settings.parallel.numberOfThreads = 1


def static_start(mbs):
    """Static deflection under the tip force without flow, stored as the initial state."""
    exu = load()
    s = exu.SimulationSettings()
    _quiet(s)
    s.staticSolver.newton.relativeTolerance = 1e-12
    s.staticSolver.newton.absoluteTolerance = 1e-14
    s.staticSolver.numberOfLoadSteps = 1
    exu.SolveStatic(mbs, s, updateInitialValues=True, storeSolver=False)


def settings(step, *, solver="trapezoidal", rel_tol=1e-6, abs_tol=1e-10, modified_newton=True,
             linear_solver="dense", rho=1.0, t_end=T_END, **newton):
    """Exudyn SimulationSettings for a fixed-step run; `newton` sets further NewtonSettings fields."""
    exu = load()
    if solver not in SOLVERS:
        raise ValueError(f"solver must be one of {SOLVERS}, got {solver!r}")
    if linear_solver not in LINEAR_SOLVERS:
        raise ValueError(f"linear_solver must be one of {LINEAR_SOLVERS}, got {linear_solver!r}")
    s = exu.SimulationSettings()
    _quiet(s)
    ti = s.timeIntegration
    ti.endTime = t_end
    ti.numberOfSteps = int(round(t_end / step))
    ti.adaptiveStep = False  # fixed steps: the error is then a function of the step alone
    ti.newton.useModifiedNewton = modified_newton
    ti.newton.relativeTolerance = rel_tol
    ti.newton.absoluteTolerance = abs_tol
    for k, v in newton.items():
        if not hasattr(ti.newton, k):
            raise ValueError(f"unknown Newton setting {k!r}")
        setattr(ti.newton, k, v)
    ga = ti.generalizedAlpha
    ga.spectralRadius = rho
    ga.useNewmark = solver in ("trapezoidal", "newmark")
    ga.useIndex2Constraints = solver == "trapezoidal"
    s.linearSolverType = exu.LinearSolverType.EXUdense if linear_solver == "dense" else exu.LinearSolverType.EigenSparse
    return s


def start(mbs, flow):
    """Flow on: the ALE node at 15 m/s from the static state (the initial state of the run)."""
    exu = load()
    mbs.SetObjectParameter(flow, "offset", FLUID_VELOCITY)
    v = mbs.systemData.GetODE2Coordinates_t(configuration=exu.ConfigurationType.Initial)
    v[0] = FLUID_VELOCITY  # the ALE node's coordinate comes first (added before the cable nodes)
    mbs.systemData.SetODE2Coordinates_t(v, configuration=exu.ConfigurationType.Initial)


def tip_y(mbs, tip):
    exu = load()
    return float(mbs.GetNodeOutput(tip, exu.OutputVariableType.Displacement)[1])


def run(step, solver="trapezoidal", rel_tol=1e-6, modified_newton=True, *, linear_solver="dense", rho=1.0,
        t_end=T_END, **newton):
    """(tip y at t_end [m], solve seconds (SolveDynamic only), stats) of one fixed-step run of the scene."""
    exu = load()
    sc, mbs, tip, flow = build()
    static_start(mbs)
    start(mbs, flow)
    s = settings(step, solver=solver, rel_tol=rel_tol, modified_newton=modified_newton, linear_solver=linear_solver,
                 rho=rho, t_end=t_end, **newton)
    kind = getattr(exu.DynamicSolverType, "TrapezoidalIndex2" if solver == "trapezoidal" else "GeneralizedAlpha")
    t0 = time.perf_counter()
    exu.SolveDynamic(mbs, s, solverType=kind)
    seconds = time.perf_counter() - t0
    it = mbs.sys["dynamicSolver"].it
    stats = dict(steps=it.currentStepIndex, newton_iterations=it.newtonStepsCount, jacobians=it.newtonJacobiCount,
                 rejected_modified_newton=it.rejectedModifiedNewtonSteps)
    return tip_y(mbs, tip), seconds, stats


def reference(steps=(1e-4, 5e-5, 2.5e-5)):
    """(converged tip y at 2 s, spread of the last two Richardson extrapolations) from three halved steps,
    trapezoidal rule, full Newton, relative tolerance 1e-10 (second order: y_h + (y_h - y_2h) / 3)."""
    y = [run(h, "trapezoidal", rel_tol=1e-10, abs_tol=1e-12, modified_newton=False)[0] for h in steps]
    r1, r2 = y[1] + (y[1] - y[0]) / 3, y[2] + (y[2] - y[1]) / 3
    return r2, abs(r2 - r1)


def cycle(step=5e-4, t_end=10.0, settle=5.0, **options):
    """(amplitude [m], period [s], mean [m]) of the tip's limit cycle, from `settle` to `t_end`
    (pipeflex.signals.cycle_metrics on the tip's y sampled every step)."""
    import numpy as np

    from pipeflex.signals import cycle_metrics
    exu = load()
    from exudyn.itemInterface import SensorNode
    sc, mbs, tip, flow = build()
    sensor = mbs.AddSensor(SensorNode(nodeNumber=tip, storeInternal=True, writeToFile=False,
                                      outputVariableType=exu.OutputVariableType.Displacement))
    mbs.Assemble()
    static_start(mbs)
    start(mbs, flow)
    s = settings(step, t_end=t_end, **options)
    s.solutionSettings.sensorsWritePeriod = step
    exu.SolveDynamic(mbs, s, solverType=exu.DynamicSolverType.TrapezoidalIndex2)
    data = np.asarray(mbs.GetSensorStoredData(sensor))
    return cycle_metrics(data[:, 0], data[:, 2], after=settle)


if __name__ == "__main__":
    sc, mbs, tip, flow = build()
    static_start(mbs)
    print(f"static tip deflection {tip_y(mbs, tip):.6f} m (P L^3 / 3 EI = 0.05 m)")
    y, sec, stats = run(1e-3)
    print(f"trapezoidal, h = 1 ms: tip y(2 s) = {y:.9f} m in {sec:.3f} s, {stats}")
    amp, period, mean = cycle()
    print(f"limit cycle (h = 0.5 ms, 5-10 s): amplitude {amp:.4f} m, period {period:.4f} s, mean {mean:.4f} m")
