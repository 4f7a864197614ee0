"""Periodic orbits (limit cycles) by shooting, their Floquet multipliers, and their
continuation in the mass flow.

A periodic orbit of the autonomous equations of motion (constant flow and loads) is a
state x0 = (z0, v0) and a period T with  phi_T(x0) = x0, where phi_T is the flow map of
the generalised-alpha integrator over T in N equal steps (N fixed, h = T / N). Shooting
solves the 2 n + 1 equations

    phi_T(x0) - x0 = 0,      xdot_ref . (x0 - x_ref) = 0   (phase condition)

for (x0, T) by Newton. The Jacobian's block d phi_T / d x0 (the monodromy matrix) comes
from the integrator's tangent-linear step (the exact iteration matrix of every step), not
from finite differences; d phi_T / dT is approximated by the vector field at the end,
which only slows Newton where it is inexact, never the answer. The monodromy is kept
across iterations while the defect falls fast (a chord method: the tangent-linear map
costs several plain ones); the first one comes from a flow map in fewer steps (cheap,
right for the slow modes that carry the amplitude), and far from the orbit the flow maps
run to a looser Newton tolerance. At the solution the monodromy is computed again for
the multipliers, when asked. Its eigenvalues are the Floquet multipliers: one is 1 (the
shift along the orbit), the orbit is stable when all others lie inside the unit circle.

Coordinates z are measured from a base state, v are the rates; per formulation (one
chart class each, :mod:`pipeflex.charts`): an element model's reduced displacements (its node
frames held fixed: no re-basing along the orbit, so rotations must stay well below pi
from the base) and their chart rates; a :class:`~pipeflex.multibody.MultibodySystem`'s
coordinates (per body the frame's translation, its rotation vector relative to the
base frame, the elastic coordinates) and its velocities (spatial angular velocities:
the flow map re-bases the frames every step, as the integrator does, and maps the end
back to the base's chart with its exact tangent); a :class:`~pipeflex.CoupledSystem`'s
both, stacked [element; bodies]. With joints the flow map's end satisfies them, so
each constrained direction has a zero multiplier. Continuation is pseudo-arclength in
(x0, T, mdot), starting at a Hopf point found by :func:`~pipeflex.critical_mass_flow`
(its critical mode and frequency give the first direction and period), with step
control and fold detection.
"""
from __future__ import annotations

from contextlib import nullcontext as _no_context
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from .. import _checks, _core
from ..errors import ConvergenceError
from ..results import Result
from ..state import State
from .._blas import pinned as blas_pinned
from .._progress import logger
from ._protocol import require_system
from .transient import explained_singular_mass

#: steps of the integrator per period unless given
STEPS_PER_PERIOD = 512
#: multipliers within this distance of the unit circle count as neutral, not unstable:
#: besides the shift along the orbit, a symmetry gives another multiplier 1 (e.g. the
#: turn of a planar orbit of an axisymmetric pipe about its axis), which round-off puts
#: on either side
NEUTRAL = 1e-6
#: a periodic orbit's amplitude (the largest half peak-to-peak excursion of a node
#: coordinate) must exceed this fraction of the model's size (the largest extent of its
#: node positions, at least 1 mm; orbit_guess's rule for an oscillation of round-off
#: size) and the shooting's tolerance ``tol``: a smaller one is the equilibrium itself
MIN_ORBIT_AMPLITUDE = 1e-9
#: the multiplier of the shift along a periodic orbit is 1; the one closest to 1 must lie
#: within this distance of it (the discrete flow map's: 1.3e-5 at 64 steps per period of
#: the cantilever's flutter cycle (Meijaard & Hakvoort's Fig. 3), falling like h^2 to 8e-8 at 800; an equilibrium's
#: multipliers are exp(lambda T), none of them 1)
TRIVIAL_MULTIPLIER_TOL = 1e-3
#: a period guess beyond this many times the model's slowest natural period (the
#: linearisation's smallest |lambda| at the start) is refused when the shooting fails
MAX_PERIOD_RATIO = 1e3
#: orbit_guess integrates t_max / step steps at most this many
MAX_GUESS_STEPS = 10**8
#: the shooting's first monodromy comes from a flow map in this many times fewer steps
#: (when that leaves at least MIN_COARSE_STEPS)
COARSE = 8
MIN_COARSE_STEPS = 64
#: the integrator's Newton tolerance of the flow maps far from the orbit (tightened with
#: the defect down to the user's newton_tol)
LOOSE_NEWTON_TOL = 1e-8


