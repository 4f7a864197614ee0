"""Periodic orbits (limit cycles) by shooting, their Floquet multipliers, their
continuation in the mass flow or another parameter, the bifurcations along a branch and
branch switching (docs/orbits.md).

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
(x0, T, p), p the mass flow (starting at a Hopf point found by
:func:`~pipeflex.critical_mass_flow`: its critical mode and frequency give the first
direction and period, or at an orbit) or another parameter (from an orbit: the model
rebuilt at each value), with step control; every orbit keeps its multipliers, and the
bifurcations between consecutive orbits (fold, period doubling, Neimark-Sacker, branch
point) are classified and located; :func:`switch_branch` starts the other branch at a
branch point.
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
from ._roots import Illinois
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
        trivial: index in ``multipliers`` of the shift along the orbit: the one whose
            eigenvector is the flow direction among those within TRIVIAL_MULTIPLIER_TOL of
            1 (else the closest to 1); -1 without multipliers.
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
    """A branch of periodic orbits continued in the mass flow or another parameter.

    Attributes:
        mass_flow: (k,) mdot [kg/s] of each orbit (all the same in another parameter).
        period: (k,) T [s].
        amplitude: (k, n_points, 3) half peak-to-peak excursions [m] (points as
            :attr:`PeriodicOrbit.x`).
        stable: (k,) stability from the Floquet multipliers.
        max_multiplier: (k,) largest modulus of the non-trivial multipliers [-].
        folds: the parameter's values [its unit] at the orbits where the branch turns
            back (d p / ds changes sign; mass flows [kg/s] in the mass flow).
        hopf: (mdot_c [kg/s], omega_c [rad/s]) of the Hopf point the branch starts at
            (nan, nan from an orbit or a branch point).
        starts: the state at t = 0 of each orbit (to solve an orbit again, e.g. at a
            nearby flow with :func:`periodic_orbit`).
        parameter_name: the continued parameter ("mass_flow", a name of
            ``PARAMETERS``, or the callable's ``__name__``).
        parameter: (k,) its value at each orbit [its unit] (the mass flow's: equal to
            ``mass_flow``).
        multipliers: (k, 2 n) all Floquet multipliers of each orbit (the monodromy's
            eigenvalues) by decreasing modulus [-].
        trivial: (k,) index in ``multipliers`` of each orbit's trivial one (whose
            eigenvector is the flow direction).
        bifurcations: the :class:`Bifurcation` s between consecutive orbits, in order.
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
    parameter_name: str = "mass_flow"
    parameter: Optional[np.ndarray] = None
    multipliers: Optional[np.ndarray] = None
    trivial: Optional[np.ndarray] = None
    bifurcations: tuple = ()

    def to_xarray(self):
        """The branch as an ``xarray.Dataset``: ``mass_flow``, ``period``, ``stable``,
        ``max_multiplier``, ``parameter`` (attribute ``parameter_name``), ``trivial``
        over ``orbit`` (the orbits in the order continued; the parameter turns back at a
        fold), ``amplitude`` over (orbit, node, component), the multipliers
        (``multipliers_real``, ``multipliers_imag``) over (orbit, multiplier), ``folds``
        over ``fold``, and the Hopf point (``hopf_mass_flow`` [kg/s], ``hopf_frequency``
        [rad/s]); every variable with ``units`` (where it has one) and ``long_name``; the
        bifurcations are not in it. xarray loads here."""
        from ..results import node_coords, to_dataset

        names = ("mass_flow", "period", "amplitude", "stable", "max_multiplier", "folds", "parameter",
                 "multipliers", "trivial")
        values = {n: getattr(self, n) for n in names}
        values["hopf_mass_flow"], values["hopf_frequency"] = (float(v) for v in self.hopf)
        coords = {"orbit": ("orbit", np.arange(len(self.mass_flow)), {"long_name": "orbit index along the branch"}),
                  **node_coords(np.shape(self.amplitude)[1])}
        return to_dataset("OrbitBranch", values, coords, {"parameter_name": self.parameter_name})


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

    def __init__(self, model, chart, steps: int, opt, *, parameter=None):
        self.model = model
        self.chart = chart
        self.base = chart.base
        self.steps = steps
        self.opt = opt
        self.n = chart.n
        self.calls = 0
        self.newton_iterations = 0
        # parameter: a continuation parameter other than the mass flow (a _Parameter);
        # then the fourth argument of a call is its scaled value, not the mass flow
        self.parameter = parameter

    def __call__(self, z0, v0, period, mass_flow, sensitivity, *, steps=None, newton_tol=None):
        """The flow map over ``period`` in ``steps`` steps (default the shooter's), its
        integrator's Newton to ``newton_tol`` (default the options'); with
        ``sensitivity`` also its monodromy matrix. With a ``parameter`` the fourth
        argument is that parameter's scaled value (the mass flow is the parameter's)."""
        opt = self.opt
        if newton_tol is not None and newton_tol != opt.newton_tol:
            opt = _options(self.chart, newton_tol, opt.rho_inf)
        self.calls += 1
        if self.parameter is None:
            system = self.chart.system(mass_flow)
        else:
            system, mass_flow = self.parameter.system(mass_flow)
        model = self.chart.element_model
        with explained_singular_mass(model) if model is not None else _no_context():
            out = _core.flow_map(system, float(mass_flow), np.asarray(z0, float), np.asarray(v0, float),
                                 float(period), self.steps if steps is None else int(steps), bool(sensitivity), opt)
        self.newton_iterations += int(out["newton_iterations"])
        return out

    def defect(self, out, z0, v0):
        return np.concatenate([out["z"][-1] - z0, out["v"] - v0])

    def where(self, p) -> tuple:
        """(text naming the parameter and its value at the fourth call argument ``p``, the
        mass flow there [kg/s]) for messages: "mdot = ... kg/s" in the mass flow, else
        the continued parameter's physical value (``p`` is scaled then)."""
        if self.parameter is None or self.parameter.rebuild is None:
            mdot = float(p) if self.parameter is None else self.parameter.physical(p)
            return f"mdot = {mdot:.6g} kg/s", mdot
        par = self.parameter
        return f"{par.name} = {par.physical(p):.6g} (mdot = {par.mass_flow:.6g} kg/s)", par.mass_flow


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
        # the trivial multiplier: the flow direction's (not merely the closest to 1)
        mu, trivial, _ = _floquet(out["monodromy"], np.concatenate([np.asarray(v0, float), out["a0"]]))
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
            at, m_at = shooter.where(mdot)
            raise ConvergenceError(f"periodic orbit: the shooting residual is not finite at {at} "
                                   f"(iteration {it})", iteration=it, mass_flow=m_at)
        g = float(xdot_ref @ (y[:2 * n] - y_ref[:2 * n]))
        logger.debug("periodic orbit: shooting iteration %d at %s: T = %.10g s, defect %.3g, "
                     "phase %.3g", it, shooter.where(mdot)[0], T, residual, g)
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
            at, m_at = shooter.where(mdot)
            raise ConvergenceError(f"periodic orbit: no Newton step of the shooting reduces the periodicity defect "
                                   f"{residual:.3g} at {at} (iteration {it}); start closer to "
                                   f"the orbit", iteration=it, residual=residual, mass_flow=m_at)
        y, mdot, out, fresh = y_try, m_try, out_try, False
    at, m_at = shooter.where(mdot)
    raise ConvergenceError(f"periodic orbit: shooting did not converge in {max_iterations} iterations at "
                           f"{at} (periodicity defect {residual:.3g})",
                           iteration=max_iterations, residual=residual, mass_flow=m_at)


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


