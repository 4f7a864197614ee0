"""Static equilibrium by Newton's method with load stepping."""
from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Optional

import numpy as np

from .. import _checks, _core
from .._lazy import loaded_instance
from ..errors import ConvergenceError, LimitPointError, SingularMatrixError
from ..results import Result
from ..state import State, as_core
from ._assembly import require_model, residual_and_tangent
from ._continuation import follow
from .._blas import pinned as blas_pinned


@dataclass(frozen=True)
class StaticResult(Result):
    """Converged static state.

    Attributes:
        state: the equilibrium (:class:`~pipeflex.state.State`: ``q`` positions [m] /
            rotation vectors [rad] per node, relative to ``state.frame(n)``).
        iterations: total Newton iterations.
        residual: final residual norm [N].
        mass_flow: mdot [kg/s] of the equilibrium.
        limit_points: load factors [-] (path parameters t with a flow ramp) of the limit
            points that arc-length continuation passed on the way (snap-through); empty
            when the load stepping converged.
    """

    state: State
    iterations: int
    residual: float
    mass_flow: float
    limit_points: tuple = ()


@blas_pinned
def static_equilibrium(model, *, state=None, mass_flow: Optional[float] = None, load_steps: int = 1,
                       tol: float = 1e-10, max_iterations: int = 30, max_bisections: int = 8,
                       from_mass_flow: Optional[float] = None, path: str = "auto",
                       arc_steps: int = 200) -> StaticResult:
    """Solve R(q) = 0 for the static equilibrium under loads, gravity and mass flow.

    The loads and gravity are applied in ``load_steps`` equal increments (halved
    automatically, at most ``max_bisections`` times, when Newton fails).

    Flow continuation: with ``from_mass_flow`` the flow is ramped from that value to
    ``mass_flow`` in the same increments (and the same halving): a path parameter
    t = 0 ... 1 sets the flow ``from_mass_flow + t (mass_flow - from_mass_flow)`` and the
    load factor, which is t from the reference configuration (no ``state``: loads and
    flow are ramped together) and 1 from a given ``state``, which is then taken to be
    the equilibrium at ``from_mass_flow`` under the full loads (e.g. a previous
    result's ``state``). Without ``from_mass_flow`` the flow is ``mass_flow`` throughout
    and only the loads are stepped.

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

    Args:
        model: the :class:`~pipeflex.Model`.
        state: starting state (a :class:`~pipeflex.state.State` or ``_core.State``;
            default the reference configuration); not modified.
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

    A :class:`~pipeflex.CoupledSystem` is solved by :func:`pipeflex.coupled.static_equilibrium`
    (``load_steps``, ``max_bisections``, ``tol``, ``max_iterations``; not ``path``, ``from_mass_flow``).
    A :class:`~pipeflex.multibody.MultibodySystem` is solved by
    :func:`pipeflex.multibody.static_equilibrium` (same options).
    """
    own = getattr(model, "_static", None)  # a system with its own solver (pipeflex.CoupledSystem)
    if own is not None:
        if path not in ("auto", "load") or from_mass_flow is not None:
            raise ValueError("path='arclength' and from_mass_flow (the arc-length and flow continuations) run on "
                             "element models: a CoupledSystem steps its loads (path='load')")
        return own(state=state, mass_flow=mass_flow, load_steps=load_steps, tol=tol, max_iterations=max_iterations,
                   max_bisections=max_bisections)

    if path not in ("auto", "load", "arclength"):
        raise ValueError(f"path must be 'auto', 'load' or 'arclength', got {path!r}")
    if loaded_instance(model, "pipeflex.multibody.system", "MultibodySystem"):
        from ..multibody import static_equilibrium as multibody_static

        if path == "arclength" or from_mass_flow is not None:
            raise ValueError("path='arclength' and from_mass_flow (the arc-length and flow continuations) run on "
                             "element models: a MultibodySystem steps its loads (path='load')")
        return multibody_static(model, state=state, mass_flow=mass_flow, load_steps=load_steps, tol=tol,
                                max_iterations=max_iterations,
                                max_bisections=max_bisections)
    require_model(model)
    load_steps = _checks.positive_int("load_steps", load_steps)
    tol = _checks.positive("tol", tol)
    max_iterations = _checks.positive_int("max_iterations", max_iterations)
    max_bisections = _checks.non_negative_int("max_bisections", max_bisections)
    arc_steps = _checks.positive_int("arc_steps", arc_steps)
    cold = state is None
    state = as_core(model, state)
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
    size = model.length_scale
    solve = dict(tol=tol, size=size, max_iterations=max_iterations)
    total_iter = 0
    if path == "arclength" and model.n_dofs:
        ok, it, rnorm, why, singular = _newton(model, state, *at(0.0), tol, max_iterations)
        if not ok and cold and mdot != 0.0 and from_mass_flow is None:  # ramp the flow with the loads
            ok, state, along = True, as_core(model, None), (lambda t: (t * mdot, t))
        if not ok:
            raise (SingularMatrixError if singular else ConvergenceError)(
                f"static equilibrium failed at the start of the continuation (t = 0) after {it} iterations: {why}",
                load_factor=at(0.0)[1], iteration=it, residual=rnorm, mass_flow=at(0.0)[0])
        return _continue(model, state, 0.0, along, solve, arc_steps, 1.0 / load_steps, it, mdot, None)

    def step(trial, t):
        nonlocal total_iter
        outcome = _newton(model, trial, *at(t), tol, max_iterations, step=True)
        total_iter += outcome[1]
        return outcome[0], outcome

    way = follow(step, state, start=0.0, end=1.0, steps=load_steps, halving="step", max_failures=max_bisections,
                 steps_name="load_steps")
    _, it, rnorm, why, singular = way.outcome
    state, lf = way.state, way.t
    if not way.done:
        m_t, lf_t = at(way.target)
        error = SingularMatrixError if singular else ConvergenceError
        where = (f"load factor {lf_t:.6g} (from {at(lf)[1]:.6g})" if from_mass_flow is None else
                 f"mdot = {m_t:.6g} kg/s, load factor {lf_t:.6g} (from {at(lf)[0]:.6g} kg/s)")
        ramp = from_mass_flow is not None
        failure = error(f"static equilibrium failed at {where} after {it} iterations: {why}",
                        load_factor=lf_t, iteration=it, residual=rnorm, mass_flow=m_t,
                        reached_mass_flow=at(lf)[0] if ramp else None,
                        reached_state=State.from_core(state, model) if ramp else None)
        if path == "load" or (path == "auto" and ramp):
            raise failure
        secant = _core.reduce(model.core, np.asarray(state.q) - np.asarray(start.q)) / lf if lf > 0 else None
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
                         total_iter, mdot, failure, secant)
    return StaticResult(State.from_core(state, model), total_iter, rnorm, mdot)