@dataclass(frozen=True)
class PeriodicOrbit(Result):
    """A periodic orbit of a model at a constant mass flow.

    Attributes:
        mass_flow: mdot [kg/s].
        period: T [s].
        base: the base state (the chart: coordinates z are measured from it): a
            :class:`~pipeflex.State` of an element model, a
            :class:`~pipeflex.multibody.MultibodyState` of bodies, a
            :class:`~pipeflex.coupled.CoupledStatic` of a coupled system.
        z0: (n,) coordinates at t = 0 [m, rad, ...] (n: an element model's n_dofs, the
            bodies' n_coordinates, their sum for a coupled system); v0: their rates
            [m/s, rad/s, ...].
        start: the state at t = 0 on the orbit (of base's kind).
        t: (N + 1,) times over one period [s].
        x: (N + 1, n_points, 3) positions over one period [m]: the element nodes, then
            each body's nodes (:meth:`~pipeflex.multibody.MultibodySystem.centre_line`).
        amplitude: (n_points, 3) half the peak-to-peak excursion of each point's coordinate [m].
        multipliers: (2 n,) Floquet multipliers by decreasing modulus [-] (empty
            if not asked for: ``periodic_orbit(..., multipliers=False)``).
        trivial: index in ``multipliers`` of the one closest to 1 (the shift along the
            orbit); -1 without multipliers.
        stable: all other multipliers inside the unit circle (or on it, to NEUTRAL);
            None without multipliers.
        residual: ``max |phi_T(x0) - x0|`` at the solution [m, m/s].
        iterations: Newton iterations of the shooting.
        steps: N, integrator steps per period.
    """

    mass_flow: float
    period: float
    base: State
    z0: np.ndarray
    v0: np.ndarray
    start: State
    t: np.ndarray
    x: np.ndarray
    amplitude: np.ndarray
    multipliers: np.ndarray
    trivial: int
    stable: Optional[bool]
    residual: float
    iterations: int
    steps: int
    stats: dict = field(default_factory=dict)

    def node_amplitude(self, node: int, component: int) -> float:
        """Half peak-to-peak of one coordinate (0, 1, 2 = x, y, z) of a node [m]."""
        return float(self.amplitude[node, component])

    def to_xarray(self):
        """The orbit as an ``xarray.Dataset``: ``x`` over (time, node, component) with the
        coordinate ``time`` (= ``t`` [s], one period), ``amplitude`` over (node,
        component), ``z0``, ``v0`` over ``dof``, the multipliers (``multipliers_real``,
        ``multipliers_imag``) over ``multiplier``, and the scalars (``mass_flow``,
        ``period``, ``stable`` (left out without multipliers), ``residual`` ...); every
        variable with ``units`` (where it has one) and ``long_name``. xarray loads here."""
        from ..results import field_info, node_coords, to_dataset

        coords = {"time": ("time", self.t, field_info("PeriodicOrbit", "t")[0]), **node_coords(self.x.shape[1])}
        names = ("mass_flow", "period", "z0", "v0", "x", "amplitude", "multipliers", "trivial", "stable", "residual",
                 "iterations", "steps")
        return to_dataset("PeriodicOrbit", {n: getattr(self, n) for n in names}, coords)


@dataclass(frozen=True)
class OrbitBranch(Result):
    """A branch of periodic orbits continued in the mass flow.

    Attributes:
        mass_flow: (k,) mdot [kg/s] of each orbit.
        period: (k,) T [s].
        amplitude: (k, n_points, 3) half peak-to-peak excursions [m] (points as
            :attr:`PeriodicOrbit.x`).
        stable: (k,) stability from the Floquet multipliers.
        max_multiplier: (k,) largest modulus of the non-trivial multipliers [-].
        folds: mass flows [kg/s] where the branch turns back (d mdot / ds changes sign).
        hopf: (mdot_c [kg/s], omega_c [rad/s]) of the Hopf point the branch starts at.
        starts: the state at t = 0 of each orbit (to solve an orbit again, e.g. at a
            nearby flow with :func:`periodic_orbit`).
    """

    mass_flow: np.ndarray
    period: np.ndarray
    amplitude: np.ndarray
    stable: np.ndarray
    max_multiplier: np.ndarray
    folds: np.ndarray
    hopf: tuple
    starts: tuple = ()
    stats: dict = field(default_factory=dict)

    def to_xarray(self):
        """The branch as an ``xarray.Dataset``: ``mass_flow``, ``period``, ``stable``,
        ``max_multiplier`` over ``orbit`` (the orbits in the order continued; the mass
        flow turns back at a fold), ``amplitude`` over (orbit, node, component),
        ``folds`` over ``fold``, and the Hopf point (``hopf_mass_flow`` [kg/s],
        ``hopf_frequency`` [rad/s]); every variable with ``units`` (where it has one)
        and ``long_name``. xarray loads here."""
        from ..results import node_coords, to_dataset

        names = ("mass_flow", "period", "amplitude", "stable", "max_multiplier", "folds")
        values = {n: getattr(self, n) for n in names}
        values["hopf_mass_flow"], values["hopf_frequency"] = (float(v) for v in self.hopf)
        coords = {"orbit": ("orbit", np.arange(len(self.mass_flow)), {"long_name": "orbit index along the branch"}),
                  **node_coords(np.shape(self.amplitude)[1])}
        return to_dataset("OrbitBranch", values, coords)


@dataclass(frozen=True)
class OrbitGuess(Result):
    """A start for :func:`periodic_orbit` from a coarse transient (:func:`orbit_guess`).

    Attributes:
        state: the transient's final state, near the cycle.
        period: T [s], the mean of the last two cycles (upward crossings of the watched
            coordinate's mid-range, interpolated linearly).
        amplitude: half the peak-to-peak range of the watched coordinate over the last
            cycle [m].
        time: motion integrated [s].
        settled: the last two cycles' amplitudes agreed to ``settle``; False when
            ``t_max`` came first (e.g. a cycle that attracts very slowly, or an oscillation
            that dies out below the flutter flow).
    """

    state: State
    period: float
    amplitude: float
    time: float
    settled: bool