#: the section fields a continuation ``parameter`` may name (set in every section)
SECTION_PARAMETERS = ("EI", "EIz", "EA", "GJ", "GAy", "GAz", "pipe_mass", "fluid_mass", "kv", "eta_bending",
                      "eta_torsion", "eta_axial", "c_ext", "k_found")
#: the gravity's parameter names: its magnitude along its direction, or one component
GRAVITY_PARAMETERS = ("gravity", "gravity_x", "gravity_y", "gravity_z")
#: every parameter name continue_orbits knows for an element model (besides a callable
#: rebuild(value) -> model)
PARAMETERS = ("mass_flow",) + GRAVITY_PARAMETERS + ("point_mass",) + SECTION_PARAMETERS
#: the names it knows for floating-frame bodies and coupled systems (their bodies' sections
#: are reduced when a body is made: a callable rebuild(value) -> system changes them)
BODY_PARAMETERS = ("mass_flow",) + GRAVITY_PARAMETERS
#: the kinds of bifurcation between two orbits of a branch (Bifurcation.kind)
BIFURCATION_KINDS = ("fold", "period_doubling", "neimark_sacker", "branch_point")
#: a multiplier is complex (a Neimark-Sacker pair, not a real one crossing +-1) when its
#: imaginary part exceeds this at both orbits of the interval
COMPLEX_IMAG = 1e-6
#: shootings at most to locate one bifurcation (Illinois secant on the arclength)
LOCATE_SOLVES = 8


@dataclass(frozen=True)
class Bifurcation(Result):
    """A bifurcation between two consecutive orbits of an :class:`OrbitBranch`.

    Attributes:
        kind: one of BIFURCATION_KINDS: "fold" (the parameter turns; a real multiplier passes +1),
            "period_doubling" (a real multiplier passes -1), "neimark_sacker" (a complex
            pair leaves or enters the unit circle), "branch_point" (a real multiplier
            passes +1 where the parameter does not turn: a symmetry-breaking pitchfork
            or a transcritical branch point; :func:`switch_branch` starts there).
        parameter: the continued parameter's value there [its unit].
        mass_flow: mdot [kg/s] there.
        period: T [s] there.
        multiplier: the crossing multiplier there [-] (on the unit circle when located).
        multipliers: the non-trivial Floquet multipliers there, by decreasing modulus [-].
        index: it lies between the branch's orbits ``index`` and ``index + 1``.
        located: found by shooting orbits between the two (secant on the crossing
            multiplier's distance from the unit circle); False: interpolated linearly
            between them.
        residual: the located multiplier's distance from the unit circle, abs(mu) - 1 [-].
        y: (2 n + 1,) the orbit there: z0, v0, T (the branch's chart).
        tangent: (2 n + 2,) the branch's direction there in (z0, v0, T, scaled parameter).
        vector: (2 n,) real eigenvector of the monodromy for the crossing multiplier (for
            :func:`switch_branch`), its largest entry 1.
    """

    kind: str
    parameter: float
    mass_flow: float
    period: float
    multiplier: complex
    multipliers: np.ndarray
    index: int
    located: bool
    residual: float
    y: np.ndarray
    tangent: np.ndarray
    vector: np.ndarray


class _Parameter:
    """A continuation parameter: its name, its value at the start ``value`` and scale
    (the arclength counts the scaled value p / scale: the mass flow in kg/s, any other
    parameter relative to its start), and the core system at a scaled value in the chart
    of ``base``."""

    def __init__(self, model, name, rebuild, value, scale, mass_flow):
        self.model, self.name, self.rebuild = model, name, rebuild
        self.value, self.scale, self.mass_flow = float(value), float(scale), float(mass_flow)
        self.base = None  # set with the chart
        self._models: dict = {}

    def physical(self, scaled) -> float:
        return float(scaled) * self.scale

    def model_at(self, scaled):
        """The model at the scaled value (the last few cached: Newton and the parameter
        column call the same values again)."""
        key = float(scaled)
        if key not in self._models:
            model = self.rebuild(self.physical(key))
            n = _chart(self.model, self.base).n
            try:
                same = type(model) is type(self.model) and _chart(model, self.base).n == n
            except (ValueError, TypeError, IndexError, RuntimeError):  # the base state does not fit it
                same = False
            if not same:
                raise ValueError(f"parameter: rebuild({self.physical(key):.6g}) returned a {type(model).__name__} "
                                 f"whose coordinates differ from the start's ({n}): the model's dof layout must not "
                                 "change along the branch")
            if len(self._models) >= 4:
                self._models.pop(next(iter(self._models)))
            self._models[key] = model
        return self._models[key]

    def system(self, scaled):
        """(core system, mass flow [kg/s]) at the scaled value."""
        if self.rebuild is None:  # the mass flow itself
            mdot = self.physical(scaled)
            return _chart(self.model, self.base).system(mdot), mdot
        return _chart(self.model_at(scaled), self.base).system(self.mass_flow), self.mass_flow