def _continue(model, state, t0, along, solve, arc_steps, dt0, total_iter, mdot, failure, secant=None):
    """Arc-length continuation from the converged ``state`` at t0 to t = 1; ``failure``
    the load stepping's error (re-raised, with the continuation's reason, if the
    continuation fails too) or None."""
    from . import arclength

    def newton(trial, arc):
        return _arc_newton(model, trial, arc, solve["tol"], solve["size"], solve["max_iterations"])

    way = arclength.follow(model, state, t0, at=along, newton=newton, size=solve["size"], tol=solve["tol"],
                           max_iterations=solve["max_iterations"], max_steps=arc_steps, dt0=dt0,
                           secant=secant)
    total_iter += way.iterations
    limits = tuple(float(p.t) for p in way.limits)
    if way.end is not None:
        end = way.end.state.copy()
        # onto t = 1 exactly
        ok, it, rnorm, why, _ = _newton(model, end, *along(1.0), solve["tol"], solve["max_iterations"])
        if ok:
            return StaticResult(State.from_core(end, model), total_iter + it, rnorm, mdot, limits)
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
            reached_state=State.from_core(top.state, model), limit_points=limits)
    if failure is None:
        raise ConvergenceError(f"arc-length continuation failed: {way.why}", load_factor=along(way.last.t)[1]
                               if way.last else None, iteration=total_iter, residual=way.residual)
    failure.args = (f"{failure.args[0]}; arc-length continuation from load factor {along(t0)[1]:.6g} "
                    f"failed too: {way.why}",)
    raise failure