def _chart(model, base):
    """The chart of ``model``'s formulation about the state ``base`` (None: the model's
    initial state): the model's ``_orbit_chart`` (one of the chart classes above)."""
    return require_system(model)._orbit_chart(base)


def _critical_direction(model, equilibrium, start):
    """The critical mode of ``start`` (a CriticalFlow) in the chart's coordinates: an
    element model's as it is; with constraints the mode of the linearisation at the Hopf
    equilibrium nearest ``start.eigenvalue``, in that linearisation's own independent
    coordinates (its null-space basis may pivot otherwise than the scan's, in which
    ``start.mode`` is), through its basis."""
    phi = np.asarray(start.mode, complex)
    if equilibrium.independent:
        return phi
    from .eigen import eigenvalues
    from .linearize import linearize

    lin = linearize(model, equilibrium.base, mass_flow=float(start.mass_flow))
    mode = eigenvalues(lin, vectors=True, n_modes=1, sigma=complex(start.eigenvalue)).vectors[:, 0]
    return np.asarray(lin.basis @ mode)


class _Shooter:
    """The flow map of a model at one mass flow in a chart (pipeflex.charts)."""

    def __init__(self, model, chart, steps: int, opt):
        self.model = model
        self.chart = chart
        self.base = chart.base
        self.steps = steps
        self.opt = opt
        self.n = chart.n
        self.calls = 0
        self.newton_iterations = 0

    def __call__(self, z0, v0, period, mass_flow, sensitivity, *, steps=None, newton_tol=None):
        """The flow map over ``period`` in ``steps`` steps (default the shooter's), its
        integrator's Newton to ``newton_tol`` (default the options'); with
        ``sensitivity`` also its monodromy matrix."""
        opt = self.opt
        if newton_tol is not None and newton_tol != opt.newton_tol:
            opt = _options(self.chart, newton_tol, opt.rho_inf)
        self.calls += 1
        system = self.chart.system(mass_flow)
        model = self.chart.element_model
        with explained_singular_mass(model) if model is not None else _no_context():
            out = _core.flow_map(system, float(mass_flow), np.asarray(z0, float), np.asarray(v0, float),
                                 float(period), self.steps if steps is None else int(steps), bool(sensitivity), opt)
        self.newton_iterations += int(out["newton_iterations"])
        return out

    def defect(self, out, z0, v0):
        return np.concatenate([out["z"][-1] - z0, out["v"] - v0])


def _options(chart, newton_tol, rho_inf):
    opt = _core.TransientOptions()
    opt.newton_tol = _checks.positive("newton_tol", newton_tol)
    rho = _checks.finite("rho_inf", rho_inf)
    if not 0.0 <= rho <= 1.0:
        raise ValueError(f"rho_inf must be in [0, 1], got {rho}")
    opt.rho_inf = rho
    opt.max_newton = 30
    opt.length_scale = chart.length_scale
    return opt


def _mass_flow(model) -> float:
    """The model's mass flow mdot [kg/s] (a coupled system's: its element model's)."""
    return float(model.mass_flow)


def _finish(shooter, z0, v0, period, mass_flow, out, iterations, residual) -> PeriodicOrbit:
    if "monodromy" in out:
        mu = np.linalg.eigvals(out["monodromy"])
        mu = mu[np.argsort(-np.abs(mu), kind="stable")]
        trivial = int(np.argmin(np.abs(mu - 1.0)))
        stable = bool(np.delete(np.abs(mu), trivial).max(initial=0.0) <= 1.0 + NEUTRAL)
    else:  # not asked for
        mu, trivial, stable = np.zeros(0, complex), -1, None
    z = out["z"]
    x = shooter.chart.positions(z)
    amplitude = 0.5 * (x.max(axis=0) - x.min(axis=0))
    orbit = PeriodicOrbit(mass_flow=float(mass_flow), period=float(period), base=shooter.base, z0=np.array(z0),
                          v0=np.array(v0), start=shooter.chart.state(np.array(z0), np.array(v0)),
                          t=np.linspace(0.0, period, len(z)), x=x, amplitude=amplitude,
                          multipliers=mu, trivial=trivial, stable=stable,
                          residual=float(residual), iterations=int(iterations), steps=shooter.steps,
                          stats={"flow_maps": shooter.calls, "newton_iterations": shooter.newton_iterations})
    return orbit


