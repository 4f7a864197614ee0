"""Static equilibrium by Newton's method with load stepping, arc-length continuation
through limit points and flow continuation: one driver for every formulation (element
models, systems of bodies, coupled systems) on the core's system object.

A formulation gives the driver what is its own through a small protocol of its model
class (pipeflex.Model, pipeflex.MultibodySystem, pipeflex.CoupledSystem):
``_system(state, mass_flow=)`` and ``_state_of(system)`` (the core system object on a
user-level state and back), ``_static_start(state)`` (the working start state: a copy
the solves update in place, with ``copy()``), ``_static_newton(state, solve, ...)`` (one
Newton solve: the driver's core call ``solve`` on the formulation's system object, with
its force level, acceptance test and reasons; its dict may say ``refused`` (a converged
state outside the model's validity) or ``final`` (a failure no continuation helps: a
mechanism)), ``_static_increment(start, end)`` (the increment in the core's chart: the
continuation's secant), ``_static_failure(out, ...)`` (the error of a failed load
stepping) and ``_static_result(state, ...)`` (the :class:`StaticResult`).
"""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Optional

import numpy as np

from .. import _checks, _core
from ..errors import ConvergenceError, LimitPointError, SingularMatrixError
from ..results import Result
from ._continuation import follow
from .._blas import pinned as blas_pinned


@dataclass(frozen=True)
class StaticResult(Result):
    """Converged static state (of any formulation).

    Attributes:
        state: the equilibrium: an element model's :class:`~pipeflex.state.State` (``q``
            positions [m] / rotation vectors [rad] per node, relative to
            ``state.frame(n)``); a :class:`~pipeflex.multibody.MultibodySystem`'s
            :class:`~pipeflex.multibody.MultibodyState` (the joint reactions in
            ``state.lam``); a :class:`~pipeflex.CoupledSystem`'s element model's State.
        iterations: total Newton iterations.
        residual: final residual norm [N] (a system of bodies: its largest entry).
        mass_flow: mdot [kg/s] of the equilibrium.
        limit_points: load factors [-] (path parameters t with a flow ramp) of the limit
            points that arc-length continuation passed on the way (snap-through); empty
            when the load stepping converged.
        body_state: a CoupledSystem's bodies (a MultibodyState with their joint
            multipliers); None otherwise.
        coupling_forces: a CoupledSystem's coupling multipliers [N, N m]; None otherwise.
    """

    state: object
    iterations: int
    residual: float
    mass_flow: float
    limit_points: tuple = ()
    body_state: Optional[object] = None
    coupling_forces: Optional[np.ndarray] = None

    def to_vtk(self, folder, model=None, **options):
        """Write the equilibrium for ParaView (one frame at t = 0, ``.pvd`` + ``.vtu`` in
        ``folder``) through meshio; ``model``: the element model it was computed with.
        Options and data: :func:`pipeflex.vtk.write_vtk`. Returns the .pvd paths."""
        from ..vtk import write_vtk

        return write_vtk(self, folder, model, **options)


def _require_protocol(model):
    """``model`` is one of the package's model classes (it gives the static protocol), else
    TypeError naming it."""
    if not hasattr(model, "_static_newton"):
        hint = " (a tuple: pass the state as state=)" if isinstance(model, tuple) else ""
        raise TypeError(f"model must be a pipeflex.Model (or a MultibodySystem or CoupledSystem), got "
                        f"{type(model).__name__}{hint}")
    return model


