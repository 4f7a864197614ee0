"""Time integration: ``simulate(model, t_end, integrator="auto" | "generalized_alpha" | "ida")``.

Both integrators run in the C++ core on the element residuals and their analytic
(automatic-differentiation) tangents; see ``docs/theory.md``. ``"auto"`` (the default)
picks one from the options (:func:`choose_integrator`) and, for generalised-alpha, a
step from the model (:func:`default_step`).
"""
from __future__ import annotations

import contextlib
import json
import time as _time
from dataclasses import dataclass, field, replace
from typing import Optional, Sequence, Tuple, Union

import numpy as np

from .. import _checks, _core, _progress
from .._options import MAX_NEWTON, MAX_STEPS, NEWTON_TOL, RHO_INF, STEP
from .._progress import logger
from ..results import COUNTERS, Result
from ..rotation import rotation_exp, rotation_log
from ..time_functions import Sine, time_function
from ._protocol import require_system

INTEGRATORS = ("auto", "ida", "generalized_alpha")
#: generalised-alpha with rtol: Newton's tolerance unless given, a cap only (each step's
#: tolerance is its share of the error, in the core)
CONTROLLED_NEWTON_TOL = 1e-6
#: the smallest rtol of generalised-alpha's error control (its estimate differences two
#: accelerations, whose round-off is ~1e-14 of their size)
MIN_RTOL = 1e-12
#: generalised-alpha with rtol: the fraction of the summed local error estimates that the
#: run's error reaches (error at the end against a converged reference / sum). The sum
#: bounds errors that add up; the local errors of the stiff modes a flow start or a load
#: rings do not (a mode's error stays below its small amplitude, and rho_inf damps the
#: unresolved ones), nor do those of a motion drawn to a limit cycle. Measured (element
#: models: rotations counted at 4/27 of their elements' length, rho_inf = CONTROLLED_RHO_INF):
#: 0.33-0.43 on the flutter limit cycle of benchmarks/bench_limit_cycle.py (rtol 1e-2 ...
#: 1e-4; the error 0.91-1.17 of the request), 0.10-0.17 on a growing flutter (4 elements,
#: 0.5 s). The control keeps the sum below (rtol L + atol) / ERROR_ACCUMULATION.
ERROR_ACCUMULATION = 0.3
#: generalised-alpha with rtol (not extrapolated): the control per step
#: (``error_per_step``: each step's error against the rate times the mean step so far, which
#: spreads the same sum with fewer steps) reaches this fraction of its budget, as the mean
#: step so far lags the run's (the flow start's short steps come first); its rate is raised
#: by 1 / PER_STEP_FILL. Measured as the error against the request on the limit cycle of
#: benchmarks/bench_limit_cycle.py (rtol 1e-2 ... 1e-4).
PER_STEP_FILL = 0.6
#: generalised-alpha with rtol, second order: rho_inf unless given. The
#: smallest numerical damping with about one Newton correction per step (docs/performance.md,
#: "rho_inf"): the control's steps pass over the elements' stiff modes a flow start rings,
#: which rho_inf = 0.8 leaves ringing (two corrections a step); the slow motion's error
#: hardly changes. Bodies too: their joints' stiff modes, rung by a flow start and by a
#: large flutter, held the step (a fluttering cantilever of 8 bodies at rtol 3e-3: 2417
#: steps at 0.8, 1963 at 0.6, the tip's error 3.2e-4 and 5.4e-4 m; the semicircle of
#: Table 1 at rtol 0.1: 650-1255 steps against 971-1737, final rates within 5.4e-5 of each
#: other, relative).
CONTROLLED_RHO_INF = 0.6
#: The order rule of ``simulate(..., rtol=)`` on element models: at rtol >= EXTRAPOLATE_BELOW
#: the error-controlled run alone (second order); below it, Richardson extrapolation over
#: a controlled mesh (fourth order where the error's expansion holds): a run controlled at
#: the looser rtol_mesh = min(MESH_FACTOR rtol^MESH_EXPONENT, MAX_MESH_RTOL), then the same
#: mesh with every step halved, quartered, ... (at most EXTRAPOLATION_LEVELS halvings,
#: rho_inf = 1 unless given), until the estimated error of the two finest runs' combination
#: meets rtol L + atol. On the limit cycle of bench_limit_cycle.py: 3374-3395 steps for
#: 0.8-4.9e-7 m at rtol 1e-6 (the second-order control takes 33586 for 5.8e-7 m); at 1e-8
#: the estimate after two halvings is 0.99-1.01 of the request, as the mesh's round-off
#: falls: 11704 steps for 3.4e-9 m, or a third halving, 25170 for 2.0e-9 m. MESH_FACTOR and
#: MESH_EXPONENT: measured there so that two halvings meet rtol from 1e-6 to 1e-8 (the
#: combinations' error falls about as rtol_mesh^1.5 there, not rtol_mesh^2: hence 2/3, not
#: 1/2); a finer mesh at 1e-8 (exponent 0.79, the same mesh at 1e-6) met it by two halvings
#: at 0.4 of the request, but the spin-up of benchmarks/bench_peer.py then took 5 times the
#: steps.
EXTRAPOLATE_BELOW = 1e-4
MESH_FACTOR = 80.0
MESH_EXPONENT = 2.0 / 3.0
MAX_MESH_RTOL = 1e-2  # coarser meshes' runs differ by more than a discretisation error (rotations)
#: ... and its mesh's control: local error estimates summed to at most (rtol_mesh L + atol) /
#: MESH_ERROR_ACCUMULATION (with which MESH_FACTOR was measured; rotations at the model size)
MESH_ERROR_ACCUMULATION = 0.1
#: ... halvings at most: added only while the estimate misses rtol L + atol. The rotating
#: cantilever's spin-up (benchmarks/bench_peer.py, L = 8 m) at rtol 1e-8: its mesh (rtol_mesh 3.7e-4, 186
#: steps up to 0.4 s against the tip's 6 mm vibration of about 1 s) reaches the asymptotic
#: range only at the third halving (the finest run's error falls 25, 1, 3.4, 3.9, 3.8 times
#: per halving); after 4 halvings 5.5e-8 L (estimate 7.9e-7 L), after 6 3-4e-9 L (23622
#: steps in all, 0.07 s). Newton's tolerance is not the cause: 100 times tighter, the same
#: 5.5e-8 L.
EXTRAPOLATION_LEVELS = 6
#: ... the error estimate of the finest combination (positions): its largest change from the
#: combination a level coarser / 15 (a rate of 16 per halving) where that change is at most
#: EXTRAPOLATION_SETTLED of the finest run's correction (the h^4 term small beside the h^2
#: one: 0.01-0.06 measured on the limit cycle, where the rates were 8-22 and this estimate
#: 0.8-2.7 of the error at rtol 1e-5 ... 1e-8), else / 3 (a rate of 4: 0.2-1.1 on a flutter growing from a flow
#: start, whose combinations gain 1-4 per halving).
EXTRAPOLATION_SETTLED = 0.1
#: ... Newton's tolerance (relative to L; the combination does not cancel Newton's error):
#: EXTRAPOLATION_NEWTON_SHARE rtol in the coarse run, and in each refined run of n steps
#: at most EXTRAPOLATION_NEWTON_SUM rtol / n (Newton's errors grow with the steps: at rtol
#: 1e-8 over a mesh at rtol_mesh 4.6e-4, 1e-10 left 3.0e-8 m after three halvings, 8e-12
#: left 1.9e-9 m)
EXTRAPOLATION_NEWTON_SHARE = 0.01
EXTRAPOLATION_NEWTON_SUM = 10.0
#: ... the coarse mesh's steps (failed ones included) at most: a mesh that needs more
#: resolves modes the motion does not (stiff ones that ring undamped at rho_inf = 1, which
#: the second-order run's damping removes), and the second-order run at rtol is returned
#: instead (logged). The rigid sprinkler (scenes.sprinkler(EI=1, rigid=True): EI 1e9 N m^2,
#: spun up by its flow over 0.5 s) at rtol 5e-5: its mesh took 794777 steps and 243118 failed
#: ones (22 s), the extrapolation 11.9 million steps in all (146 s); the second-order run
#: 1051 steps (1.9e-5 m), 2.3 s with the mesh given up. The meshes
#: of bench_peer.py's scenes take 20-1700 steps at rtol 1e-5 ... 1e-8.
EXTRAPOLATION_MESH_MAX_STEPS = 100_000
#: ... and where the extrapolation fails (that budget, or runs that differ by more than a
#: discretisation error), the second-order run's Newton tolerance unless newton_tol is given
#: (relative to L): such scenes (stiff modes about a free rotation) are where a modified
#: Newton's contraction, measured on fast coordinates, hides a slow one. The rigid sprinkler
#: at rtol 2e-5 and 1e-5: 1.6e-4 and 1.8e-4 m in 4368 and 11312 steps with the controlled
#: tolerance, 1.2e-5 and 3.5e-6 m in 1564 and 5428 steps so.
FALLBACK_NEWTON_TOL = 1e-10
_OPTIONS = {
    "ida": {"rtol", "atol", "rebase_angle", "max_steps", "max_order", "divergence_limit", "work"},
    "generalized_alpha": {"step", "rho_inf", "newton_tol", "max_newton", "min_step", "max_steps",
                          "divergence_limit", "work", "rtol", "atol"},
}
_OPTIONS["auto"] = _OPTIONS["ida"] | _OPTIONS["generalized_alpha"]
#: options that only IDA takes: passing one with ``integrator="auto"`` selects IDA.
IDA_ONLY = frozenset(_OPTIONS["ida"] - _OPTIONS["generalized_alpha"])
#: "auto"'s generalised-alpha step: this many steps per period 2 pi/|lambda_1| of the
#: slowest non-rigid eigenvalue lambda_1 of the linearised model (i.e. >= 40 steps per
#: period of every mode up to 10 |lambda_1|).
STEPS_PER_SLOWEST_PERIOD = 400
#: ... and at most this h |lambda_g| for the fastest growing eigenvalue lambda_g (flutter,
#: divergence). Generalised-alpha's discrete rate is lambda (1 + O((h lambda)^2)): its
#: relative error is (h |lambda|)^2 / 12 (the period error; 2.1e-4 at 0.05), while its
#: numerical damping at rho_inf = 0.8 (the default) is a damping ratio of 8.6e-8 there
#: (9e-9 at 0.9; it acts on the unresolved modes, h |lambda| >> 1). A growing motion is
#: followed over some 20-30
#: e-foldings before it turns nonlinear or diverges: by this estimate its amplitude errs
#: by ~0.5 %; measured, 1.7 % (the 8-element cantilever at 1e6 kg/s over 25 e-foldings,
#: against h/4; 5-7 % at 0.1, 17-23 % at 0.2).
GROWING_STEP_FACTOR = 0.05
_MODES_FOR_STEP = 12  # eigenvalues nearest 0 examined for lambda_1 (sparse path on large models)
_MAX_MODES_FOR_GROWTH = 192  # sparse path: eigenvalues nearest 0 examined at most for lambda_g
_DENSE_MAX_DOFS = 2000  # sparse path: all eigenvalues (dense) up to this size for lambda_g