def _solve(shooter, y, mass_flow, *, tol, max_iterations, phase=None, arclength=None, coarse=False,
           monodromy=True, jacobian=None):
    """Newton on (z0, v0, T) [and mdot with an arclength row].

    ``phase`` = (y_ref, xdot_ref): the phase condition xdot_ref . (x0 - x_ref) = 0
    (default: the starting y and its vector field). ``arclength`` = (y_prev, mdot_prev,
    tangent, ds): the extra unknown mdot and the equation tangent . ((y, mdot) - (y_prev,
    mdot_prev)) = ds; its parameter column is differenced once, at the start (a chord:
    it sets Newton's rate, not the solution). ``coarse``: the first Jacobian from the
    flow map in COARSE times fewer steps. ``jacobian``: a monodromy to start from instead
    (e.g. the previous orbit's on a branch). ``monodromy``: the returned flow map carries
    the monodromy at the solution (for the multipliers)."""
    n = shooter.n
    y = np.array(y, float)
    mdot = float(mass_flow)
    # Inexact flow maps: far from the orbit the integrator's Newton need not be tight; its
    # tolerance follows the defect (the flow map's error grew about 1e5 times its per-step
    # tolerance over 877 steps of the Fig. 3 cantilever), down to the user's at the end.
    floor = shooter.opt.newton_tol

    def newton_tol(residual):
        return float(min(max(1e-7 * residual, floor), max(floor, LOOSE_NEWTON_TOL)))

    dF_dm = None
    residual = previous = np.inf
    # Chord Newton: the monodromy (the expensive tangent-linear map) is refreshed only
    # when the defect stops falling fast; the cheap flow maps in between give the defect.
    # A coarse start: the monodromy of the same period in COARSE times fewer steps costs
    # a fraction of the exact one and points the first steps well (the slow modes, which
    # set the amplitude, are resolved alike); the stiff modes it gets wrong stall the
    # defect, and then the exact monodromy takes over.
    coarse_steps = shooter.steps // COARSE if coarse and shooter.steps >= COARSE * MIN_COARSE_STEPS else None
    exact = coarse_steps is None
    out = shooter(y[:n], y[n:2 * n], y[-1], mdot, exact and jacobian is None, newton_tol=floor)
    if jacobian is not None:
        Phi, fresh = jacobian, False
    elif exact:
        Phi, fresh = out["monodromy"], True
    else:
        # an approximate Jacobian anyway: its integrator's Newton need not be tight
        Phi = shooter(y[:n], y[n:2 * n], y[-1], mdot, True, steps=coarse_steps,
                      newton_tol=max(floor, LOOSE_NEWTON_TOL))["monodromy"]
        fresh = False
    if phase is None:
        phase = (y.copy(), np.concatenate([y[n:2 * n], out["a0"]]))
    y_ref, xdot_ref = phase
    for it in range(1, max_iterations + 1):
        z0, v0, T = y[:n], y[n:2 * n], y[-1]
        F = shooter.defect(out, z0, v0)
        residual = float(np.abs(F).max())
        if not np.isfinite(residual):
            raise ConvergenceError(f"periodic orbit: the shooting residual is not finite at mdot = {mdot:.6g} kg/s "
                                   f"(iteration {it})", iteration=it, mass_flow=mdot)
        g = float(xdot_ref @ (y[:2 * n] - y_ref[:2 * n]))
        logger.debug("periodic orbit: shooting iteration %d at mdot = %.8g kg/s: T = %.10g s, defect %.3g, "
                     "phase %.3g", it, mdot, T, residual, g)
        done = residual <= tol and abs(g) <= tol * max(1.0, np.abs(xdot_ref).max())
        if arclength is not None:
            y_prev, m_prev, tangent, ds = arclength
            s = float(tangent @ np.concatenate([y - y_prev, [mdot - m_prev]])) - ds
            done = done and abs(s) <= tol * max(1.0, abs(ds))
        if done:
            if monodromy and not fresh:  # the multipliers need the monodromy at the solution
                out = shooter(z0, v0, T, mdot, True)
            return y, mdot, out, it, residual
        ntol = newton_tol(residual)
        if not fresh and residual > 0.25 * previous:
            out = shooter(z0, v0, T, mdot, True, newton_tol=ntol)
            Phi, fresh, exact = out["monodromy"], True, True
        previous = residual
        J = np.zeros((2 * n + 1, 2 * n + 1))
        J[:2 * n, :2 * n] = Phi - np.eye(2 * n)
        J[:2 * n, -1] = np.concatenate([out["v"], out["a"]])
        J[-1, :2 * n] = xdot_ref
        rows = [F, [g]]
        if arclength is not None:
            if dF_dm is None:
                dF_dm = _flow_derivative(shooter, z0, v0, T, mdot)
            J = np.block([[J, np.concatenate([dF_dm, [0.0]])[:, None]], [tangent[None, :]]])
            rows.append([s])
        step = np.linalg.solve(J, -np.concatenate(rows))
        # Backtracking: lightly damped modes put multipliers next to 1, so a rough start
        # can ask for large corrections along them; halve the step while the flow map
        # fails or the defect grows more than tenfold. A step of the coarse monodromy
        # must lower the defect, else the exact monodromy is taken at once.
        growth = 10.0 if exact else 1.0
        for _ in range(8 if exact else 1):
            y_try = y + step[:2 * n + 1]
            m_try = mdot + step[-1] if arclength is not None else mdot
            if y_try[-1] > 0.0:
                try:
                    out_try = shooter(y_try[:n], y_try[n:2 * n], y_try[-1], m_try, False, newton_tol=ntol)
                    if np.abs(shooter.defect(out_try, y_try[:n], y_try[n:2 * n])).max() <= growth * residual:
                        break
                except ConvergenceError:
                    pass
            step = 0.5 * step
        else:
            if not exact:
                out = shooter(z0, v0, T, mdot, True, newton_tol=ntol)
                Phi, fresh, exact = out["monodromy"], True, True
                previous = np.inf
                continue
            raise ConvergenceError(f"periodic orbit: no Newton step of the shooting reduces the periodicity defect "
                                   f"{residual:.3g} at mdot = {mdot:.6g} kg/s (iteration {it}); start closer to "
                                   f"the orbit", iteration=it, residual=residual, mass_flow=mdot)
        y, mdot, out, fresh = y_try, m_try, out_try, False
    raise ConvergenceError(f"periodic orbit: shooting did not converge in {max_iterations} iterations at "
                           f"mdot = {mdot:.6g} kg/s (periodicity defect {residual:.3g})",
                           iteration=max_iterations, residual=residual, mass_flow=mdot)