def _element_rebuild(model, name):
    """(rebuild(value) -> model, value at the start) of a parameter by name of an element
    model built by ModelBuilder."""
    from dataclasses import replace

    from ..model import Model, _rebuild_model

    if not isinstance(model, Model) or model._description is None:
        raise ValueError(f"parameter = {name!r} by name needs a pipeflex.Model built by ModelBuilder (got "
                         f"{type(model).__name__}); give a callable rebuild(value) -> model instead "
                         "(parameter_value its value at the start)")
    desc = model._description
    if name in GRAVITY_PARAMETERS:
        value, gravity_at = _gravity_parameter(name, desc["_gravity"])

        def change(d, v):
            d["_gravity"] = gravity_at(v)
    elif name == "point_mass":
        masses = {float(m["mass"]) for m in desc["_masses"]}
        if len(masses) != 1:
            raise ValueError(f"parameter = 'point_mass' sets every point mass of the model, whose masses are "
                             f"{sorted(masses) or 'none'}: it needs one or more equal point masses (else give a "
                             "callable rebuild(value) -> model)")
        value = masses.pop()

        def change(d, v):
            d["_masses"] = [{**m, "mass": v} for m in d["_masses"]]
    else:  # a section field, in every section
        sections = [e["section"] for e in desc["_elements"] + desc["_ancf"]]
        values = {getattr(s, name) for s in sections}
        if len(values) != 1 or None in values:
            raise ValueError(f"parameter = {name!r} sets the field in every section, whose values are "
                             f"{sorted(values, key=str)}: it needs one value at the start (else give a callable "
                             "rebuild(value) -> model)")
        value = float(values.pop())

        def change(d, v):
            for key in ("_elements", "_ancf"):
                d[key] = [{**e, "section": replace(e["section"], **fields(e["section"], v))} for e in d[key]]

        def fields(section, v):
            # "EI" is an isotropic section's bending stiffness: EIz follows where it equals EI
            return {name: v, "EIz": v} if name == "EI" and section.EIz == section.EI else {name: v}

    def rebuild(v):
        d = dict(desc)
        change(d, float(v))
        out = _rebuild_model(d, model.mass_flow, model._is_free)
        out.info = model.info
        return out

    return rebuild, value


def _gravity_parameter(name, g):
    """(value at the start [m/s^2], gravity(value) -> vector [m/s^2]) of the gravity
    parameter ``name`` (GRAVITY_PARAMETERS) of the gravity vector ``g``."""
    g = np.array(g, float)
    if name == "gravity":
        if not np.any(g):
            raise ValueError("parameter = 'gravity' scales the model's gravity vector, which is zero: use "
                             "'gravity_x', 'gravity_y' or 'gravity_z'")
        unit = g / np.linalg.norm(g)
        return float(np.linalg.norm(g)), lambda v: v * unit
    k = "xyz".index(name[-1])

    def component(v):
        out = g.copy()
        out[k] = v
        return out

    return float(g[k]), component


def _bodies_rebuild(system, name):
    """(rebuild(value) -> system, value at the start) of a parameter by name
    (BODY_PARAMETERS but the mass flow) of a system whose class rebuilds it with another
    gravity (``_gravity_rebuild``: a MultibodySystem built by MultibodyBuilder, a
    CoupledSystem of such parts, whose gravities must agree)."""
    if name not in BODY_PARAMETERS:
        raise ValueError(f"parameter = {name!r} by name is for an element model; a {type(system).__name__} knows "
                         f"{', '.join(BODY_PARAMETERS)} (its bodies' sections are reduced when a body is made): give "
                         "a callable rebuild(value) -> system instead (parameter_value its value at the start)")
    gravity_rebuild = getattr(system, "_gravity_rebuild", None)
    found = None if gravity_rebuild is None else gravity_rebuild()
    if found is None:
        raise ValueError(f"parameter = {name!r} by name needs a system built by its builder (MultibodyBuilder.build, "
                         f"or a CoupledSystem of such parts; got {type(system).__name__}); give a callable "
                         "rebuild(value) -> system instead")
    g0, with_gravity = found
    value, gravity_at = _gravity_parameter(name, g0)
    return (lambda v: with_gravity(gravity_at(float(v)))), value


def _parameter(model, parameter, parameter_value, mass_flow) -> _Parameter:
    """The continuation parameter ``parameter`` (a name of PARAMETERS or a callable) of
    ``model`` at the mass flow ``mass_flow`` [kg/s]."""
    if callable(parameter):
        if parameter_value is None:
            raise ValueError("parameter_value (the parameter's value at the start) is needed with a callable "
                             "parameter rebuild(value) -> model")
        value = _checks.finite("parameter_value", parameter_value)
        name, rebuild = getattr(parameter, "__name__", "parameter"), parameter
    elif parameter == "mass_flow":
        name, rebuild, value = "mass_flow", None, float(mass_flow)
    elif isinstance(parameter, str) and parameter in PARAMETERS:
        name = parameter
        from ..model import Model

        rebuild, value = (_element_rebuild if isinstance(model, Model) else _bodies_rebuild)(model, parameter)
    else:
        raise ValueError(f"parameter must be one of {', '.join(PARAMETERS)} or a callable rebuild(value) -> model; "
                         f"got {parameter!r}")
    if not callable(parameter) and parameter_value is not None:
        raise ValueError(f"parameter_value is for a callable parameter; {name!r} is read from the model "
                         f"({value:.6g})")
    scale = 1.0 if rebuild is None else (abs(value) if value != 0.0 else 1.0)
    return _Parameter(model, name, rebuild, value, scale, mass_flow)