def choose_integrator(integrator: str, options) -> str:
    """The integrator ``simulate`` runs: ``integrator`` itself unless it is ``"auto"``;
    then ``"ida"`` if an IDA-only option (``rebase_angle``, ``max_order``) is given, else
    ``"generalized_alpha"`` (with ``rtol``: its error-controlled step). The structural models have no
    damping: IDA's error control resolves the undamped axial and bending modes a flow
    start excites (~1e6 steps per second of motion on the fluid-conveying pipes),
    where generalised-alpha's numerical damping (``rho_inf``) leaves them behind at a
    step set by the slow motion."""
    if integrator not in INTEGRATORS:
        raise ValueError(f"unknown integrator {integrator!r}; choose from {INTEGRATORS}")
    if integrator != "auto":
        return integrator
    ida = sorted(set(options) & IDA_ONLY)
    ga = sorted(set(options) & (_OPTIONS["generalized_alpha"] - _OPTIONS["ida"]))
    if ida and ga:
        raise ValueError(f"options of both integrators: {ida} (IDA) and {ga} (generalised-alpha); "
                         "choose one with integrator='ida' or 'generalized_alpha'")
    return "ida" if ida else "generalized_alpha"


def step_rates(model, state=None, mass_flow: Optional[float] = None, *,
               duration: float = np.inf) -> Tuple[float, float]:
    """(|lambda_1|, |lambda_g|) [1/s] of the model linearised about ``state``, the two rates
    :func:`default_step` follows; ``duration`` T [s] is the run's length.

    |lambda_1|: the smallest magnitude of the non-rigid eigenvalues among the 12 nearest 0
    (an angular frequency or, for a real eigenvalue, a growth or decay rate). An
    eigenvalue within 1e4 times its round-off bound (``EigenResult.noise``) of 0 counts
    as rigid (a free hinge without flow: round-off splits its double zero to ~1e2 noise;
    the elastic ones lie > 1e6 noise away). NaN if there is none.

    |lambda_g|: the largest magnitude of the non-rigid eigenvalues that grow (real part
    above its round-off bound, the test of :func:`pipeflex.stability`: flutter,
    divergence) by at least a factor e over the run, Re(lambda) T >= 1 (a slower growth
    is an oscillation like the stable ones: the sucking sprinkler's bending modes grow at
    Re(lambda) ~ 1e-4 1/s); NaN if none does. Below
    :data:`~pipeflex.analysis.eigen.SPARSE_MIN_DOFS` coordinates every eigenvalue is
    examined (the dense solve finds them all anyway); above, the 12 nearest 0 (shift-invert),
    and all of them (dense, up to 2,000 coordinates: 0.6 s at 960) where the fastest
    growing one lies in the outer half of those or the shift-invert fails (far above a
    critical flow, K(mdot) turns nearly singular); beyond 2,000 coordinates the 12 are
    doubled, up to 192, instead.
    """
    from .eigen import SPARSE_MIN_DOFS, _growing, _select, eigenvalues
    from .linearize import linearize

    def rates(e):
        lam = np.abs(e.values)
        noise = np.zeros_like(lam) if e.noise is None else np.asarray(e.noise, float)
        elastic = np.isfinite(lam) & (lam > 1e4 * noise)
        return lam, elastic, elastic & _growing(e) & (e.values.real >= 1.0 / duration)  # e-fold in T

    def beyond(lam, elastic, grows):  # growing eigenvalues may lie beyond those examined
        return grows.any() and lam[grows].max() > 0.5 * lam[elastic].max()

    lin = linearize(model, state, mass_flow=mass_flow)
    n = lin.K.shape[0]
    if n < SPARSE_MIN_DOFS:
        near = full = eigenvalues(lin)
    else:
        full = None
        try:
            near = eigenvalues(lin, n_modes=_MODES_FOR_STEP)
        except np.linalg.LinAlgError:
            if n > _DENSE_MAX_DOFS:
                raise
            near = None
        if (near is None or beyond(*rates(near))) and n <= _DENSE_MAX_DOFS:
            full = eigenvalues(lin, method="dense")
    lam, elastic, grows = rates(_select(near if near is not None else full, _MODES_FOR_STEP, 0.0))
    slowest = float(lam[elastic].min()) if elastic.any() else float("nan")
    if full is not None:
        lam, elastic, grows = rates(full)
    k = _MODES_FOR_STEP
    while full is None and beyond(lam, elastic, grows) and k < _MAX_MODES_FOR_GROWTH:
        k *= 2
        lam, elastic, grows = rates(eigenvalues(lin, n_modes=k))
    return slowest, float(lam[grows].max()) if grows.any() else float("nan")