def _flow_derivative(shooter, z0, v0, T, mdot, rel=1e-6):
    """d(phi_T(x0) - x0)/d mdot by a central difference of two flow maps (a parameter
    column of the Jacobian; it affects Newton's rate, not the solution)."""
    d = rel * max(abs(mdot), 1.0)
    hi = shooter(z0, v0, T, mdot + d, False)
    lo = shooter(z0, v0, T, mdot - d, False)
    return (shooter.defect(hi, z0, v0) - shooter.defect(lo, z0, v0)) / (2 * d)


@blas_pinned
def periodic_orbit(model, *, period: float, state=None, base=None, mass_flow: Optional[float] = None,
                   steps: int = STEPS_PER_PERIOD, tol: float = 1e-8, max_iterations: int = 20,
                   newton_tol: float = 1e-12, rho_inf: float = 0.9, multipliers: bool = True) -> PeriodicOrbit:
    """The periodic orbit through (near) ``state`` with period near ``period``.

    Args:
        model: an autonomous model (constant flow and loads, no hub drive): a
            :class:`~pipeflex.Model`, a :class:`~pipeflex.multibody.MultibodySystem` or a
            :class:`~pipeflex.CoupledSystem`.
        period: T [s] first guess of the period (e.g. from a transient, or 2 pi / omega
            at a Hopf point).
        state: a state on or near the orbit (e.g. the end of a transient that has settled
            on the cycle: :attr:`OrbitGuess.state`); default the model's reference state
            (assembly configuration) at rest. Of the model's kind: a
            :class:`~pipeflex.State`, a :class:`~pipeflex.multibody.MultibodyState`, a
            :class:`~pipeflex.coupled.CoupledStatic` (its element and body states).
        base: the chart (an element model's positions and node frames, the bodies'
            frames, that the coordinates are measured from); default ``state`` itself.
        mass_flow: mdot [kg/s] (default the model's).
        steps: N, generalised-alpha steps per period (h = T / N) [-].
        tol: Newton tolerance on the periodicity defect ``max |phi_T(x0) - x0|`` [m, m/s].
        max_iterations: Newton iterations of the shooting.
        newton_tol, rho_inf: the integrator's options (as in :func:`pipeflex.simulate`);
            far from the orbit the flow maps use a looser Newton tolerance (at most
            LOOSE_NEWTON_TOL, tightened with the defect down to ``newton_tol``).
        multipliers: compute the Floquet multipliers (the monodromy matrix at the
            solution: about as much work as 7 flow maps at 8 elements); False leaves
            ``multipliers`` empty and ``stable`` None, and starts Newton from a coarse
            monodromy (a flow map in COARSE times fewer steps).

    Returns:
        :class:`PeriodicOrbit` with the orbit over one period, its amplitude and its
        Floquet multipliers.

    A converged shooting is returned only if it is a periodic orbit: its amplitude above
    MIN_ORBIT_AMPLITUDE of the model's size (and ``tol``) and, with multipliers, one
    within TRIVIAL_MULTIPLIER_TOL of 1; else it is the equilibrium the start decays to.

    Raises:
        ConvergenceError: the shooting did not converge (``iteration``, ``residual``), or
            it converged on an equilibrium (the start decays to it, e.g. below the flutter
            flow; the message gives the flow and the amplitude).
        ValueError: bad options; or the shooting failed with ``period`` above
            MAX_PERIOD_RATIO times the model's slowest natural period.
    """
    start_chart = _chart(model, state)
    chart = start_chart if base is None else _chart(model, base)
    T = _checks.positive("period", period)
    steps = _checks.flow_map_steps("steps", steps, chart.n)
    tol = _checks.positive("tol", tol)
    max_iterations = _checks.positive_int("max_iterations", max_iterations)
    mdot = _mass_flow(model) if mass_flow is None else _checks.finite("mass_flow", mass_flow)
    start = start_chart.base
    shooter = _Shooter(model, chart, steps, _options(chart, newton_tol, rho_inf))
    # the start in the chart's coordinates
    z0, v0 = chart.coordinates(start)
    y = np.concatenate([z0, v0, [T]])
    # The coarse start pays where no exact monodromy is needed: with multipliers one is
    # computed anyway, and an exact first one then serves the whole chord (measured:
    # 6 flow maps instead of 10 from the 2.5 s guess of bench_periodic.py).
    try:
        y, mdot, out, it, res = _solve(shooter, y, mdot, tol=tol, max_iterations=max_iterations,
                                       coarse=not multipliers, monodromy=bool(multipliers))
    except ConvergenceError as e:
        _refuse_period(model, T, start, mdot, e)
        raise
    logger.info("periodic_orbit: converged in %d iterations at mdot = %.8g kg/s: T = %.10g s, defect %.3g "
                "(%d flow maps)", it, mdot, y[-1], res, shooter.calls)
    n = chart.n
    return _nontrivial(_finish(shooter, y[:n], y[n:2 * n], y[-1], mdot, out, it, res), shooter.opt.length_scale, tol)