def _floquet(Phi, flow):
    """(multipliers by decreasing modulus, index of the trivial one, eigenvectors as
    columns) of the monodromy ``Phi``; the trivial multiplier is the one whose eigenvector
    is the flow direction ``flow`` (xdot at t = 0), among those within
    TRIVIAL_MULTIPLIER_TOL of 1 (another multiplier 1 of a symmetry stays); else the
    closest to 1."""
    mu, V = np.linalg.eig(Phi)
    order = np.argsort(-np.abs(mu), kind="stable")
    mu, V = mu[order], V[:, order]
    near = np.flatnonzero(np.abs(mu - 1.0) <= TRIVIAL_MULTIPLIER_TOL)
    f = np.asarray(flow, float)
    if len(near) > 1 and np.linalg.norm(f) > 0.0:
        align = np.abs(V[:, near].conj().T @ f) / (np.linalg.norm(V[:, near], axis=0) * np.linalg.norm(f))
        trivial = int(near[np.argmax(align)])
    else:
        trivial = int(np.argmin(np.abs(mu - 1.0)))
    return mu, trivial, V


@dataclass
class _Point:
    """An orbit of a branch being continued (scaled parameter p)."""

    y: np.ndarray
    p: float
    tangent: np.ndarray  # the direction it was reached in (the secant from the last point)
    mu: np.ndarray
    trivial: int
    vectors: np.ndarray
    monodromy: np.ndarray
    orbit: PeriodicOrbit
    step: float  # arclength from the last point


def _nontrivial_multipliers(point):
    return np.delete(point.mu, point.trivial), np.delete(point.vectors, point.trivial, axis=1)


def _tracks(points):
    """The non-trivial multipliers of each orbit and (k, m) the index of each of the m
    tracks at each orbit: a multiplier of one orbit continues as its match at the next
    (least total distance, scipy's linear_sum_assignment)."""
    from scipy.optimize import linear_sum_assignment

    mus = [_nontrivial_multipliers(q)[0] for q in points]
    idx = np.zeros((len(points), len(mus[0])), dtype=np.int64)
    idx[0] = np.arange(len(mus[0]))
    for k in range(len(points) - 1):
        ia, ib = linear_sum_assignment(np.abs(mus[k][:, None] - mus[k + 1][None, :]))
        to = np.empty(len(ia), dtype=np.int64)
        to[ia] = ib
        idx[k + 1] = to[idx[k]]
    return mus, idx


def _crossings(points):
    """The multipliers that cross the unit circle along the orbits ``points``: (kind, k,
    index at orbit k, index at orbit k + 1), indices among the non-trivial multipliers,
    the crossing in the interval (k, k + 1). A track crosses when it leaves NEUTRAL on
    one side and later on the other (it may linger within NEUTRAL in between: the
    interval is where it changes sign); a complex pair (imaginary parts above
    COMPLEX_IMAG at both ends) is one Neimark-Sacker crossing."""
    mus, idx = _tracks(points)
    out = []
    for track in range(idx.shape[1]):
        mu = np.array([mus[k][idx[k, track]] for k in range(len(points))])
        d = np.abs(mu) - 1.0
        side = np.where(d > NEUTRAL, 1, np.where(d < -NEUTRAL, -1, 0))
        last, last_k = 0, 0
        for k in np.flatnonzero(side):
            if last != 0 and side[k] != last:
                flips = [q for q in range(last_k, k) if np.sign(d[q]) != np.sign(d[q + 1])]
                q = flips[0] if flips else last_k
                if abs(mu[last_k].imag) > COMPLEX_IMAG and abs(mu[k].imag) > COMPLEX_IMAG:
                    if mu[k].imag > 0:  # a pair: once
                        out.append(("neimark_sacker", q, idx[q, track], idx[q + 1, track]))
                else:
                    s = d[q] / (d[q] - d[q + 1]) if d[q] != d[q + 1] else 0.0
                    at = mu[q] + s * (mu[q + 1] - mu[q])
                    out.append(("branch_point" if at.real > 0 else "period_doubling", q, idx[q, track],
                                idx[q + 1, track]))
            last, last_k = side[k], k
    return out