def slowest_rate(model, state=None, mass_flow: Optional[float] = None) -> float:
    """|lambda_1| [1/s] of :func:`step_rates`: the smallest magnitude of the non-rigid
    eigenvalues of the model linearised about ``state`` among the 12 nearest 0; NaN if
    there is none."""
    return step_rates(model, state, mass_flow)[0]


def default_step(model, times: Sequence[float], state=None, mass_flow: Optional[float] = None) -> float:
    """The generalised-alpha step [s] of ``simulate(..., integrator="auto")`` without ``step``:
    h_max = min(2 pi / (STEPS_PER_SLOWEST_PERIOD |lambda_1|), GROWING_STEP_FACTOR / |lambda_g|)
    (:func:`step_rates`, about the initial state at ``mass_flow``; the growing modes that
    grow by a factor e or more over the run), shortened to divide the smallest output
    spacing dt into whole steps: h = dt / ceil(dt / h_max). Without a non-rigid
    eigenvalue, h_max = 1e-3 s.

    The first bound resolves the slow motion, the second the fastest growing mode (400
    and >= 126 steps per period 2 pi/|lambda|). The second binds only where a growing
    eigenvalue exceeds 3.2 |lambda_1| in magnitude: far above a critical flow, or the
    soft sprinkler (EI = 1 N m^2) over 1 s, whose bending flutters at 6.7 +- 29.6j 1/s
    against |lambda_1| = 0.39 1/s. Below a critical flow and just above it (the
    8-element cantilever at 30 kg/s: |lambda_g| = 14.4 against |lambda_1| = 12.0 1/s)
    the step is the slow motion's alone.

    For the rotating sprinkler (``scenes.sprinkler``, EI = 100 N m^2, |lambda_1| = 7.9 1/s)
    a 1 s run with 201 outputs gets h = 5 ms / 3 = 1.67 ms: its mean hinge speed over
    0.5-1 s is within 3e-6 (relative) of a 25 us run; 5 ms steps (dt alone) err by 2e-4
    (docs/performance.md). The 8-element cantilever at 1e6 kg/s (|lambda_g| = 8.6e6 1/s
    against |lambda_1| = 435 1/s, a torsion mode), started with a 1 mm/s tip velocity,
    gets h = 5.8 ns: its tip motion over 3 us agrees within 2 % of its largest deflection
    (5.6 mm) with a run at h/4, while the slow motion's step (the 3 us in one step) ends
    at 1.4e-8 m for 4.1e-4 m.
    """
    times = np.asarray(times, float)
    rate, growth = step_rates(model, state, mass_flow, duration=float(times[-1] - times[0]))
    h_max = 2 * np.pi / (STEPS_PER_SLOWEST_PERIOD * rate) if np.isfinite(rate) and rate > 0 else 1e-3
    if np.isfinite(growth) and growth > 0 and GROWING_STEP_FACTOR / growth < h_max:
        h_max = GROWING_STEP_FACTOR / growth
        logger.info("simulate: step %.6g s from the fastest growing eigenvalue, |lambda| = %.6g 1/s", h_max, growth)
    gaps = np.diff(times)
    dt = float(gaps.min())
    if gaps.max() - dt <= 1e-9 * dt:  # equally spaced: the exact spacing, not a rounded difference
        dt = (times[-1] - times[0]) / len(gaps)
    return dt / np.ceil(dt / h_max - 1e-9)


def _control_per_step(opt, rtol: float, atol: float, length: float, duration: float) -> None:
    """Set ``opt`` for generalised-alpha's error control per step at ``rtol``, ``atol`` [m]:
    the run's local error estimates add up to about (rtol L + atol) / ERROR_ACCUMULATION, its
    error to about rtol L + atol (L the model's ``length``, or the motion's size D where that
    is larger: a motion that outgrows the model), over ``duration`` [s]."""
    budget = ERROR_ACCUMULATION * PER_STEP_FILL * duration
    opt.error_rate = (rtol * length + atol) / budget
    opt.motion_rate = rtol / budget
    opt.error_per_step = True


def _step_used(step: float, times: np.ndarray) -> float:
    """The largest step [s] generalised-alpha takes for ``step`` h: each output interval
    dt is split into ceil(dt / h) equal steps (the core's rule), so a step longer than the
    output spacing becomes that spacing. ``step`` itself where every interval is a whole
    number of steps (to round-off)."""
    times = np.asarray(times, float)
    gaps = np.diff(times)
    if gaps.max() - gaps.min() <= 1e-9 * gaps.min():  # equally spaced: the exact spacing (as default_step)
        gaps = np.array([(times[-1] - times[0]) / len(gaps)])
    used = float(np.max(gaps / np.ceil(gaps / step - 1e-9)))
    return step if abs(used - step) <= 1e-9 * step else used


def _inertia_hint(model) -> str:
    """Why the mass matrix is singular and what to do, if pipe sections lack the polar
    rotary inertia rho I_p (their rotation about the pipe axis then has no inertia);
    "" if none does."""
    elements = getattr(model, "elements", ())  # bodies: their own error says why
    pipes = [i for i, e in enumerate(elements) if e.kind == "pipe"]
    bare = [i for i in pipes if elements[i].section.rotary_inertia[0] == 0]
    if not bare:
        return ""
    which = f"{bare[0]}..{bare[-1]}" if len(bare) > 3 and bare[-1] - bare[0] == len(bare) - 1 else \
        ", ".join(map(str, bare[:8])) + (", ..." if len(bare) > 8 else "")
    return (f"time integration needs the polar rotary inertia rho I_p [kg m] of the pipe sections (the inertia of "
            f"the rotation about the pipe axis), and it is 0 in {len(bare)} of the {len(pipes)} pipe elements "
            f"({which}). Give it as PipeSection(..., rotary_inertia=(rho_Ip, rho_Iy, rho_Iz)), "
            "PipeSection.tube(..., rotary_inertia=True), or a scene's polar_inertia= (e.g. "
            "pf.scenes.cantilever_pipe(n_elements=8, polar_inertia=1e-4): a small value leaves the bending motion "
            "alone); or constrain the axial rotation (ModelBuilder.fix_rotation). The static, eigen and "
            "critical-flow analyses do not need it.")


@contextlib.contextmanager
def explained_singular_mass(model):
    """The core's "the mass matrix is singular" ValueError raised again with the reason and
    the remedy (:func:`_inertia_hint`) where pipe sections lack the polar rotary inertia:
    every time integration of an element model (``simulate``, the shooting's flow map)."""
    try:
        yield
    except ValueError as exc:
        hint = _inertia_hint(model) if str(exc).startswith("the mass matrix is singular") else ""
        if not hint:
            raise
        raise ValueError(f"the mass matrix is singular: {hint}") from None