def _nontrivial(orbit, size, tol):
    """The orbit, or ConvergenceError when it is an equilibrium: an amplitude below
    MIN_ORBIT_AMPLITUDE * size (and tol), or (with multipliers) none within
    TRIVIAL_MULTIPLIER_TOL of 1. Shooting converges on an equilibrium too (x0 a fixed
    point of every flow map), e.g. from a start that decays below the flutter flow."""
    amp = float(np.max(orbit.amplitude, initial=0.0))
    floor = max(MIN_ORBIT_AMPLITUDE * size, tol)
    mu = orbit.multipliers[orbit.trivial] if orbit.trivial >= 0 else None
    if amp > floor and (mu is None or abs(mu - 1.0) <= TRIVIAL_MULTIPLIER_TOL):
        return orbit
    why = (f"its amplitude {amp:.3g} m is below {floor:.3g} m (MIN_ORBIT_AMPLITUDE = {MIN_ORBIT_AMPLITUDE:g} of the "
           f"model's size {size:.3g} m, or tol)" if amp <= floor else f"its amplitude is {amp:.3g} m")
    if mu is not None:
        why += (f"; no Floquet multiplier is 1 (the closest, {mu.real:.6g} {mu.imag:+.3g}j, is {abs(mu - 1.0):.3g} "
                f"away; TRIVIAL_MULTIPLIER_TOL = {TRIVIAL_MULTIPLIER_TOL:g})")
    raise ConvergenceError(
        f"periodic_orbit: the start decays to an equilibrium at mdot = {orbit.mass_flow:.6g} kg/s, not to a periodic "
        f"orbit (or is one): the shooting converged (defect {orbit.residual:.3g}) but {why}. Below the flutter flow "
        f"(critical_mass_flow) there is no cycle to find; above it, start from a state on the cycle "
        f"(orbit_guess)", iteration=orbit.iterations, residual=orbit.residual, mass_flow=orbit.mass_flow)


def _refuse_period(model, period, start, mdot, err):
    """After a failed shooting: ValueError if ``period`` exceeds MAX_PERIOD_RATIO times the
    model's slowest natural period (then the integrator's failure, e.g. a singular
    iteration matrix at a huge step, is about the period, not the model); else nothing."""
    from .eigen import SPARSE_MIN_DOFS, eigenvalues
    from .linearize import linearize

    try:
        lin = linearize(model, start, mass_flow=mdot)
        n = lin.M.shape[0]
        lam = eigenvalues(lin).values if n < SPARSE_MIN_DOFS else eigenvalues(lin, n_modes=6).values
        lam = np.abs(lam[np.abs(lam) > 0.0])
        slowest = 2.0 * np.pi / float(lam.min())
    except (ValueError, RuntimeError, np.linalg.LinAlgError):  # (ConvergenceError too) no verdict:
        return  # the shooting's own error stands
    if period > MAX_PERIOD_RATIO * slowest:
        raise ValueError(f"period = {period:.6g} s is {period / slowest:.3g} times the model's slowest natural period "
                         f"{slowest:.6g} s (2 pi / the smallest |lambda| of its linearisation at mdot = {mdot:.6g} "
                         f"kg/s); at most MAX_PERIOD_RATIO = {MAX_PERIOD_RATIO:g} times it: give the period of the "
                         "cycle (orbit_guess's, or 2 pi / critical_mass_flow's frequency near the Hopf point)") from err