class _Branch:
    """The continuation of one branch: pseudo-arclength steps in (z0, v0, T, p) with step
    control, the orbits' Floquet multipliers, and the bifurcations between them."""

    def __init__(self, shooter, par, *, tol, max_iterations, ds, max_step, p_end, max_points, locate):
        self.shooter, self.par = shooter, par
        self.tol, self.max_iterations = tol, max_iterations
        self.ds, self.max_step = ds, max_step
        self.p_end, self.max_points, self.locate_ = p_end, max_points, locate
        self.points = []
        self.folds = []
        # the shooter may have served another branch (switch_branch): count this one's work
        self.work0 = (shooter.calls, shooter.newton_iterations) if shooter is not None else (0, 0)

    def _solve_at(self, y_prev, p_prev, tangent, h, xdot_prev, jacobian):
        n = self.shooter.n
        y_pred = y_prev + h * tangent[:-1]
        p_pred = p_prev + h * tangent[-1]
        y, p, out, it, res = _solve(self.shooter, y_pred, p_pred, tol=self.tol, max_iterations=self.max_iterations,
                                    phase=(y_pred, xdot_prev), arclength=(y_prev, p_prev, tangent, h),
                                    jacobian=jacobian)
        mdot = self.par.mass_flow if self.par.rebuild is not None else self.par.physical(p)
        orbit = _finish(self.shooter, y[:n], y[n:2 * n], y[-1], mdot, out, it, res)
        mu, trivial, V = _floquet(out["monodromy"], np.concatenate([y[n:2 * n], out["a0"]]))
        return y, p, out, it, orbit, mu, trivial, V

    def run(self, y_prev, p_prev, tangent, xdot_prev, *, what, unturned=1):
        """Continue from the orbit (or Hopf point) y_prev at p_prev along ``tangent``; a
        turn of the parameter counts from orbit ``unturned`` on (the secant from a located
        branch point carries its location's error: no turn at the first orbit after it)."""
        n = self.shooter.n
        h = self.ds
        direction = 1.0 if self.p_end >= p_prev else -1.0
        Phi_prev = None
        while len(self.points) < self.max_points:
            try:
                y, p, out, it, orbit, mu, trivial, V = self._solve_at(y_prev, p_prev, tangent, h, xdot_prev,
                                                                      Phi_prev)
            except (ConvergenceError, np.linalg.LinAlgError) as exc:
                h *= 0.5
                logger.info("continue_orbits: no orbit at step %.3g (%s); halving the step", 2 * h, exc)
                if h < 1e-6 * self.ds or h == 0.0:  # (1e-6 ds underflows for a subnormal ds)
                    break
                continue
            logger.info("continue_orbits: orbit %d at %s = %.8g: T = %.8g s, %s (%d iterations)",
                        len(self.points) + 1, self.par.name, self.par.physical(p), y[-1],
                        "stable" if orbit.stable else "unstable", it)
            Phi_prev = out["monodromy"]
            new_tangent = np.concatenate([y - y_prev, [p - p_prev]])
            step = float(np.linalg.norm(new_tangent))
            new_tangent /= step
            if len(self.points) >= unturned and tangent[-1] != 0.0 and np.sign(new_tangent[-1]) != np.sign(tangent[-1]):
                self.folds.append(len(self.points) - 1)  # the turn is at the last orbit
            self.points.append(_Point(y, p, new_tangent, mu, trivial, V, out["monodromy"], orbit, step))
            tangent = new_tangent
            y_prev, p_prev = y, p
            xdot_prev = np.concatenate([y[n:2 * n], out["a0"]])
            if (self.par.physical(p) - self.par.physical(self.p_end)) * direction >= 0.0:
                break
            if it <= 6:  # chord iterations are cheap: a few are an easy step
                h = min(2.0 * h, self.max_step)
            elif it >= 10:
                h *= 0.5
        if not self.points:
            raise ConvergenceError(f"orbit continuation: no orbit found next to {what}",
                                   mass_flow=self.par.mass_flow if self.par.rebuild is not None
                                   else self.par.physical(p_prev))
        return self

    def bifurcations(self):
        """The bifurcations between consecutive orbits, located (``locate``) or interpolated:
        a fold at each turn of the parameter (its multiplier +1 is the fold's), the
        multipliers' crossings elsewhere."""
        out = []
        turns = [k for k in self.folds if 0 < k < len(self.points) - 1]
        for kind, k, i, j in (_crossings(self.points) if len(self.points) > 1 else ()):
            if kind == "branch_point" and (k in turns or k + 1 in turns):
                continue  # the multiplier +1 of the parameter's turn
            out.append(self._locate(k, kind, i, j))
        out += [self._fold(k) for k in turns]
        return tuple(sorted(out, key=lambda bif: (bif.index, bif.parameter)))

    def _fold(self, k):
        """The fold at the turn at orbit k: where the tangent's parameter component
        vanishes (Illinois secant on the arclength between the two orbits where it changes
        sign: the tangent at each is the null vector of the shooting's Jacobian with the
        parameter column); interpolated (the vertex of the parabola through orbits k - 1,
        k, k + 1) without ``locate`` or when the shooting fails."""
        if not self.locate_:
            return self._turn(k)
        n = self.shooter.n
        try:
            def dp(y, p, out, reference):
                return _extended_tangent(self.shooter, y, p, out, reference)

            tang = {}
            for i in (k - 1, k, k + 1):
                q = self.points[i]
                out = self.shooter(q.y[:n], q.y[n:2 * n], q.y[-1], q.p, True)
                tang[i] = (dp(q.y, q.p, out, self.points[max(i, k)].tangent), out)
            i = k - 1 if np.sign(tang[k - 1][0][-1]) != np.sign(tang[k][0][-1]) else k
            a, b = self.points[i], self.points[i + 1]
            if np.sign(tang[i][0][-1]) == np.sign(tang[i + 1][0][-1]):
                return self._turn(k)
            bracket = Illinois(0.0, b.step, tang[i][0][-1], tang[i + 1][0][-1])
            xdot_a = np.concatenate([a.y[n:2 * n], tang[i][1]["a0"]])
            best = None
            for _ in range(LOCATE_SOLVES):
                s = bracket.trial()
                y, p, out, it, orbit, mu, trivial, V = self._solve_at(a.y, a.p, b.tangent, s, xdot_a, a.monodromy)
                t = dp(y, p, out, b.tangent)
                best = (y, p, mu, trivial, V, t)
                f = t[-1]
                if abs(f) <= 1e-9 or bracket.width <= 1e-9 * b.step:
                    break
                bracket.update(s, f)
        except (ConvergenceError, np.linalg.LinAlgError):
            return self._turn(k)
        y, p, mu, trivial, V, t = best
        others = np.delete(mu, trivial)
        c = int(np.argmin(np.abs(others - 1.0)))
        return self._make("fold", i, y, p, mu, trivial, V, c, True, abs(others[c]) - 1.0, t)

    def _make(self, kind, k, y, p, mu_all, trivial, V, crossing, located, residual, tangent):
        mu, vecs = np.delete(mu_all, trivial), np.delete(V, trivial, axis=1)
        c = int(crossing)
        v = np.real(vecs[:, c] * np.exp(-1j * np.angle(vecs[np.argmax(np.abs(vecs[:, c])), c])))
        v = v / np.abs(v).max()
        mdot = self.par.mass_flow if self.par.rebuild is not None else self.par.physical(p)
        return Bifurcation(kind=kind, parameter=self.par.physical(p), mass_flow=float(mdot), period=float(y[-1]),
                           multiplier=complex(mu[c]), multipliers=mu, index=int(k), located=bool(located),
                           residual=float(residual), y=np.array(y), tangent=np.array(tangent), vector=v)

    def _locate(self, k, kind, i, j):
        a, b = self.points[k], self.points[k + 1]
        mu_a = _nontrivial_multipliers(a)[0][i]
        mu_b = _nontrivial_multipliers(b)[0][j]
        lo, hi = 0.0, b.step
        flo, fhi = abs(mu_a) - 1.0, abs(mu_b) - 1.0
        best = (b.y, b.p, b.mu, b.trivial, b.vectors, j, fhi)
        if self.locate_:
            n = self.shooter.n
            out_a = xdot_a = None
            bracket = Illinois(lo, hi, flo, fhi)
            for _ in range(LOCATE_SOLVES):
                if abs(best[-1]) <= 10 * NEUTRAL or bracket.width <= 1e-9 * b.step:
                    break
                s = bracket.trial()
                try:
                    if out_a is None:  # the phase reference at a: its vector field
                        out_a = self.shooter(a.y[:n], a.y[n:2 * n], a.y[-1], a.p, False)
                        xdot_a = np.concatenate([a.y[n:2 * n], out_a["a0"]])
                    y, p, out, it, orbit, mu, trivial, V = self._solve_at(a.y, a.p, b.tangent, s, xdot_a,
                                                                          a.monodromy)
                except (ConvergenceError, np.linalg.LinAlgError):
                    break
                others = np.delete(mu, trivial)
                guess = mu_a + (s / b.step) * (mu_b - mu_a)
                c = int(np.argmin(np.abs(others - guess)))
                f = abs(others[c]) - 1.0
                best = (y, p, mu, trivial, V, c, f)
                bracket.update(s, f)
            y, p, mu, trivial, V, c, f = best
            return self._make(kind, k, y, p, mu, trivial, V, c, True, f, b.tangent)
        # interpolated linearly between the two orbits
        t = flo / (flo - fhi)
        y, p = a.y + t * (b.y - a.y), a.p + t * (b.p - a.p)
        return self._make(kind, k, y, p, b.mu, b.trivial, b.vectors, j, False, fhi, b.tangent)

    def _turn(self, k):
        """A fold at the turn at orbit k: the vertex of the parabola p(s) through orbits
        k - 1, k, k + 1 (interpolated)."""
        pts = self.points[k - 1:k + 2]
        s = np.array([0.0, pts[1].step, pts[1].step + pts[2].step])
        c2, c1, _ = np.polyfit(s, [q.p for q in pts], 2)
        sv = float(np.clip(-c1 / (2 * c2), s[0], s[2])) if c2 != 0 else s[1]
        w = np.interp(sv, s, [0.0, 1.0, 2.0])
        i = min(int(w), 1)
        a, b = pts[i], pts[i + 1]
        t = w - i
        y, p = a.y + t * (b.y - a.y), a.p + t * (b.p - a.p)
        others = np.delete(b.mu, b.trivial)
        c = int(np.argmin(np.abs(others - 1.0)))
        return self._make("fold", k - 1 + i, y, p, b.mu, b.trivial, b.vectors, c, False, abs(others[c]) - 1.0,
                          b.tangent)

    def result(self, hopf, context):
        pts = self.points
        par = self.par
        values = np.array([par.physical(q.p) for q in pts])
        mdot = values if par.rebuild is None else np.full(len(pts), par.mass_flow)
        mmax = [float(np.abs(np.delete(q.mu, q.trivial)).max(initial=0.0)) for q in pts]
        stable = [bool(m <= 1.0 + NEUTRAL) for m in mmax]
        bifs = self.bifurcations()
        branch = OrbitBranch(mass_flow=mdot, period=np.array([q.y[-1] for q in pts]),
                             amplitude=np.array([q.orbit.amplitude for q in pts]), stable=np.array(stable),
                             max_multiplier=np.array(mmax), folds=np.array([values[k] for k in self.folds]),
                             hopf=hopf, starts=tuple(q.orbit.start for q in pts),
                             stats={"flow_maps": self.shooter.calls - self.work0[0],
                                    "newton_iterations": self.shooter.newton_iterations - self.work0[1]},
                             parameter_name=par.name, parameter=values,
                             multipliers=np.array([q.mu for q in pts]),
                             trivial=np.array([q.trivial for q in pts], dtype=np.int64), bifurcations=bifs)
        object.__setattr__(branch, "_context", context)
        return branch