#: The bodies' motion's accessors that a result of bodies alone also answers itself
#: (``res.node_position(...)`` for ``res.bodies.node_position(...)``).
_BODY_ACCESSORS = frozenset({"r", "eta", "v", "drift", "offsets", "n_constraints", "nodes_s", "bases", "n_coordinates",
                             "state", "node_position", "angular_velocity", "node_angular_velocity"})


@dataclass(frozen=True)
class TransientResult(Result):
    """Motion at the output times, of every formulation; arrays are numpy, SI units.

    Attributes:
        t: (nt,) output times [s].
        x: (nt, N, 3) node positions [m]; R: (nt, N, 3, 3) node rotation matrices.
        xd: (nt, N, 3) node velocities [m/s]; omega: (nt, N, 3) spatial angular velocities [rad/s].
        kinetic, elastic, gravity_potential: (nt,) energies [J].
        fluid_work: (nt,) work done by the fluid forces on the structure since t[0] [J]
            (momentum flux in and out, Coriolis and centripetal forces).
        load_work: (nt,) work of the nodal loads [J].
        dissipated: (nt,) energy D [J] the damping forces (Kelvin-Voigt and external
            viscous damping of the sections, dashpots of the springs) took out of the
            motion since t[0]: the integral of v . f_d >= 0, so D >= 0 and never
            decreasing; exactly 0 for an undamped model.
            (x ... dissipated: the element model's, of an element model or a coupled
            system; None for bodies alone.)
        final_state: the state at the end (to continue the run, or to start a periodic
            orbit from a settled transient): a :class:`~pipeflex.state.State`, a
            :class:`~pipeflex.multibody.MultibodyState` or a
            :class:`~pipeflex.coupled.CoupledState`, as the system's.
        stats: integrator statistics (steps, Newton iterations, Jacobians, re-basings,
            failed steps, wall time [s]).
        metadata: ``integrator`` (the one that ran), ``requested`` (e.g. ``"auto"``),
            ``step`` (the largest step [s] generalised-alpha took, None for IDA),
            ``requested_step`` (the step asked for or chosen, before it was fitted to
            the output spacing), options and model description.
        bodies: the bodies' motion (a :class:`~pipeflex.multibody.MultibodyResult`:
            frames, elastic coordinates, velocities, constraint drift, and its accessors
            ``node_position``, ``state(k)``, ...) of a system with bodies, else None. A
            result of bodies alone answers those accessors itself (``res.node_position``).
        coupling_forces: (nt, rows) the couplings' multipliers [N, N m] of a coupled
            system, else None.
        sensors: ``simulate(..., sensors=)``'s records (:mod:`pipeflex.sensor`): name ->
            ``(t_steps, values)``, t_steps (n,) [s] the start and every accepted step,
            values (n,) or (n, components) in the sensor's unit; a crossing's name ->
            ``(times [s], signs)`` (+1 up, -1 down). ``metadata["sensors"]`` holds each
            one's units (and components). Empty without sensors.
    """

    t: np.ndarray
    x: Optional[np.ndarray] = None
    R: Optional[np.ndarray] = None
    xd: Optional[np.ndarray] = None
    omega: Optional[np.ndarray] = None
    kinetic: Optional[np.ndarray] = None
    elastic: Optional[np.ndarray] = None
    gravity_potential: Optional[np.ndarray] = None
    fluid_work: Optional[np.ndarray] = None
    load_work: Optional[np.ndarray] = None
    dissipated: Optional[np.ndarray] = None
    stats: dict = field(default_factory=dict)
    metadata: dict = field(default_factory=dict)
    final_state: Optional[object] = None
    bodies: Optional[Result] = None
    coupling_forces: Optional[np.ndarray] = None
    sensors: dict = field(default_factory=dict)

    _ARRAYS = ("t", "x", "R", "xd", "omega", "kinetic", "elastic", "gravity_potential", "fluid_work", "load_work",
               "dissipated")

    def __getattr__(self, name):
        # only for names not found otherwise: a result of bodies alone answers its bodies' accessors
        fields = self.__dict__
        if name in _BODY_ACCESSORS and fields.get("bodies") is not None and fields.get("x") is None:
            return getattr(fields["bodies"], name)
        raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")

    @property
    def elements(self) -> Optional["TransientResult"]:
        """The element part: the result itself for an element model's run; a coupled run's
        element motion with the element model's ``final_state`` (a
        :class:`~pipeflex.state.State`); None for bodies alone."""
        if self.x is None or self.bodies is None:
            return self if self.x is not None else None
        end = self.final_state
        return replace(self, bodies=None, coupling_forces=None, final_state=None if end is None else end.state)

    def to_vtk(self, folder, model=None, **options):
        """Write the result for ParaView (``.pvd`` + ``.vtu`` files in ``folder``) through
        meshio; ``model``: the model it was computed with. Options and data:
        :func:`pipeflex.vtk.write_vtk`. Returns the .pvd paths."""
        from ..vtk import write_vtk

        return write_vtk(self, folder, model, **options)

    @property
    def energy(self) -> np.ndarray:
        """Mechanical energy T + U + V_g [J]."""
        return self.kinetic + self.elastic + self.gravity_potential

    def energy_balance(self) -> np.ndarray:
        """E(t) - E(0) - W_fluid(t) - W_loads(t) + D(t) [J]: zero up to the integration error.

        E = T + U + V_g is the mechanical energy (:attr:`energy`), W the work done on the
        structure by the fluid forces and the loads, D = :attr:`dissipated` >= 0 the energy
        the damping forces took out (the energy equation E - E(0) = W - D): damped models
        balance as undamped ones do. A result whose ``dissipated`` is None counts D = 0."""
        D = 0.0 if self.dissipated is None else self.dissipated
        return self.energy - self.energy[0] - self.fluid_work - self.load_work + D

    def angle(self, node: int, axis: Sequence[float] = (0.0, 0.0, 1.0)) -> np.ndarray:
        """Unwrapped rotation angle [rad] of a node about a fixed ``axis`` (for planar
        rotation about that axis, e.g. a hinge), from the rotation matrices."""
        k = _checks.unit_vector("axis", axis)
        ref = np.linalg.svd(k.reshape(1, 3))[2][1]  # a vector normal to the axis
        rot = self.R[:, node] @ self.R[0, node].T @ ref
        ang = np.arctan2(np.einsum("j,ij->i", k, np.cross(ref, rot)), rot @ ref)
        return np.unwrap(ang)

    def to_xarray(self):
        """The motion as an ``xarray.Dataset``: ``x``, ``xd``, ``omega`` over (time, node,
        component), ``R`` over (time, node, row, column), the energies and works over
        time; coordinates ``time`` (= ``t`` [s]), ``node`` (indices) and ``component``
        (x, y, z); every variable with ``units`` and ``long_name``; ``attrs``: the
        integrator and its step [s] (None for IDA: left out). xarray loads here.
        Sensors (:attr:`sensors`) are variables of their names over the coordinate
        ``step_time`` [s] (the recorded steps; a sensor of several components also over
        ``<name>_component``), a crossing's times over ``<name>_event``."""
        from ..results import field_info, node_coords, to_dataset

        if self.x is None:
            raise ValueError("to_xarray() holds the element nodes' motion; a run of bodies alone has none (its "
                             "bodies' motion: result.bodies)")
        coords = {"time": ("time", self.t, field_info("TransientResult", "t")[0]), **node_coords(self.x.shape[1])}
        attrs = {k: self.metadata[k] for k in ("integrator", "requested", "step")
                 if isinstance(self.metadata.get(k), (str, int, float))}
        ds = to_dataset("TransientResult", {name: getattr(self, name) for name in self._ARRAYS[1:]}, coords, attrs)
        info = self.metadata.get("sensors", {})
        for name, (t, values) in self.sensors.items():
            about = info.get(name, {})
            if about.get("kind") == "crossing":
                ds[name] = ((f"{name}_event",), t, {"units": "s", "long_name": f"times of {name}"})
                continue
            if "step_time" not in ds.coords:
                ds = ds.assign_coords(step_time=("step_time", t, {"units": "s", "long_name": "recorded step times"}))
            units = about.get("units")
            attrs = {"long_name": name, **({"units": units} if isinstance(units, str) else {})}
            if np.ndim(values) == 2:
                dim = f"{name}_component"
                ds = ds.assign_coords({dim: (dim, np.array(about.get("components", range(values.shape[1])),
                                                          dtype=object))})
                if not isinstance(units, str) and units is not None:
                    attrs["units"] = ", ".join(units)
                ds[name] = (("step_time", dim), values, attrs)
            else:
                ds[name] = (("step_time",), values, attrs)
        return ds

    @classmethod
    def _load_legacy(cls, f) -> "TransientResult":
        """A file of the earlier format: the arrays, stats and metadata as JSON."""
        return cls(**{k: f[k] for k in cls._ARRAYS if k in f}, stats=json.loads(str(f["stats"])),
                   metadata=json.loads(str(f["metadata"])))