def orbit_guess(model, *, node: int, step: float, component: int = 1, state=None,
                mass_flow: Optional[float] = None, settle: float = 1e-3, chunk: float = 0.5,
                t_max: float = 200.0) -> OrbitGuess:
    """A state near the limit cycle and its period, for :func:`periodic_orbit`: a
    generalised-alpha transient with a coarse ``step``, integrated ``chunk`` by ``chunk``
    until two successive cycles of one coordinate have the same amplitude to ``settle``.

    The step may be several times the shooting's (e.g. 4 to 16 times): the coarse cycle
    differs from the fine one by O(h^2), which the shooting's Newton removes in a few
    iterations, while the transient's cost falls with the step. This is where shooting
    pays against the plain transient: the transient must contract the cycle's error to
    the accuracy wanted at the fine step, the guess only to the coarse step's error
    (docs/performance.md, "Periodic orbits from a coarse transient").

    Args:
        model: an autonomous model (constant flow and loads): a
            :class:`~pipeflex.Model`, a :class:`~pipeflex.multibody.MultibodySystem` or
            a :class:`~pipeflex.CoupledSystem`.
        node: the node whose coordinate is watched [-]; with bodies a point of
            :attr:`PeriodicOrbit.x` (the element nodes, then each body's nodes).
        step: h [s] of the transient (bodies and coupled systems: the flow map's
            generalised-alpha, re-based every ``chunk``; element models: :func:`simulate`'s).
        component: 0, 1, 2 = x, y, z of the node's position.
        state: the start (default the reference configuration at rest; a coupled
            system's: a CoupledStatic, e.g. ``pipeflex.static_equilibrium(system)``).
        mass_flow: mdot [kg/s] (default the model's).
        settle: relative change of the amplitude between the last two cycles at which
            the transient stops [-].
        chunk: motion integrated between checks [s].
        t_max: most motion integrated [s]; at most MAX_GUESS_STEPS steps (t_max / step).

    Raises:
        ValueError: bad options, e.g. t_max / step above MAX_GUESS_STEPS.
        ConvergenceError: fewer than two cycles by ``t_max`` (no oscillation, or one that
            died out).
    """
    from ..signals import zero_crossings
    from .transient import simulate

    chart = _chart(model, state)
    element = chart.guess_by_simulate
    n_points = chart.positions(np.zeros(chart.n)).shape[1]
    node = _checks.non_negative_int("node", node)
    if node >= n_points:
        raise ValueError(f"node must be in [0, {n_points}), got {node}")
    if component not in (0, 1, 2):
        raise ValueError(f"component must be 0, 1 or 2 (x, y, z), got {component!r}")
    h = _checks.positive("step", step)
    settle = _checks.positive("settle", settle)
    chunk = max(_checks.positive("chunk", chunk), 4.0 * h)
    t_max = _checks.positive("t_max", t_max)
    if t_max / h > MAX_GUESS_STEPS:
        raise ValueError(f"t_max = {t_max:g} s is {t_max / h:.3g} steps of step = {h:g} s; at most MAX_GUESS_STEPS = "
                         f"{MAX_GUESS_STEPS:.0e}: lower t_max (a cycle that attracts settles within some hundred "
                         "periods) or raise step")
    size = chart.length_scale
    t, st = 0.0, state
    ts, ys = [np.zeros(0)], [np.zeros(0)]
    # each chunk ends at t + chunk >= t + 4 step (or t_max): a bounded count
    for _ in range(int(np.ceil(t_max / chunk)) + 2):
        t_end = min(t + chunk, t_max)
        k = max(2, int(round((t_end - t) / h)) + 1)
        if element:
            run = simulate(model, t_end, t_start=t, state=st, step=h, n_outputs=k, mass_flow=mass_flow,
                           progress=False, integrator="generalized_alpha")
            ts.append(run.t[1:])
            ys.append(run.x[1:, node, component])
            st = run.final_state
        else:  # the flow map from the chunk's start, in its chart
            mdot = _mass_flow(model) if mass_flow is None else _checks.finite("mass_flow", mass_flow)
            out = _core.flow_map(chart.system(mdot), mdot, np.zeros(chart.n), chart.coordinates(chart.base)[1],
                                 t_end - t, k - 1, False, _options(chart, 1e-10, 0.9))
            ts.append(np.linspace(t, t_end, k)[1:])
            ys.append(chart.positions(out["z"][1:])[:, node, component])
            chart = _chart(model, chart.state(out["z"][-1], out["v"]))
            st = chart.base
        t = t_end
        time_, y = np.concatenate(ts), np.concatenate(ys)
        recent = y[time_ >= t - chunk]
        mid = 0.5 * (recent.max() + recent.min())
        up = np.flatnonzero((y[:-1] < mid) & (y[1:] >= mid))
        # an oscillation of round-off size about a rest state is not a cycle
        if len(up) >= 3 and recent.max() - recent.min() > 1e-9 * size:
            amps = [0.5 * (y[a:b + 1].max() - y[a:b + 1].min()) for a, b in zip(up[-3:-1], up[-2:])]
            settled = abs(amps[1] - amps[0]) <= settle * max(amps[1], 1e-300)
            if settled or t >= t_max:
                period = float(np.diff(zero_crossings(time_, y - mid)[-3:]).mean())
                return OrbitGuess(state=st, period=period, amplitude=float(amps[1]), time=float(t),
                                  settled=bool(settled))
        if t >= t_max:
            break
    raise ConvergenceError(f"orbit_guess: fewer than two cycles of node {node}'s coordinate {component} "
                           f"by t_max = {t_max:g} s (no oscillation to settle on)", mass_flow=mass_flow)


