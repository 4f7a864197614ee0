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
from ._assembly import residual_and_tangent


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


def static_equilibrium(model, *, state=None, mass_flow: Optional[float] = None, load_steps: int = 1,
                       tol: float = 1e-10, max_iterations: int = 25, max_bisections: int = 8) -> StaticResult:
    """Solve R(q) = 0 for the static equilibrium under loads, gravity and mass flow.

    The loads and gravity are applied in ``load_steps`` equal increments (halved
    automatically, at most ``max_bisections`` times, when Newton fails).

    Args:
        model: the :class:`~pipeflex.Model`.
        state: starting state (a :class:`~pipeflex.state.State` or ``_core.State``;
            default the reference configuration); not modified.
        mass_flow: mdot [kg/s] (default the model's).
        load_steps: number of load increments.
        tol: relative tolerance on the increment norm (to the model size) and on the
            residual (to the applied force level).
        max_iterations: Newton iterations per load step.

    Raises:
        ConvergenceError: with the load factor, iteration and residual where it failed
            (attributes ``load_factor``, ``iteration``, ``residual``, ``mass_flow``);
            :class:`~pipeflex.errors.SingularMatrixError` if the tangent was singular.

    A :class:`~pipeflex.multibody.MultibodySystem` is solved by
    :func:`pipeflex.multibody.static_equilibrium` (same options).
    """
    from ..multibody import MultibodySystem, static_equilibrium as multibody_static

    if isinstance(model, MultibodySystem):
        return multibody_static(model, state=state, mass_flow=mass_flow, load_steps=load_steps, tol=tol,
                                max_iterations=max(max_iterations, 30))
    load_steps = _checks.positive_int("load_steps", load_steps)
    tol = _checks.positive("tol", tol)
    state = as_core(model, state)
    mdot = model.mass_flow if mass_flow is None else _checks.finite("mass_flow", mass_flow)
    size = max(float(np.ptp(model.positions, axis=0).max()), model.total_length / max(1, len(model.elements)))
    total_iter = 0
    lf, dlf, bis = 0.0, 1.0 / load_steps, 0
    rnorm = 0.0
    while lf < 1.0 - 1e-14:
        target = min(1.0, lf + dlf)
        trial = state.copy()
        ok, it, rnorm, why, singular = _newton(model, trial, mdot, target, tol, size, max_iterations)
        total_iter += it
        if ok:
            state, lf = trial, target
            continue
        bis += 1
        if bis > max_bisections:
            error = SingularMatrixError if singular else ConvergenceError
            raise error(f"static equilibrium failed at load factor {target:.6g} (from {lf:.6g}) after {it} "
                        f"iterations: {why}", load_factor=target, iteration=it, residual=rnorm, mass_flow=mdot)
        dlf /= 2
    return StaticResult(State.from_core(state, model), total_iter, rnorm, mdot)


def _newton(model, state, mdot, load_factor, tol, size, max_iterations):
    load = model.load_state(mass_flow=mdot, gravity_factor=load_factor)
    # Converged already (a warm start)? Compare with the model's own force level.
    r, _ = residual_and_tangent(model, state, load, load_factor=load_factor, matrix=False)
    rnorm = float(np.linalg.norm(r))
    fscale = model.force_scale(mass_flow=mdot)
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
            return False, it, rnorm, ("the tangent is singular (a mechanism: missing supports, or a "
                                      "bifurcation point)"), True
        if not np.all(np.isfinite(dz)):
            return False, it, rnorm, "the tangent is singular or ill-conditioned", True
        _core.add_increment(model.core, state, dz, "q")
        state.rebase(np.pi)
        if np.linalg.norm(dz, np.inf) <= tol * size or rnorm <= 1e-3 * tol * max(fscale, 1e-300) or rnorm == 0.0:
            r2, _ = residual_and_tangent(model, state, load, load_factor=load_factor, matrix=False)
            return True, it, float(np.linalg.norm(r2)), "", False
    return False, max_iterations, rnorm, f"no convergence in {max_iterations} iterations (residual {rnorm:.3e} N)", False