def simulate(model, t_end: float, *, integrator: str = "auto", state=None, t_start: float = 0.0,
             n_outputs: int = 201, times: Optional[Sequence[float]] = None,
             mass_flow: Union[None, float, Tuple[Sequence[float], Sequence[float]], Sine] = None,
             load_factor: Union[float, Tuple[Sequence[float], Sequence[float]], Sine] = 1.0,
             progress: Optional[bool] = None, extrapolate: bool = False, sensors: Sequence = (),
             **options) -> TransientResult:
    """Integrate the equations of motion from ``state`` over [t_start, t_end].

    Args:
        model: an element :class:`~pipeflex.Model`, a
            :class:`~pipeflex.multibody.MultibodySystem` or a :class:`~pipeflex.CoupledSystem`
            (elements and floating-frame bodies): the same driver and options for each;
            bodies and joints make the equations differential-algebraic of index 3, which
            generalised-alpha integrates as they are (with ``rho_inf`` < 1) and IDA in their
            stabilised index-2 form (positions and velocities on the constraints;
            docs/theory.md).
        t_end: final time [s] (> t_start).
        integrator: ``"auto"`` (default), ``"generalized_alpha"`` (second order, numerical
            damping set by ``rho_inf``; fixed step, halved when Newton fails) or ``"ida"``
            (SUNDIALS IDA, variable-order variable-step BDF with error control: for smooth,
            damped motions; on the undamped pipe and beam models it resolves every axial
            and bending mode the start excites, ~1e6 steps per second of motion).
            ``"auto"`` runs IDA if an IDA-only option (``rebase_angle``, ``max_order``)
            is given, else generalised-alpha: with ``rtol`` its error-controlled step (see
            ``**options``), else with the ``step`` given or :func:`default_step`: 400 steps per period
            ``2 pi/|lambda_1|`` of the slowest non-rigid eigenvalue of the model linearised
            about ``state`` (at the largest ``mass_flow`` of the run), and at most
            ``h |lambda_g| = 0.05`` for the fastest eigenvalue lambda_g that grows by a
            factor e or more over the run (flutter or divergence; generalised-alpha's rate
            error is ``(h |lambda|)^2 / 12``, 2.1e-4 there, and its numerical damping at
            ``rho_inf = 0.8`` negligible), shortened to divide the output spacing (e.g.
            1.67 ms for the sprinkler with EI = 100 N m^2 over 1 s, from the slow motion;
            5.8 ns for the 8-element cantilever at 1e6 kg/s, 40,000 times its critical
            flow, whose flutter grows at 8.6e6 1/s).
            Options of both integrators together are an error with ``"auto"``.
            ``result.metadata["integrator"]`` and ``["step"]`` [s] (None for IDA) say
            what ran. The step actually taken: each output interval dt is split into
            ceil(dt / h) equal steps, so a ``step`` h longer than the output spacing
            runs at that spacing (``step=0.05`` with 5 ms between outputs steps 5 ms),
            and ``metadata["step"]`` is the largest step taken (``["requested_step"]``
            the h asked for); steps halved after a failed Newton iteration are counted
            in ``stats["convergence_failures"]``, steps redone for their error estimate
            (``rtol``) in ``stats["failed_steps"]``.
        state: initial state (an element model's :class:`~pipeflex.state.State` or
            ``_core.State``; bodies' :class:`~pipeflex.multibody.MultibodyState`; a coupled
            system's :class:`~pipeflex.coupled.CoupledState` or a static result; default:
            the reference configuration at rest); not modified.
        t_start: initial time [s].
        n_outputs: number of equally spaced output times (ignored if ``times`` is given).
        times: output times [s], increasing, from t_start to t_end.
        mass_flow: mdot [kg/s], constant, or a table ``(times [s], values [kg/s])``
            interpolated linearly, or a :class:`Sine` (its slope gives the
            relative-acceleration term). Default: the model's.
        load_factor: [-] multiplier of the model's nodal loads: a number, a table
            ``(times [s], values)`` or a :class:`Sine` (a harmonic drive).
        progress: None (default): a progress bar in a notebook or on a terminal once the
            run has taken 3 s of wall time, else (a log, CI) a line on the logger
            ``"pipeflex"`` every 15 s; True: the bar from the start (or the lines on
            stderr); False: nothing (:mod:`pipeflex._progress`; docs/user_guide.md,
            Progress and logging).
        **options: for ``ida``: ``rtol`` (1e-6), ``atol`` (1e-8), ``rebase_angle`` [rad]
            (1.0), ``max_steps``; for ``generalized_alpha``: ``rtol`` [-] and ``atol``
            [m] (0): the accuracy asked for, error-controlled steps: each step's local
            error estimate (the displacement's, Zienkiewicz & Xie's (beta - 1/6) h^2
            (a' - a); a node's rotation error counts times 4/27 of its longest
            element's length, the most it bends a cubic Hermite element whose nodes
            are held; a floating frame's times the model size) is kept below
            ``(rtol L + atol) h_mean / (ERROR_ACCUMULATION PER_STEP_FILL (t_end -
            t_start))``, h_mean the mean of the steps taken so far (error per step: the
            steps go as the error's coefficient C^(-1/3), not C^(-1/2) as per unit step,
            which meets the same sum of local errors with fewer steps; the filled
            share :data:`PER_STEP_FILL` 0.6), L the
            model's size (``length_scale``), or the motion's size D where that is larger
            (the largest displacement of a node from its reference position, or of a
            body's frame origin from where it started, at the step's start):
            ``(rtol max(L, D) + atol) h_mean / (...)``, so that a motion
            that outgrows the model (a divergence) keeps its relative accuracy, not
            ever shorter steps; the estimates then add up to rtol times D's mean over
            the run, at most its largest. The run's error, about
            :data:`ERROR_ACCUMULATION` (0.3) of its summed estimates (the stiff modes' and
            a limit cycle's local errors do not add up), lands near ``rtol L + atol``
            (``stats["error_estimate"]`` [m] is 0.3 of the sum; on the flutter limit
            cycle of ``benchmarks/bench_limit_cycle.py`` the error is 0.9-1.2 of the
            request, on a growing flutter 0.18-0.21 of it: below, not above); ``rho_inf``
            0.6 unless given (:data:`CONTROLLED_RHO_INF`). That
            is second order; below rtol = :data:`EXTRAPOLATE_BELOW` (1e-4) an element
            model's run is Richardson-extrapolated over a controlled mesh (the rule there:
            a run at a looser rtol, then its mesh halved, quartered, ... until the
            estimated error meets ``rtol max(L, D) + atol``; ``stats["error_estimate"]`` is that
            estimate and ``metadata["extrapolated"]`` holds the halvings; ``rho_inf`` 1
            unless given, Newton's tolerance 0.01 rtol, in a refined run of n steps at
            most 10 rtol / n), fourth order where the motion is
            smooth on the mesh's scale; ``step`` is then the first
            step (default (t_end - t_start) / 1000) and Newton's tolerance follows each
            step's share of the error (``newton_tol``, if given, caps it);
            ``stats["smallest_step"]``, ``["largest_step"]`` [s] and ``["failed_steps"]``
            (steps redone for their error) tell how it went; ``step`` [s] (1e-3 with
            ``integrator="generalized_alpha"``, :func:`default_step` with ``"auto"``),
            ``rho_inf`` [-] (0.8, in [0, 1]: damps the unresolved high modes a step
            start of the flow excites; 1, no damping, is allowed for an element model,
            whose supports are eliminated, while joints' multipliers need < 1),
            ``newton_tol`` [-] (1e-10, on the position correction relative to the
            model size), ``max_newton`` (12, Newton iterations per step), ``min_step`` [s],
            ``max_steps`` (10^7); one default each for every formulation
            (:mod:`pipeflex._options` says why). Both: ``divergence_limit`` (1e3): a node
            farther than this many model sizes from its reference position stops the run
            with :class:`~pipeflex.ConvergenceError`; ``work`` (True): integrate the work of the
            fluid forces and loads, and the energy the damping dissipates, at every step
            (the fluid forces' and loads' power at each step end: 0.4-0.6 us of the 6.3 us
            step of the 8-element cantilever of benchmarks/bench_limit_cycle.py at
            rtol 1e-4; without it ``fluid_work``, ``load_work`` and ``dissipated`` are
            NaN).
        extrapolate: generalised-alpha only: run at the step h and at h/2 and combine the
            outputs by Richardson extrapolation, y = y_h/2 + (y_h/2 - y_h)/3, which removes
            the h^2 term of the global error (:func:`richardson`): fourth order with
            ``rho_inf=1`` (a symmetric method), third otherwise; for smooth motion and a
            tight ``newton_tol`` (the default), whose error the combination does not
            cancel. E.g. the tip of Meijaard & Hakvoort's fluttering cantilever (Fig. 3)
            at 2 s: 1e-4 m at h = 1.25 ms alone, 4e-7 m extrapolated from 2.5 and
            1.25 ms (docs/performance.md).
            The output times must be whole steps of h from t_start.
        sensors: :mod:`pipeflex.sensor` sensors and crossings, recorded at the start and
            every accepted step in the core (``result.sensors``; element models,
            floating-frame bodies and coupled systems, custom sensors of the user's
            functions).
            A terminal crossing ends the run at the step that crosses
            (``metadata["stopped_at"]`` its time [s]); the outputs then end there. With
            Richardson extrapolation (``extrapolate`` or a small ``rtol``) the sensors are
            those of the finest run.

    Raises:
        ValueError: bad time span, tolerances, unknown integrator or option, a singular
            mass matrix (coordinates without inertia).
        ConvergenceError: a failed step or a diverging motion; ``time`` [s] (and for
            generalised-alpha ``iteration`` and ``residual``) say where.
    """
    require_system(model)
    requested = integrator
    integrator = choose_integrator(integrator, options)
    unknown = set(options) - _OPTIONS[integrator]
    if unknown:
        raise ValueError(f"unknown option(s) {sorted(unknown)} for integrator {integrator!r}; "
                         f"valid: {sorted(_OPTIONS[integrator])}")
    if extrapolate and integrator != "generalized_alpha":
        raise ValueError("extrapolate=True needs generalised-alpha (its fixed step; IDA controls its own error)")
    controlled = integrator == "generalized_alpha" and ("rtol" in options or "atol" in options)
    if controlled and extrapolate:
        raise ValueError("extrapolate=True combines two fixed-step runs; with rtol the step is error-controlled: "
                         "give one of them")
    if controlled and "rtol" not in options:
        raise ValueError("atol [m] is generalised-alpha's absolute error floor beside rtol: give rtol too")
    model._check_transient()
    t0 = _checks.finite("t_start", t_start)
    t1 = _checks.finite("t_end", t_end)
    if t1 <= t0:
        raise ValueError(f"t_end must be > t_start, got t_end = {t1}, t_start = {t0}")
    if times is None:
        times = np.linspace(t0, t1, _checks.output_count("n_outputs", n_outputs, model.n_nodes) + (n_outputs == 1))
    else:
        times = np.asarray(times, float)
        if times.ndim != 1 or len(times) < 2 or not np.all(np.isfinite(times)) or np.any(np.diff(times) <= 0):
            raise ValueError("times must be a finite, strictly increasing sequence of at least 2 values [s]")
        if abs(times[0] - t0) > 0 or times[-1] > t1 + 1e-12 * max(1.0, abs(t1)):
            raise ValueError("times must start at t_start and end at or before t_end")
    system = model._system(state)
    bodies = system.body_state is not None
    from .. import sensor as _sensor

    sensors = tuple(sensors)
    sensor_log, sensor_entries = _sensor.prepare(model, system, sensors) if sensors else (None, [])
    if bodies and extrapolate:
        raise ValueError("extrapolate=True is for element models (pipeflex.Model) only")
    opt = _core.TransientOptions()
    # one default per option for every formulation (pipeflex._options says why)
    opt.rho_inf, opt.newton_tol, opt.max_newton = RHO_INF, NEWTON_TOL, MAX_NEWTON
    opt.step, opt.max_steps = STEP, MAX_STEPS
    for name in ("step", "min_step", "newton_tol", "divergence_limit"):
        if name in options:
            setattr(opt, name, _checks.positive(name, options[name]))
    if controlled:
        rtol = _checks.positive("rtol", options["rtol"])
        if rtol < MIN_RTOL:
            raise ValueError(f"rtol must be >= {MIN_RTOL:g} (generalised-alpha's error control: below it round-off "
                             f"decides the error estimate), got {rtol:g}")
        atol = _checks.non_negative("atol", options.get("atol", 0.0))
        # below EXTRAPOLATE_BELOW (element models): Richardson over a controlled mesh and
        # the mesh halved, whose error falls as the mesh's rtol^1.5 ... ^2 (rho_inf = 1: fourth order)
        extrapolated = rtol < EXTRAPOLATE_BELOW and not bodies
        rtol_mesh = min(MESH_FACTOR * rtol ** MESH_EXPONENT, MAX_MESH_RTOL) if extrapolated else rtol
        # the mesh: error per unit step (MESH_FACTOR was measured so); the run alone: per step
        if extrapolated:
            accumulation = MESH_ERROR_ACCUMULATION * (t1 - t0)
            opt.error_rate = (rtol_mesh * system.length_scale + atol) / accumulation
            opt.motion_rate = rtol_mesh / accumulation
        else:
            _control_per_step(opt, rtol, atol, system.length_scale, t1 - t0)
        if "newton_tol" not in options:
            opt.newton_tol = CONTROLLED_NEWTON_TOL  # each step's share of the error decides
        if extrapolated:
            # the combination amplifies Newton's error (5/3) and does not cancel it
            opt.newton_tol = min(opt.newton_tol, EXTRAPOLATION_NEWTON_SHARE * rtol)
            if "rho_inf" not in options:
                opt.rho_inf = 1.0  # symmetric: the error's expansion in even powers of h
            # the mesh resolves every mode, the elements' stiff ones too: rotations count at
            # the model size (the expansion in h holds only for resolved modes)
            opt.rotation_error_length = system.length_scale
        elif "rho_inf" not in options:
            opt.rho_inf = CONTROLLED_RHO_INF
        if "step" not in options:
            opt.step = (t1 - t0) / 1000.0
    else:
        extrapolated = False
        for name in ("rtol", "atol"):
            if name in options:
                setattr(opt, name, _checks.positive(name, options[name]))
    if (extrapolate or extrapolated) and any(getattr(c, "terminal", False) for c in sensors):
        raise ValueError("a terminal crossing sensor ends a run early; Richardson extrapolation (extrapolate=True, or "
                         f"rtol < {EXTRAPOLATE_BELOW:g} on an element model) combines whole runs: use a looser rtol, "
                         "a fixed step, or no terminal crossing")
    if "rho_inf" in options:
        rho = _checks.finite("rho_inf", options["rho_inf"])
        if system.n_constraints:
            rho = _checks.rho_inf_with_multipliers(rho)
        elif not 0.0 <= rho <= 1.0:
            raise ValueError(f"rho_inf must be in [0, 1], got {rho}")
        opt.rho_inf = rho
    if "rebase_angle" in options:
        ang = _checks.positive("rebase_angle", options["rebase_angle"])
        if ang > 3.0:
            raise ValueError(f"rebase_angle must be <= 3 rad (the rotation vector is singular at 2 pi), got {ang}")
        opt.rebase_angle = ang
    if "max_order" in options:
        k = _checks.positive_int("max_order", options["max_order"])
        if k > 5:
            raise ValueError(f"max_order must be 1..5 (BDF orders), got {k}")
        opt.max_order = k
    for name in ("max_newton", "max_steps"):
        if name in options:
            setattr(opt, name, _checks.positive_int(name, options[name]))
    if "work" in options:
        opt.work = bool(options["work"])
    flow = time_function("mass_flow", model.mass_flow if mass_flow is None else mass_flow)
    loads = time_function("load_factor", load_factor)
    if requested == "auto" and integrator == "generalized_alpha" and "step" not in options and not controlled:
        peak = float(np.asarray(flow.value)[np.argmax(np.abs(flow.value))])
        # about the run's start itself (bodies: no static solve, which a free hinge would refuse)
        opt.step = default_step(model, times, model._state_of(system), mass_flow=peak)
    if integrator == "generalized_alpha" and opt.step > (t1 - t0):
        opt.step = t1 - t0
    if extrapolate:
        h = float(opt.step)
        whole = (times - t0) / h
        if np.any(np.abs(whole - np.round(whole)) > 1e-9 * np.maximum(whole, 1.0)):
            raise ValueError(f"extrapolate=True: the output times must be whole steps of h = {h:.6g} s from t_start "
                             "(choose step or the output times so)")
        run = dict(integrator=integrator, state=state, t_start=t_start, times=times, mass_flow=mass_flow,
                   load_factor=load_factor, progress=progress, sensors=sensors)
        return richardson(*(simulate(model, t_end, **run, **{**options, "step": step}) for step in (h, 0.5 * h)))

    def run(system, pass_name=""):
        """One run of the core on ``system`` with ``opt`` as it stands: a TransientResult."""
        replay = len(opt.steps) > 0
        step = _step_used(float(opt.step), times) if integrator == "generalized_alpha" and not controlled else None
        logger.info("simulate: %s%s from t = %.6g to %.6g s, %d outputs, %d coordinates%s", integrator, pass_name, t0,
                    t1, len(times), system.n_coordinates, "" if step is None else f", step {step:.6g} s")
        bar = _progress.Progress(progress, t1 - t0, desc=f"simulate ({integrator}{pass_name})", unit="s", leave=False)
        wall = _time.perf_counter()
        try:
            with bar, explained_singular_mass(model):
                out = _core.integrate(system, flow, loads, list(times), opt,
                                      None if bar.mode == "off" else (lambda t: bar.update(t - t0)), integrator,
                                      sensors=sensor_log)
                bar.update(t1 - t0)  # the core reports at most every 0.1 s, not the end
        except Exception as exc:
            logger.info("simulate: %s failed after %.3g s of wall time: %s", integrator, _time.perf_counter() - wall,
                        exc)
            raise
        wall = _time.perf_counter() - wall
        stats = {k: int(out.pop(k)) for k in COUNTERS}
        mesh = out.pop("step_sizes", None)
        if opt.error_rate > 0:  # the step control's figures
            stats["error_estimate"] = ERROR_ACCUMULATION * float(out.pop("error_sum"))
            stats["largest_local_error"] = float(out.pop("error_max"))
            for k in ("smallest_step", "largest_step"):
                stats[k] = float(out.pop(k))
            step = stats["largest_step"]
        elif replay:
            step = float(np.max(opt.steps))
        stats["wall_time"] = wall
        logger.info("simulate: %s done in %.3g s: %d steps (%d failed), %d Newton iterations", integrator, wall,
                    stats["steps"], stats["failed_steps"], stats["newton_iterations"])
        if not opt.work:  # the works were not integrated (an element part's; bodies record none)
            for name in ("fluid_work", "load_work", "dissipated"):
                if name in out:
                    out[name][:] = np.nan
        meta = {"integrator": integrator, "requested": requested,
                "step": step, "requested_step": float(opt.step) if step is not None else None,
                "rtol": float(options["rtol"]) if controlled else None,
                "options": {k: float(v) for k, v in options.items()}, "t_start": t0, "t_end": t1,
                "mass_flow": [list(flow.t), list(flow.value), flow.omega, flow.phase],
                "load_factor": [list(loads.t), list(loads.value), loads.omega, loads.phase]}
        recorded = {}
        if sensor_log is not None:
            recorded, meta["sensors"] = _sensor.collect(sensor_log, sensor_entries)
            if sensor_log.stopped:
                meta["stopped_at"] = float(sensor_log.stop_time)
        res = TransientResult(**model._transient_parts(out, system, stats, meta), stats=stats, metadata=meta,
                              sensors=recorded)
        return res, mesh

    if not extrapolated:
        return run(system)[0]
    # Richardson extrapolation over a controlled mesh (docs/user_guide.md): the coarse run's
    # steps, then each halved, quartered, ...: the combination of the two finest runs has the
    # error's h^2 term removed (rho_inf = 1: fourth order); its error is estimated by its
    # difference from the combination one level coarser, / 15 where that difference is
    # small beside the finest correction (EXTRAPOLATION_SETTLED: the expansion holds, a
    # rate of 16), else / 3 (1-4 measured before it holds). A level is added until the
    # estimate meets rtol max(L, D) + atol (D the coarse run's largest node displacement:
    # relative to a motion that outgrows the model, as the mesh's control).
    from ..errors import ConvergenceError

    # the coarse run enters only the estimate (the result combines the two finest runs): no works
    work, max_steps, mesh_newton_tol = opt.work, opt.max_steps, opt.newton_tol
    opt.work = work and EXTRAPOLATION_LEVELS < 2
    opt.max_steps = min(max_steps, EXTRAPOLATION_MESH_MAX_STEPS)
    runs, table, estimate = [], [], np.inf
    try:
        try:
            coarse, mesh = run(system, " (coarse mesh)")
        except ValueError as exc:
            if opt.max_steps == max_steps or "max_steps" not in str(exc):
                raise  # the user's own limit, or bad input
            raise ConvergenceError(f"the coarse mesh took more than {opt.max_steps} steps: {exc}") from exc
        target = rtol * max(system.length_scale,
                            float(np.linalg.norm(coarse.x - model.positions, axis=-1).max())) + atol
        opt.work, opt.max_steps = work, max_steps
        opt.error_rate = 0.0
        runs.append(coarse)
        for level in range(1, EXTRAPOLATION_LEVELS + 1):
            opt.steps = list(np.repeat(mesh / 2 ** level, 2 ** level))
            opt.newton_tol = min(mesh_newton_tol, EXTRAPOLATION_NEWTON_SUM * rtol / len(opt.steps))
            runs.append(run(model._system(state), f" (mesh / {2 ** level})")[0])
            table.append(_combined(runs[-2], runs[-1], 1.0 / 3.0))
            if len(table) >= 2:
                change = float(np.abs(table[-1].x - table[-2].x).max())
                correction = float(np.abs(table[-1].x - runs[-1].x).max())
                # settled: the h^4 term small beside the h^2 one, a rate of 16 per level
                estimate = change / (15.0 if change <= EXTRAPOLATION_SETTLED * correction else 3.0)
                if estimate <= target:
                    break
    except ConvergenceError as exc:
        # the runs differ by more than a discretisation error (a rotation the coarse mesh
        # does not follow) or a refined mesh failed: the error-controlled run alone
        logger.info("simulate: extrapolation over the controlled mesh failed (%s); the error-controlled run at "
                    "rtol = %.3g alone", exc, rtol)
        opt.steps, opt.work, opt.max_steps = [], work, max_steps
        opt.newton_tol = mesh_newton_tol if "newton_tol" in options else min(mesh_newton_tol, FALLBACK_NEWTON_TOL)
        _control_per_step(opt, rtol, atol, system.length_scale, t1 - t0)
        opt.rotation_error_length = 0.0
        if "rho_inf" not in options:
            opt.rho_inf = CONTROLLED_RHO_INF
        return run(model._system(state))[0]
    if estimate > target:
        logger.warning("simulate: extrapolated over %d halvings of the controlled mesh, the error estimate %.3g m "
                       "is still above rtol max(L, D) + atol = %.3g m", len(runs) - 1, estimate, target)
    res = table[-1]
    res.stats.clear()
    res.stats.update({k: sum(r.stats[k] for r in runs) for k in COUNTERS + ("wall_time",)})
    res.stats["error_estimate"] = estimate
    res.stats["largest_local_error"] = coarse.stats["largest_local_error"]
    for k in ("smallest_step", "largest_step"):
        res.stats[k] = coarse.stats[k] / 2 ** (len(runs) - 1)
    res.metadata["step"] = runs[-2].metadata["step"]
    res.metadata["extrapolated"] = {"steps": [runs[-2].metadata["step"], runs[-1].metadata["step"]], "order": 2,
                                    "mesh_rtol": float(rtol_mesh), "halvings": len(runs) - 1}
    return res