def _extended_tangent(shooter, y, p, out, direction):
    """The unit tangent (dz0, dv0, dT, dp) of the branch at the orbit y at the scaled
    parameter p: the null vector of the shooting's Jacobian with the parameter column (the
    phase condition at the orbit itself), oriented so that dp has the sign of
    ``direction``, or (an array) along the direction ``direction``."""
    n = shooter.n
    xdot = np.concatenate([y[n:2 * n], out["a0"]])
    J = np.zeros((2 * n + 1, 2 * n + 2))
    J[:2 * n, :2 * n] = out["monodromy"] - np.eye(2 * n)
    J[:2 * n, 2 * n] = np.concatenate([out["v"], out["a"]])
    J[:2 * n, 2 * n + 1] = _flow_derivative(shooter, y[:n], y[n:2 * n], y[-1], p)
    J[2 * n, :2 * n] = xdot
    t = np.linalg.svd(J)[2][-1]
    if (t @ direction if np.ndim(direction) else t[-1] * direction) < 0:
        t = -t
    return t / np.linalg.norm(t)


@blas_pinned
def continue_orbits(model, *, start, mass_flow_end: Optional[float] = None, parameter="mass_flow",
                    end: Optional[float] = None, parameter_value: Optional[float] = None, amplitude: float = 1e-3,
                    ds: Optional[float] = None, max_step: Optional[float] = None, max_points: int = 40,
                    steps: Optional[int] = None, tol: float = 1e-8, max_iterations: int = 12,
                    newton_tol: float = 1e-12, rho_inf: float = 0.9, state=None, locate: bool = True) -> OrbitBranch:
    """Continue a branch of periodic orbits in the mass flow or another parameter, with
    every orbit's Floquet multipliers and the bifurcations between them.

    Args:
        model: an autonomous model (constant loads, no hub drive): a
            :class:`~pipeflex.Model`, a :class:`~pipeflex.multibody.MultibodySystem` or a
            :class:`~pipeflex.CoupledSystem`.
        start: where the branch starts: the :class:`~pipeflex.CriticalFlow` of kind
            "flutter" (a Hopf point in the mass flow: its mass flow, frequency and critical
            mode give the first orbit; with joints the mode's independent coordinates are
            mapped to the system's through the null-space basis of the linearisation at
            the Hopf equilibrium), or a :class:`PeriodicOrbit` of ``model`` (the branch
            through it, in either direction along the parameter: toward ``end``).
        mass_flow_end: mdot [kg/s] at which to stop (either side of the Hopf point: a
            subcritical branch first turns back); the same as ``end`` for the mass flow.
        parameter: the continued parameter: "mass_flow" [kg/s]; "gravity" (the magnitude
            of the model's gravity vector along its direction) or "gravity_x",
            "gravity_y", "gravity_z" [m/s^2]; "point_mass" [kg] (every point mass); a
            :class:`~pipeflex.PipeSection` field (SECTION_PARAMETERS, set in every section,
            whose values must agree at the start; "EI" [N m^2] sets EIz too where it equals
            EI (an isotropic section: both planes bend alike), while GJ and EA, derived
            from EI when the section was made, keep their values); or a callable ``rebuild(value) -> model`` (the model's dof
            layout must not change with the value; ``parameter_value`` is its value at
            the start). Parameters other than the mass flow need a :class:`PeriodicOrbit`
            start and, by name, a model built by :class:`~pipeflex.ModelBuilder`. A
            :class:`~pipeflex.multibody.MultibodySystem` (built by
            :class:`~pipeflex.multibody.MultibodyBuilder`) and a
            :class:`~pipeflex.CoupledSystem` know BODY_PARAMETERS by name: the mass flow
            and the gravity (a coupled system's element model and bodies together, whose
            gravity must agree at the start); their sections and masses through a
            callable ``rebuild(value) -> system``.
        end: the parameter's value at which to stop [its unit].
        parameter_value: the callable parameter's value at the start.
        amplitude: size of the first orbit's excursion along the critical mode [m] (a
            Hopf start).
        ds: first pseudo-arclength step (default from ``amplitude`` at a Hopf point, 1e-2
            from an orbit); halved on a failure or a hard step, doubled after easy ones
            (Newton in <= 6 iterations) up to ``max_step`` (default 64 ds). The arclength
            is the Euclidean norm in (z0 [m, rad], v0 [m/s, rad/s], T [s], p), p the mass
            flow [kg/s] or any other parameter relative to its start value.
        max_points: orbits on the branch at most.
        steps: N, integrator steps per period (default: the start orbit's, or
            STEPS_PER_PERIOD from a Hopf point).
        tol, max_iterations, newton_tol, rho_inf: as :func:`periodic_orbit`.
        state: starting guess for the static solve at the Hopf point.
        locate: locate each bifurcation by shooting orbits between the two it lies between
            (at most LOCATE_SOLVES); False interpolates linearly.

    Returns:
        :class:`OrbitBranch` with every orbit's multipliers and the bifurcations; its
        ``stats`` hold the flow maps used.

    Raises:
        ValueError: bad options, e.g. an unknown parameter name (the message lists the
            valid ones; a section field on bodies), or a parameter other than the mass
            flow from a Hopf point.
        ConvergenceError: no orbit next to the start.
    """
    from .static import static_equilibrium

    orbit_start = isinstance(start, PeriodicOrbit)
    if not orbit_start and getattr(start, "kind", None) != "flutter":
        raise ValueError("start must be a CriticalFlow of kind 'flutter' (a Hopf point) or a PeriodicOrbit; got "
                         f"{getattr(start, 'kind', type(start).__name__)!r}")
    mdot0 = float(start.mass_flow)
    par = _parameter(model, parameter, parameter_value, mdot0)
    if mass_flow_end is not None and end is not None:
        raise ValueError("give mass_flow_end or end, not both")
    if mass_flow_end is not None:
        if par.name != "mass_flow" or par.rebuild is not None:
            raise ValueError(f"mass_flow_end is the end of a continuation in the mass flow; give end for "
                             f"parameter = {par.name!r}")
        end, end_name = mass_flow_end, "mass_flow_end"
    else:
        end_name = "end"
    if end is None:
        raise ValueError("end (or mass_flow_end) is needed: the parameter's value at which to stop")
    p_end = _checks.finite(end_name, end) / par.scale
    max_points = _checks.positive_int("max_points", max_points)
    tol = _checks.positive("tol", tol)
    max_iterations = _checks.positive_int("max_iterations", max_iterations)
    if not orbit_start:
        if par.rebuild is not None:
            raise ValueError(f"a Hopf point (CriticalFlow) starts a branch in the mass flow only; to continue in "
                             f"{par.name!r}, start from a PeriodicOrbit (e.g. one of a mass-flow branch: "
                             "periodic_orbit(model, state=branch.starts[k], period=branch.period[k]))")
        amp = _checks.positive("amplitude", amplitude)
        mc, wc = float(start.mass_flow), float(start.frequency)
        static = static_equilibrium(model, mass_flow=mc, state=state)
        # a coupled system's chart is its whole static result (element and body states)
        chart = _chart(model, model._equilibrium_state(static))
        steps = _checks.flow_map_steps("steps", STEPS_PER_PERIOD if steps is None else steps, chart.n)
        par.base = chart.base
        shooter = _Shooter(model, chart, steps, _options(chart, newton_tol, rho_inf))
        n = chart.n
        # first orbit: the equilibrium displaced along the real part of the critical mode,
        # velocity from its imaginary part (x(t) = Re(phi e^{i w t}) at t = 0)
        phi = _critical_direction(model, chart, start)
        phi = phi / np.abs(phi).max()
        z_dir, v_dir = phi.real, -wc * phi.imag
        scale = amp / max(np.abs(z_dir).max(), 1e-300)
        y0 = np.concatenate([np.zeros(n), np.zeros(n), [2 * np.pi / wc]])
        tangent = np.concatenate([scale * z_dir, scale * v_dir, [0.0], [0.0]])
        norm = np.linalg.norm(tangent)
        tangent /= norm
        ds = norm if ds is None else _checks.positive("ds", ds)
        # phase reference of the first orbit: the linear mode's point and velocity at t = 0
        xdot = scale * np.concatenate([v_dir, -wc ** 2 * z_dir])
        p0, hopf, what = mc, (mc, wc), f"the Hopf point at {mc:.6g} kg/s"
    else:
        chart = _chart(model, start.base)
        steps = _checks.flow_map_steps("steps", start.steps if steps is None else steps, chart.n)
        par.base = chart.base
        shooter = _Shooter(model, chart, steps, _options(chart, newton_tol, rho_inf),
                           parameter=None if par.rebuild is None else par)
        n = chart.n
        p0 = par.value / par.scale
        y0 = np.concatenate([start.z0, start.v0, [start.period]])
        out = shooter(y0[:n], y0[n:2 * n], y0[-1], p0, True)
        tangent = _extended_tangent(shooter, y0, p0, out, 1.0 if p_end >= p0 else -1.0)
        xdot = np.concatenate([y0[n:2 * n], out["a0"]])
        ds = 1e-2 if ds is None else _checks.positive("ds", ds)
        hopf = (float("nan"), float("nan"))
        what = f"the start orbit at {par.name} = {par.value:.6g}"
    max_step = 64.0 * ds if max_step is None else _checks.positive("max_step", max_step)
    branch = _Branch(shooter, par, tol=tol, max_iterations=max_iterations, ds=ds, max_step=max_step,
                     p_end=p_end, max_points=max_points, locate=bool(locate))
    branch.work0 = (0, 0)  # the start's flow maps count too
    branch.run(y0, p0, tangent, xdot, what=what)
    context = dict(model=model, par=par, shooter=shooter, tol=tol, max_iterations=max_iterations, max_step=max_step,
                   locate=bool(locate))
    return branch.result(hopf, context)