@blas_pinned
def static_equilibrium(model, *, state=None, mass_flow: Optional[float] = None, load_steps: int = 1,
                       tol: float = 1e-10, max_iterations: int = 30, max_bisections: int = 8,
                       from_mass_flow: Optional[float] = None, path: str = "auto",
                       arc_steps: int = 200) -> StaticResult:
    """Solve R(q) = 0 for the static equilibrium under loads, gravity and mass flow, of
    an element model, a system of bodies or a coupled system.

    The loads and gravity are applied in ``load_steps`` equal increments (halved
    automatically, at most ``max_bisections`` times, when Newton fails).

    Flow continuation: with ``from_mass_flow`` the flow is ramped from that value to
    ``mass_flow`` in the same increments (and the same halving): a path parameter
    t = 0 ... 1 sets the flow ``from_mass_flow + t (mass_flow - from_mass_flow)`` and the
    load factor, which is t from the reference configuration (no ``state``: loads and
    flow are ramped together) and 1 from a given ``state``, which is then taken to be
    the equilibrium at ``from_mass_flow`` under the full loads (e.g. a previous
    result's ``state``, or the result itself for a coupled system). Without
    ``from_mass_flow`` the flow is ``mass_flow`` throughout and only the loads are stepped.

    A flow whose forces alone (applied at once to the reference configuration, no
    ``state``) have no equilibrium near it, as on a slender curved pipe whose flow
    deflects it far, is followed from rest instead, as if ``from_mass_flow=0`` (with
    ``path="auto"``, and as ``path="arclength"`` does).

    Limit points: with ``path="auto"`` (default), when the load stepping fails (Newton
    does not converge after the bisections, or the tangent is singular), the path is
    followed from the last converged step by arc-length (Riks/Crisfield) continuation in
    (q, t) with a spherical constraint (:mod:`pipeflex.analysis.arclength`), through
    limit points: if it comes back to t = 1 (snap-through), the equilibrium there is
    returned with the limit points passed in ``limit_points``; if it turns back and does
    not reach t = 1 within ``arc_steps`` steps, :class:`~pipeflex.LimitPointError` says
    at which load factor. ``path="load"``: load stepping only (the error as it failed);
    ``path="arclength"``: continuation from the start (from rest with the flow ramped
    with the loads if the flow's forces alone have no equilibrium near rest). A flow ramp (``from_mass_flow``)
    is continued by arc length only with ``path="arclength"`` (with "auto" its failure is
    reported as it is: :func:`~pipeflex.critical_mass_flow` reads it as divergence).

    Every formulation takes every option. A system of bodies' step acceptance (a step that
    stretches a body beyond the floating frame's small deformation is halved) and its
    mechanisms (free rigid motions kept, loads that drive one refused) are described at
    :func:`pipeflex.multibody.static_equilibrium`; a load stepping that failed after such
    a refusal, or on a coupled system's mechanism (a singular KKT matrix, a correction
    beyond the model), is reported as it is, not continued by ``"auto"``.

    Args:
        model: the :class:`~pipeflex.Model`, :class:`~pipeflex.multibody.MultibodySystem`
            or :class:`~pipeflex.CoupledSystem`.
        state: starting state (default the reference configuration); not modified: an
            element model's :class:`~pipeflex.state.State` or ``_core.State``; a
            MultibodySystem's :class:`~pipeflex.multibody.MultibodyState`; a
            CoupledSystem's :class:`StaticResult` (its parts and multipliers).
        mass_flow: mdot [kg/s] (default the model's).
        load_steps: number of load increments.
        tol: relative tolerance on the increment norm (to the model size) and on the
            residual (to the applied force level).
        max_iterations: Newton iterations per load step.
        max_bisections: halvings of the increment allowed in all.
        from_mass_flow: mdot [kg/s] at which the flow ramp starts (see above).
        path: ``"auto"``, ``"load"`` or ``"arclength"`` (see above).
        arc_steps: most arc-length steps of a continuation.

    Raises:
        ConvergenceError: with the load factor, iteration and residual where it failed
            (attributes ``load_factor``, ``iteration``, ``residual``, ``mass_flow``: the
            flow of the failed step); :class:`~pipeflex.errors.SingularMatrixError` if
            the tangent was singular. With ``from_mass_flow``, its further attributes
            ``reached_mass_flow`` and ``reached_state`` are the flow and the state of
            the last converged step (the start if none converged; else None).
        LimitPointError: (a ConvergenceError) the continuation turned back at a limit
            point below t = 1: ``load_factor`` [-] of the limit point, ``reached_state``
            there, ``mass_flow`` its mdot [kg/s].
    """
    _require_protocol(model)
    if path not in ("auto", "load", "arclength"):
        raise ValueError(f"path must be 'auto', 'load' or 'arclength', got {path!r}")
    load_steps = _checks.positive_int("load_steps", load_steps)
    tol = _checks.positive("tol", tol)
    max_iterations = _checks.positive_int("max_iterations", max_iterations)
    max_bisections = _checks.non_negative_int("max_bisections", max_bisections)
    arc_steps = _checks.positive_int("arc_steps", arc_steps)
    cold = state is None
    state = model._static_start(state)
    start = state.copy()
    mdot = model.mass_flow if mass_flow is None else _checks.finite("mass_flow", mass_flow)
    if from_mass_flow is None:
        def at(t):  # load stepping at the full flow
            return mdot, t
        along = at
    else:
        mdot0 = _checks.finite("from_mass_flow", from_mass_flow)

        def at(t):  # flow continuation (the loads ramped with it only from the reference configuration)
            return (mdot if t >= 1.0 else mdot0 + t * (mdot - mdot0)), (t if cold else 1.0)

        def extended(t):  # the same, extended past t = 1 (for the continuation)
            return mdot0 + t * (mdot - mdot0), (t if cold else 1.0)
        along = extended
    solve = dict(tol=tol, max_iterations=max_iterations)
    total_iter = 0

    def result(end, iterations, residual, limits=()):
        return model._static_result(end, iterations=iterations, residual=residual, mass_flow=mdot,
                                    limit_points=limits)
    if path == "arclength" and model.n_dofs:
        ok, it, rnorm, why, singular = _newton(model, state, *at(0.0), tol, max_iterations)
        if not ok and cold and mdot != 0.0 and from_mass_flow is None:  # ramp the flow with the loads
            ok, state, along = True, model._static_start(None), (lambda t: (t * mdot, t))
        if not ok:
            raise (SingularMatrixError if singular else ConvergenceError)(
                f"static equilibrium failed at the start of the continuation (t = 0) after {it} iterations: {why}",
                load_factor=at(0.0)[1], iteration=it, residual=rnorm, mass_flow=at(0.0)[0])
        return _continue(model, state, 0.0, along, solve, arc_steps, 1.0 / load_steps, it, result, None)

    failed = []  # the formulation's outcome dicts of the failed solves, in order

    def step(trial, t):
        nonlocal total_iter
        record = []
        outcome = _newton(model, trial, *at(t), tol, max_iterations, step=True, start=start, record=record)
        total_iter += outcome[1]
        if not outcome[0]:
            failed.extend(record)
        return outcome[0], outcome

    way = follow(step, state, start=0.0, end=1.0, steps=load_steps, halving="step", max_failures=max_bisections,
                 steps_name="load_steps")
    _, it, rnorm, why, singular = way.outcome
    state, lf = way.state, way.t
    if not way.done:
        out = failed[-1]
        m_t, lf_t = at(way.target)
        ramp = from_mass_flow is not None
        failure = model._static_failure(out, load_factor=lf_t, mass_flow=m_t, reached=at(lf), ramp=ramp,
                                        halvings=way.failures - 1, max_iterations=max_iterations,
                                        earlier=failed[:-1])
        if ramp:
            failure.reached_mass_flow = at(lf)[0]
            failure.reached_state = result(state, 0, 0.0).state
        # a step the formulation refused (its acceptance test: a body stretched beyond the
        # floating frame's small deformation) left the model's validity, and a failure it
        # calls final (a coupled system's singular KKT matrix: a mechanism) is no limit point
        if path == "load" or (path == "auto" and ramp) or any(o.get("refused") for o in failed) or out.get("final"):
            raise failure
        # the path's slope so far, dq/dt (the continuation's scale of t)
        secant = np.asarray(model._static_increment(start, state)) / lf if lf > 0 else None
        if lf == 0.0:  # is the start an equilibrium (under the flow's forces alone)?
            ok, it, _, _, _ = _newton(model, state, *at(0.0), tol, max_iterations)
            total_iter += it
            if not ok and cold and mdot != 0.0:
                # no, and the full flow at once from rest has none near: follow the flow from
                # rest with the loads (as path="arclength" does), the equilibrium reached
                # continuously; its own failure says where that path stopped
                try:
                    ramped = static_equilibrium(model, mass_flow=mdot, load_steps=load_steps, tol=tol,
                                                max_iterations=max_iterations, max_bisections=max_bisections,
                                                from_mass_flow=0.0, path=path, arc_steps=arc_steps)
                    # iterations: all of them, the failed first attempt's included
                    return replace(ramped, iterations=ramped.iterations + total_iter)
                except ConvergenceError as e:
                    e.args = (f"{failure.args[0]}; following the flow from rest (from_mass_flow=0) failed "
                              f"too: {e.args[0]}",)
                    raise
            if not ok:  # no: not a load path's failure
                raise failure
        return _continue(model, state, lf, along, solve, arc_steps, max(way.step, 1.0 / (64 * load_steps)),
                         total_iter, result, failure, secant)
    return result(state, total_iter, rnorm)