#: Largest rotation [rad] between the two runs' node frames that :func:`richardson` combines:
#: beyond it the runs differ by more than a discretisation error.
RICHARDSON_MAX_ANGLE = 0.1


def richardson(coarse: TransientResult, fine: TransientResult, *, order: int = 2) -> TransientResult:
    """Richardson extrapolation of two generalised-alpha runs at steps h and h/2:
    y = y_fine + (y_fine - y_coarse) / (2^order - 1) for every output array, the h^order
    term of their global error removed.

    The rotations are combined on SO(3): each run's R_h = R exp(c h^order~), so
    R = R_fine exp(log(R_coarse^T R_fine) / (2^order - 1)~). ``final_state`` is the fine
    run's (not extrapolated); ``stats`` are the two runs' together;
    ``metadata["extrapolated"]`` holds the two steps.

    Raises:
        ValueError: the runs do not match (integrator, output times, steps not h and h/2).
        ConvergenceError: a run halved a step (then its error has no expansion in h), or
            the two runs' frames differ by more than RICHARDSON_MAX_ANGLE.
    """
    from ..errors import ConvergenceError

    if any(r.x is None or r.bodies is not None for r in (coarse, fine)):
        raise ValueError("richardson: both runs must be element models' runs (bodies are not extrapolated)")
    steps = [r.metadata.get("step") for r in (coarse, fine)]
    if any(r.metadata.get("integrator") != "generalized_alpha" for r in (coarse, fine)) or None in steps:
        raise ValueError("richardson: both runs must be generalised-alpha runs")
    if not np.array_equal(coarse.t, fine.t) or coarse.x.shape != fine.x.shape:
        raise ValueError("richardson: the runs must have the same output times and nodes")
    if not abs(steps[1] - 0.5 * steps[0]) <= 1e-12 * steps[0]:
        raise ValueError(f"richardson: the steps must be h and h/2, got {steps[0]:.6g} and {steps[1]:.6g} s")
    for name, r in (("coarse", coarse), ("fine", fine)):
        # steps halved after a failed Newton iteration (the core's convergence_failures) or
        # redone for their error estimate (failed_steps): a mesh that is not h and h/2
        halved = r.stats.get("convergence_failures", 0) + r.stats.get("failed_steps", 0)
        if halved:
            raise ConvergenceError(f"richardson: the {name} run (step {r.metadata['step']:.6g} s) halved "
                                   f"{halved} steps, so its error has no expansion in h: "
                                   "choose a smaller step")
    factor = 1.0 / (2.0 ** _checks.positive_int("order", order) - 1.0)
    res = _combined(coarse, fine, factor)
    res.metadata["extrapolated"] = {"steps": steps, "order": order}
    return res