@blas_pinned
def continue_orbits(model, *, start, mass_flow_end: float, amplitude: float = 1e-3, ds: Optional[float] = None,
                    max_step: Optional[float] = None, max_points: int = 40, steps: int = STEPS_PER_PERIOD, tol: float = 1e-8,
                    max_iterations: int = 12, newton_tol: float = 1e-12, rho_inf: float = 0.9,
                    state=None) -> OrbitBranch:
    """Continue the periodic orbits born at a Hopf point in the mass flow.

    Args:
        model: an autonomous model (constant loads, no hub drive): a
            :class:`~pipeflex.Model`, a :class:`~pipeflex.multibody.MultibodySystem` or a
            :class:`~pipeflex.CoupledSystem`.
        start: the :class:`~pipeflex.CriticalFlow` of kind "flutter" at which the branch
            starts (its mass flow, frequency and critical mode; with joints the mode's
            independent coordinates are mapped to the system's through the null-space
            basis of the linearisation at the Hopf equilibrium).
        mass_flow_end: mdot [kg/s] at which to stop (either side of the Hopf point: a
            subcritical branch first turns back).
        amplitude: size of the first orbit's excursion along the critical mode [m].
        ds: first pseudo-arclength step (default from ``amplitude``); halved on a
            failure or a hard step, doubled after easy ones (Newton in <= 6 iterations)
            up to ``max_step`` (default 64 ds). The arclength is the Euclidean norm in
            (z0 [m, rad], v0 [m/s, rad/s], T [s], mdot [kg/s]).
        max_points: orbits on the branch at most.
        steps, tol, max_iterations, newton_tol, rho_inf: as :func:`periodic_orbit`.
        state: starting guess for the static solve at the Hopf point.

    Returns:
        :class:`OrbitBranch`; its ``stats`` hold the orbits' counts and the flow maps used.
    """
    from .static import static_equilibrium

    if getattr(start, "kind", None) != "flutter":
        raise ValueError("start must be a CriticalFlow of kind 'flutter' (a Hopf point); got "
                         f"{getattr(start, 'kind', type(start).__name__)!r}")
    m_end = _checks.finite("mass_flow_end", mass_flow_end)
    amp = _checks.positive("amplitude", amplitude)
    max_points = _checks.positive_int("max_points", max_points)
    mc, wc = float(start.mass_flow), float(start.frequency)
    static = static_equilibrium(model, mass_flow=mc, state=state)
    # a coupled system's chart is its whole static result (element and body states)
    chart = _chart(model, model._equilibrium_state(static))
    steps = _checks.flow_map_steps("steps", steps, chart.n)
    shooter = _Shooter(model, chart, steps, _options(chart, newton_tol, rho_inf))
    n = chart.n
    # first orbit: the equilibrium displaced along the real part of the critical mode,
    # velocity from its imaginary part (x(t) = Re(phi e^{i w t}) at t = 0)
    phi = _critical_direction(model, chart, start)
    phi = phi / np.abs(phi).max()
    z_dir, v_dir = phi.real, -wc * phi.imag
    scale = amp / max(np.abs(z_dir).max(), 1e-300)
    T0 = 2 * np.pi / wc
    y_hopf = np.concatenate([np.zeros(n), np.zeros(n), [T0]])
    tangent = np.concatenate([scale * z_dir, scale * v_dir, [0.0], [0.0]])
    norm = np.linalg.norm(tangent)
    tangent /= norm
    ds = norm if ds is None else _checks.positive("ds", ds)
    max_step = 64.0 * ds if max_step is None else _checks.positive("max_step", max_step)
    direction = 1.0 if m_end >= mc else -1.0
    y_prev, m_prev = y_hopf, mc
    # phase reference of the first orbit: the linear mode's point and velocity at t = 0
    xdot_prev = scale * np.concatenate([v_dir, -wc ** 2 * z_dir])
    flows, periods, amps, stable, mmax, folds, starts = [], [], [], [], [], [], []
    h = ds
    first = True
    # the monodromy at the last orbit: the next orbit's first Jacobian (a chord across
    # the step; refreshed where the defect stops falling fast)
    Phi_prev = None
    while len(flows) < max_points:
        y_pred = y_prev + h * tangent[:-1]
        m_pred = m_prev + h * tangent[-1]
        try:
            y, mdot, out, it, res = _solve(shooter, y_pred, m_pred, tol=tol, max_iterations=max_iterations,
                                           phase=(y_pred, xdot_prev), arclength=(y_prev, m_prev, tangent, h),
                                           jacobian=Phi_prev)
        except (ConvergenceError, np.linalg.LinAlgError) as exc:
            h *= 0.5
            logger.info("continue_orbits: no orbit at step %.3g (%s); halving the step", 2 * h, exc)
            if h < 1e-6 * ds or h == 0.0:  # (1e-6 ds underflows for a subnormal ds)
                break
            continue
        orbit = _finish(shooter, y[:n], y[n:2 * n], y[-1], mdot, out, it, res)
        logger.info("continue_orbits: orbit %d at mdot = %.8g kg/s: T = %.8g s, amplitude %.4g, %s (%d iterations)",
                    len(flows) + 1, mdot, y[-1], orbit.amplitude, "stable" if orbit.stable else "unstable", it)
        Phi_prev = out["monodromy"]
        new_tangent = np.concatenate([y - y_prev, [mdot - m_prev]])
        new_tangent /= np.linalg.norm(new_tangent)
        if not first and tangent[-1] != 0.0 and np.sign(new_tangent[-1]) != np.sign(tangent[-1]):
            folds.append(mdot)
        first = False
        tangent = new_tangent
        y_prev, m_prev = y, mdot
        xdot_prev = np.concatenate([y[n:2 * n], out["a0"]])
        flows.append(mdot)
        periods.append(y[-1])
        amps.append(orbit.amplitude)
        starts.append(orbit.start)
        stable.append(orbit.stable)
        others = np.delete(np.abs(orbit.multipliers), orbit.trivial)
        mmax.append(float(others.max(initial=0.0)))
        if (mdot - m_end) * direction >= 0.0:
            break
        if it <= 6:  # chord iterations are cheap: a few are an easy step
            h = min(2.0 * h, max_step)
        elif it >= 10:
            h *= 0.5
    if not flows:
        raise ConvergenceError(f"orbit continuation: no orbit found next to the Hopf point at {mc:.6g} kg/s",
                               mass_flow=mc)
    return OrbitBranch(mass_flow=np.array(flows), period=np.array(periods), amplitude=np.array(amps),
                       stable=np.array(stable), max_multiplier=np.array(mmax), folds=np.array(folds),
                       hopf=(mc, wc), starts=tuple(starts), stats={"flow_maps": shooter.calls, "newton_iterations": shooter.newton_iterations})