def _newton(model, state, mdot, load_factor, tol, max_iterations, step=False):
    """Newton's method on R(q) = 0 at (mdot, load_factor) from ``state`` (updated in place):
    the core's one static Newton (``static_equilibrium`` on the model's system). Converged
    when the increment is below ``tol`` model sizes (``model.length_scale`` [m]) or the
    residual below 1e-3 ``tol`` times the force level; a start within ``tol`` of the
    model's force level is converged already (a warm start, no iteration). Returns (converged, iterations, residual norm [N], reason,
    singular).

    ``step``: the solve is a load step from the equilibrium ``state``, accepted only if the
    tangent's inertia (its count of negative eigenvalues) at the end is the start's. Along
    a regular equilibrium path the count is constant; it changes only where an eigenvalue
    crosses zero, at a limit or bifurcation point. A step across one is not a step along
    the path: past a limit point the load has no nearby equilibrium and Newton, started
    from a nearly singular tangent, lands (if at all) on whatever equilibrium its
    wandering iterates reach (an arch under a load just past its limit converged in 23
    iterations onto the unstable branch). Such a step fails like a non-converged one: the
    increment is halved, and past the bisections the arc-length continuation takes over.
    Only a symmetric tangent (conservative loads: no flow) is tested: the flow's follower
    forces make it non-symmetric, with complex eigenvalues in general."""
    if model.n_dofs == 0:
        return True, 0, 0.0, "", False
    fscale = model.force_scale(mass_flow=mdot)
    load = model.load_state(mass_flow=mdot, gravity_factor=load_factor)
    out = _core.static_equilibrium(_core.element_system(model.core, state, load), mdot, load_factor, tol,
                                   max_iterations, fscale, step)
    before, after = out["negative_start"], out["negative_end"]
    if out["converged"] and before >= 0 and after >= 0 and before != after:
        return False, out["iterations"], out["residual"], (
            f"the step crossed a critical point (the tangent's negative eigenvalues went from {before} to {after})"), False
    return _outcome(out, max_iterations, lambda: _singular_reason(model, state, load, load_factor))


def _outcome(out, max_iterations, singular_reason):
    """(converged, iterations, residual norm [N], reason, singular) of the core's static
    Newton result ``out``; ``singular_reason()`` names the free coordinates."""
    it, rnorm = out["iterations"], out["residual"]
    if out["converged"]:
        return True, it, rnorm, "", False
    if out["nonfinite"]:
        return False, it, rnorm, "the residual is not finite", False
    if out["singular"]:
        return False, it, rnorm, singular_reason(), True
    if out["diverged"]:
        return False, it, rnorm, (f"Newton diverged at iteration {it} (a correction of {out['correction']:.3g} m "
                                  f"or rad, beyond 10 model sizes; residual {rnorm:.3e} N)"), False
    return False, it, rnorm, f"no convergence in {max_iterations} iterations (residual {rnorm:.3e} N)", False


def _singular_reason(model, state, load, load_factor):
    """Why the tangent at ``state`` is singular, naming its free coordinates."""
    from .eigen import describe_coordinates, null_coordinates

    _, J = residual_and_tangent(model, state, load, load_factor=load_factor)
    free = null_coordinates(J)
    named = f"; {describe_coordinates(free, model.dof_labels)}" if len(free) else ""
    return f"the tangent is singular (a mechanism: missing supports, or a bifurcation point{named})"


def _arc_newton(model, state, arc, tol, size, max_iterations):
    """Newton's method on the bordered system of R(q, t) = 0 and the arc-length constraint
    ``arc`` (an :class:`~pipeflex.analysis.arclength.Arc`; its ``t``, ``dq`` and ``dt``
    updated): the path parameter ``arc.t`` (which sets mdot and the load factor, affine in
    t) is an unknown too. The core's static_newton with the constraint as its border.
    Returns (converged, iterations, residual norm [N], reason, singular)."""
    (m0, l0), (m1, l1) = arc.at(0.0), arc.at(1.0)
    path = (m0, m1 - m0, l0, l1 - l0)
    mdot, load_factor = arc.at(arc.t)
    load = model.load_state(mass_flow=mdot, gravity_factor=load_factor)
    out = _core.static_arc_newton(model.core, state, load, path, arc.w2, arc.psi2, arc.ds, arc.t, arc.dq, arc.dt,
                                  tol, size, model.force_scale(mass_flow=mdot), max_iterations)
    arc.t, arc.dq, arc.dt = out["t"], np.asarray(out["dq"]), out["dt"]

    def singular_reason():
        mdot, load_factor = arc.at(arc.t)
        return _singular_reason(model, state, model.load_state(mass_flow=mdot, gravity_factor=load_factor),
                                load_factor)
    return _outcome(out, max_iterations, singular_reason)