def _combined(coarse: TransientResult, fine: TransientResult, factor: float) -> TransientResult:
    """y_fine + (y_fine - y_coarse) factor for every output array, the rotations on SO(3)
    (:func:`richardson`); the fine run's metadata and final state, the stats summed."""
    from ..errors import ConvergenceError

    out = {}
    for name in TransientResult._ARRAYS:
        if name in ("t", "R"):
            continue
        a, b = getattr(coarse, name), getattr(fine, name)
        out[name] = b + (b - a) * factor
    # R_h = R exp(c h^order~) for each run: R = R_fine exp(log(R_coarse^T R_fine) factor~)
    phi = rotation_log(np.einsum("...ji,...jk->...ik", coarse.R, fine.R))
    angle = np.linalg.norm(phi, axis=-1)
    if angle.size and angle.max() > RICHARDSON_MAX_ANGLE:
        raise ConvergenceError(f"richardson: the runs' node frames differ by up to {angle.max():.3g} rad (more than "
                               f"{RICHARDSON_MAX_ANGLE} rad): not a discretisation error; choose a smaller step")
    turn = np.array([rotation_exp(p) for p in (phi * factor).reshape(-1, 3)]).reshape(fine.R.shape)
    out["R"] = fine.R @ turn
    stats = {k: coarse.stats[k] + fine.stats[k] for k in coarse.stats if k in fine.stats}
    meta = {**fine.metadata, "step": coarse.metadata["step"]}
    return TransientResult(t=fine.t.copy(), **out, stats=stats, metadata=meta, final_state=fine.final_state,
                           sensors=fine.sensors)