@blas_pinned
def switch_branch(branch: OrbitBranch, bifurcation: Bifurcation, *, amplitude: float, end: Optional[float] = None,
                  max_step: Optional[float] = None, max_points: int = 40) -> OrbitBranch:
    """The other branch of periodic orbits through a branch point of ``branch``.

    The first orbit is sought at the branch point's orbit displaced by ``amplitude``
    along the monodromy's eigenvector of the multiplier +1 that is not the flow direction
    (:attr:`Bifurcation.vector`: the null vector of the monodromy minus the identity not
    tangent to ``branch``), on the arclength hyperplane normal to that vector (so the
    parameter is free to move: a pitchfork's new branch leaves the point at the
    parameter's value, a transcritical one across it); from there the branch is
    continued as by :func:`continue_orbits`.

    Args:
        branch: a branch from :func:`continue_orbits` (in this session: the model and
            options come from it).
        bifurcation: one of ``branch.bifurcations``, of kind "branch_point".
        amplitude: the first step along the eigenvector [m]: its largest displacement
            coordinate's change (the sign chooses the side; the other side of a
            symmetry-breaking pitchfork is the mirror image of this one).
        end: the parameter's value at which to stop [its unit] (default: the end of
            ``branch``'s continuation in the direction the branch was continued).
        max_step: the largest pseudo-arclength step (default 64 times the first, whose
            length is set by ``amplitude``); the steps double after easy ones.
        max_points: orbits on the new branch at most.

    Returns:
        the new :class:`OrbitBranch` (its first orbit next to the branch point).

    Raises:
        ValueError: not a branch point of this branch, or a branch read from a file.
        ConvergenceError: no orbit found along the eigenvector.
    """
    context = getattr(branch, "_context", None)
    if context is None:
        raise ValueError("branch must come from continue_orbits in this session (a branch read from a file has no "
                         "model to continue)")
    if not isinstance(bifurcation, Bifurcation) or not any(b is bifurcation for b in branch.bifurcations):
        raise ValueError("bifurcation must be one of branch.bifurcations")
    if bifurcation.kind != "branch_point":
        raise ValueError(f"switch_branch starts at a branch point; this bifurcation is a {bifurcation.kind!r}")
    amp = _checks.finite("amplitude", amplitude)
    if amp == 0.0:
        raise ValueError("amplitude must be non-zero (its sign chooses the side of the branch point)")
    shooter, par = context["shooter"], context["par"]
    n = shooter.n
    v = np.asarray(bifurcation.vector, float)
    zpart = np.abs(v[:n]).max()
    scale = amp / (zpart if zpart > 0 else np.abs(v).max())
    tangent = np.concatenate([scale * v, [0.0], [0.0]])
    norm = np.linalg.norm(tangent)
    tangent /= norm
    y0, p0 = np.array(bifurcation.y, float), bifurcation.parameter / par.scale
    out = shooter(y0[:n], y0[n:2 * n], y0[-1], p0, False)
    xdot = np.concatenate([y0[n:2 * n], out["a0"]])
    if end is None:  # on in the direction the branch was continued
        p_end = np.inf if branch.parameter[-1] >= branch.parameter[0] else -np.inf
    else:
        p_end = _checks.finite("end", end) / par.scale
    max_step = 64.0 * norm if max_step is None else _checks.positive("max_step", max_step)
    new = _Branch(shooter, par, tol=context["tol"], max_iterations=context["max_iterations"], ds=norm,
                  max_step=max_step, p_end=p_end, max_points=_checks.positive_int("max_points", max_points),
                  locate=context["locate"])
    new.run(y0, p0, tangent, xdot, what=f"the branch point at {par.name} = {bifurcation.parameter:.6g}", unturned=2)
    return new.result(branch.hopf, context)