def _continue(model, state, t0, along, solve, arc_steps, dt0, total_iter, result, failure, secant=None):
    """Arc-length continuation from the converged ``state`` at t0 to t = 1; ``result(end,
    iterations, residual, limits)`` the StaticResult; ``failure`` the load stepping's error
    (re-raised, with the continuation's reason, if the continuation fails too) or None."""
    from . import arclength

    def newton(trial, arc):
        return _arc_newton(model, trial, arc, solve["tol"], None, solve["max_iterations"])

    size = model._system(state, mass_flow=along(t0)[0]).length_scale
    way = arclength.follow(model, state, t0, at=along, newton=newton, size=size, tol=solve["tol"],
                           max_iterations=solve["max_iterations"], max_steps=arc_steps, dt0=dt0,
                           secant=secant)
    total_iter += way.iterations
    limits = tuple(float(p.t) for p in way.limits)
    if way.end is not None:
        end = way.end.state.copy()
        # onto t = 1 exactly
        ok, it, rnorm, why, _ = _newton(model, end, *along(1.0), solve["tol"], solve["max_iterations"])
        if ok:
            return result(end, total_iter + it, rnorm, limits)
        way.why = f"the point at t = 1 did not converge: {why}"
    if way.limits:
        top = max(way.limits, key=lambda p: p.t)  # the largest load on the path
        m_top, lf_top = along(top.t)
        ramp = along(2.0)[0] != along(1.0)[0]
        at_ = f"path parameter t = {top.t:.6g} (mdot = {m_top:.6g} kg/s)" if ramp else f"load factor λ = {top.t:.6g}"
        raise LimitPointError(
            f"limit point at {at_}: the equilibrium path turns back there and did not return to "
            f"{'t' if ramp else 'the load factor'} 1 in {way.steps} arc-length steps ({way.why})",
            load_factor=lf_top if not ramp else top.t, iteration=total_iter, residual=way.residual,
            mass_flow=m_top, reached_mass_flow=m_top if ramp else None,
            reached_state=result(top.state, 0, 0.0).state, limit_points=limits)
    if failure is None:
        raise ConvergenceError(f"arc-length continuation failed: {way.why}", load_factor=along(way.last.t)[1]
                               if way.last else None, iteration=total_iter, residual=way.residual)
    failure.args = (f"{failure.args[0]}; arc-length continuation from load factor {along(t0)[1]:.6g} "
                    f"failed too: {way.why}",)
    raise failure


