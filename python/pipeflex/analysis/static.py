"""Static equilibrium by Newton's method with load stepping."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np
import scipy.sparse.linalg as spla

from .. import _checks, _core
from ..errors import ConvergenceError, SingularMatrixError
from ..results import Result
from ..state import State, as_core
from ._assembly import require_model, residual_and_tangent
from .eigen import describe_coordinates, null_coordinates
from .._blas import small_problems_single_threaded


@dataclass(frozen=True)
class StaticResult(Result):
    """Converged static state.

    Attributes:
        state: the equilibrium (:class:`~pipeflex.state.State`: ``q`` positions [m] /
            rotation vectors [rad] per node, relative to ``state.frame(n)``).
        iterations: total Newton iterations.
        residual: final residual norm [N].
        mass_flow: mdot [kg/s] of the equilibrium.
    """

    state: State
    iterations: int
    residual: float
    mass_flow: float


@small_problems_single_threaded
def static_equilibrium(model, *, state=None, mass_flow: Optional[float] = None, load_steps: int = 1,
                       tol: float = 1e-10, max_iterations: int = 25, max_bisections: int = 8,
                       from_mass_flow: Optional[float] = None) -> StaticResult:
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

    Raises:
        ConvergenceError: with the load factor, iteration and residual where it failed
            (attributes ``load_factor``, ``iteration``, ``residual``, ``mass_flow``: the
            flow of the failed step); :class:`~pipeflex.errors.SingularMatrixError` if
            the tangent was singular. With ``from_mass_flow``, its further attributes
            ``reached_mass_flow`` and ``reached_state`` are the flow and the state of
            the last converged step (the start if none converged; else None).

    A :class:`~pipeflex.multibody.MultibodySystem` is solved by
    :func:`pipeflex.multibody.static_equilibrium` (same options).
    """
    from ..multibody import MultibodySystem, static_equilibrium as multibody_static

    if isinstance(model, MultibodySystem):
        if from_mass_flow is not None:
            raise NotImplementedError("from_mass_flow (flow continuation) for a MultibodySystem")
        return multibody_static(model, state=state, mass_flow=mass_flow, load_steps=load_steps, tol=tol,
                                max_iterations=max(_checks.positive_int("max_iterations", max_iterations), 30))
    require_model(model)
    load_steps = _checks.positive_int("load_steps", load_steps)
    tol = _checks.positive("tol", tol)
    max_iterations = _checks.positive_int("max_iterations", max_iterations)
    max_bisections = _checks.non_negative_int("max_bisections", max_bisections)
    cold = state is None
    state = as_core(model, state)
    mdot = model.mass_flow if mass_flow is None else _checks.finite("mass_flow", mass_flow)
    if from_mass_flow is None:
        def path(t):  # load stepping at the full flow
            return mdot, t
    else:
        mdot0 = _checks.finite("from_mass_flow", from_mass_flow)

        def path(t):  # flow continuation (the loads ramped with it only from the reference configuration)
            return (mdot if t >= 1.0 else mdot0 + t * (mdot - mdot0)), (t if cold else 1.0)
    size = max(float(np.ptp(model.positions, axis=0).max()), model.total_length / max(1, len(model.elements)))
    total_iter = 0
    lf, dlf, bis = 0.0, 1.0 / load_steps, 0
    rnorm = 0.0
    while lf < 1.0 - 1e-14:
        target = min(1.0, lf + dlf)
        m_t, lf_t = path(target)
        trial = state.copy()
        ok, it, rnorm, why, singular = _newton(model, trial, m_t, lf_t, tol, size, max_iterations)
        total_iter += it
        if ok:
            state, lf = trial, target
            continue
        bis += 1
        if bis > max_bisections:
            error = SingularMatrixError if singular else ConvergenceError
            where = (f"load factor {lf_t:.6g} (from {path(lf)[1]:.6g})" if from_mass_flow is None else
                     f"mdot = {m_t:.6g} kg/s, load factor {lf_t:.6g} (from {path(lf)[0]:.6g} kg/s)")
            ramp = from_mass_flow is not None
            raise error(f"static equilibrium failed at {where} after {it} iterations: {why}",
                        load_factor=lf_t, iteration=it, residual=rnorm, mass_flow=m_t,
                        reached_mass_flow=path(lf)[0] if ramp else None,
                        reached_state=State.from_core(state, model) if ramp else None)
        dlf /= 2
    return StaticResult(State.from_core(state, model), total_iter, rnorm, mdot)


def _newton(model, state, mdot, load_factor, tol, size, max_iterations):
    load = model.load_state(mass_flow=mdot, gravity_factor=load_factor)
    # Converged already (a warm start)? Compare with the model's own force level.
    r, _ = residual_and_tangent(model, state, load, load_factor=load_factor, matrix=False)
    rnorm = float(np.linalg.norm(r))
    fscale = model.force_scale(mass_flow=mdot)
    if not np.isfinite(rnorm):  # inf <= tol * inf must not pass for convergence
        return False, 0, rnorm, "the residual is not finite", False
    if rnorm <= tol * fscale or model.n_dofs == 0:
        return True, 0, rnorm, "", False
    for it in range(1, max_iterations + 1):
        r, J = residual_and_tangent(model, state, load, load_factor=load_factor)
        rnorm = float(np.linalg.norm(r))
        if not np.isfinite(rnorm):
            return False, it, rnorm, "the residual is not finite", False
        fscale = max(fscale, rnorm)
        try:
            lu = spla.splu(J)
            dz = lu.solve(-r)
        except RuntimeError:
            free = null_coordinates(J)
            named = f"; {describe_coordinates(free, model.dof_labels)}" if len(free) else ""
            return False, it, rnorm, (f"the tangent is singular (a mechanism: missing supports, or a "
                                      f"bifurcation point{named})"), True
        if not np.all(np.isfinite(dz)):
            return False, it, rnorm, "the tangent is singular or ill-conditioned", True
        _core.add_increment(model.core, state, dz, "q")
        state.rebase(np.pi)
        if np.linalg.norm(dz, np.inf) <= tol * size or rnorm <= 1e-3 * tol * max(fscale, 1e-300) or rnorm == 0.0:
            r2, _ = residual_and_tangent(model, state, load, load_factor=load_factor, matrix=False)
            return True, it, float(np.linalg.norm(r2)), "", False
    return False, max_iterations, rnorm, f"no convergence in {max_iterations} iterations (residual {rnorm:.3e} N)", False