def _newton(model, state, mdot, load_factor, tol, max_iterations, step=False, start=None, record=None):
    """Newton's method on R(q) = 0 at (mdot, load_factor) from ``state`` (a working state of
    ``model``: :meth:`_static_start`'s; updated in place): the core's one static Newton on
    the model's system object (the formulation's ``_static_newton``). Converged when the
    increment is below ``tol`` model sizes or the residual below 1e-3 ``tol`` times the
    force level; a start within ``tol`` of the model's force level is converged already
    (a warm start, no iteration). Returns (converged, iterations, residual norm [N],
    reason, singular); ``start``: the solve's start state (a system of bodies judges its
    mechanisms' loads there); ``record``: a list the formulation's outcome dict is
    appended to (its failure's error reads it).

    ``step``: the solve is a load step from the equilibrium ``state``, accepted only if the
    tangent's inertia (its count of negative eigenvalues) at the end is the start's. Along
    a regular equilibrium path the count is constant; it changes only where an eigenvalue
    crosses zero, at a limit or bifurcation point. A step across one is not a step along
    the path: past a limit point the load has no nearby equilibrium and Newton, started
    from a nearly singular tangent, lands (if at all) on whatever equilibrium its
    wandering iterates reach (an arch under a load just past its limit converged in 23
    iterations onto the unstable branch). Such a step fails like a non-converged one: the
    increment is halved, and past the bisections the arc-length continuation takes over.
    Only a symmetric tangent (conservative loads: no flow) without constraints is tested:
    the flow's follower forces make it non-symmetric, with complex eigenvalues in general."""
    def solve(system, *, force_scale=0.0, mechanism=False):
        return _core.static_equilibrium(system, mdot, load_factor, tol, max_iterations, force_scale, step, mechanism)
    out = model._static_newton(state, solve, mass_flow=mdot, load_factor=load_factor, max_iterations=max_iterations,
                               start=start)
    if record is not None:
        record.append(out)
    before, after = out["negative_start"], out["negative_end"]
    it, rnorm = out["iterations"], out["residual"]
    if out["converged"] and before >= 0 and after >= 0 and before != after:
        out["why"] = (f"the step crossed a critical point (the tangent's negative eigenvalues went from {before} to "
                      f"{after})")
        return False, it, rnorm, out["why"], False
    ok = bool(out["converged"]) and not out.get("refused")
    return ok, it, rnorm, "" if ok else out["why"], bool(out["singular"]) and not ok


def outcome_reason(out, max_iterations, singular_reason):
    """Why the core's static Newton (its dict ``out``) did not converge;
    ``singular_reason()`` says why its tangent is singular, in the formulation's terms."""
    it, rnorm = out["iterations"], out["residual"]
    if out["nonfinite"]:
        return "the residual is not finite"
    if out["singular"]:
        return singular_reason()
    if out["diverged"]:
        return (f"Newton diverged at iteration {it} (a correction of {out['correction']:.3g} m "
                f"or rad, beyond 10 model sizes; residual {rnorm:.3e} N)")
    return f"no convergence in {max_iterations} iterations (residual {rnorm:.3e} N)"


def newton_failure(out, *, load_factor, mass_flow, reached, ramp):
    """The error of a load stepping whose step to (``mass_flow`` [kg/s], ``load_factor``)
    failed with the outcome ``out`` (its reason ``out["why"]``) from ``reached`` (mdot,
    load factor) of the last converged step; ``ramp``: a flow continuation."""
    error = SingularMatrixError if out["singular"] else ConvergenceError
    where = (f"load factor {load_factor:.6g} (from {reached[1]:.6g})" if not ramp else
             f"mdot = {mass_flow:.6g} kg/s, load factor {load_factor:.6g} (from {reached[0]:.6g} kg/s)")
    return error(f"static equilibrium failed at {where} after {out['iterations']} iterations: {out['why']}",
                 load_factor=load_factor, iteration=out["iterations"], residual=out["residual"], mass_flow=mass_flow)


def _arc_newton(model, state, arc, tol, size, max_iterations):
    """Newton's method on the bordered system of R(q, t) = 0 and the arc-length constraint
    ``arc`` (an :class:`~pipeflex.analysis.arclength.Arc`; its ``t``, ``dq`` and ``dt``
    updated) from ``state`` (a working state of ``model``, updated in place; with
    ``arc.predict`` first moved by ``arc.dq``, the predictor): the path parameter ``arc.t``
    (which sets mdot and the load factor, affine in t) is an unknown too. The core's
    static_newton with the constraint as its border, on the model's system object
    (``size``: unused, the system's own length scale [m] is the test's). Returns (converged, iterations,
    residual norm [N], reason, singular)."""
    def solve(system, *, force_scale=0.0, mechanism=False):  # the border takes no mechanism's penalty
        out = _core.static_arc_newton(system, arc.path(), arc.w2, arc.psi2, arc.ds, arc.t, arc.dq, arc.dt, tol,
                                      max_iterations, force_scale, arc.predict)
        arc.t, arc.dq, arc.dt = out["t"], np.asarray(out["dq"]), out["dt"]
        return out
    mdot, load_factor = arc.at(arc.t)
    out = model._static_newton(state, solve, mass_flow=mdot, load_factor=load_factor, max_iterations=max_iterations)
    it, rnorm = out["iterations"], out["residual"]
    if out["converged"]:
        return True, it, rnorm, "", False
    return False, it, rnorm, out["why"], bool(out["singular"])
