"""Steady rotation about a hinge: the relative equilibrium of a spinning structure.

The motion sought is a rigid rotation at constant rate omega about the hinge axis a
through the hinge point x_h, carrying a fixed deformation: node i moves with
    x_dot = omega a x (x - x_h),  x_ddot = omega^2 a x (a x (x - x_h)),
and turns with spatial angular velocity omega a. Unknowns: the reduced coordinates,
except the hinge angle (arbitrary), and omega; equations: R(q, v, a) = 0, whose hinge
row is the balance of moments about the axis. The core's one static Newton
(``static_newton``, cpp/src/rigid_rotation.cpp) with the analytic tangent
K + omega C Av + omega^2 M Aa and omega as its border (omega's column in place of the
hinge angle's), with continuation in the mass flow from rest.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from .. import _checks, _core
from ..errors import ConvergenceError, SingularMatrixError
from ..results import Result
from ..state import State, as_core
from ._assembly import require_model
from .._blas import small_problems_single_threaded


# below this many coordinates the Newton systems are solved densely (cheaper than sparse
# bookkeeping); above, sparsely (linear in the model size): the core's crossover
DENSE_BELOW = _core.DENSE_LU_BELOW


@dataclass(frozen=True)
class SteadyRotation(Result):
    """Steady rotation found by :func:`steady_rotation`.

    Attributes:
        omega: angular velocity [rad/s] about the hinge axis (right-hand rule).
        state: the deformed, rotating state (:class:`~pipeflex.state.State`: positions,
            rotation vectors, velocities, accelerations of the rigid rotation).
        axis: (3,) unit hinge axis [-]; hinge_node: its node.
        iterations: Newton iterations; residual: final residual norm [N].
    """

    omega: float
    state: State
    axis: np.ndarray
    hinge_node: int
    iterations: int
    residual: float


def _hinge(model):
    """The node with one free rotation and fixed position (the hinge), and its axis
    (linear in the model size: only nodes with one reduced coordinate are looked at)."""
    nodes = np.fromiter((n for n, _ in model.dof_labels), dtype=int, count=model.n_dofs)
    single = np.bincount(nodes, minlength=model.n_nodes)[nodes] == 1
    basis = model.basis
    found = []
    for dof in np.flatnonzero(single):
        n = int(nodes[dof])
        t = basis[6 * n:6 * n + 6, [dof]].toarray()[:, 0]
        if np.allclose(t[:3], 0.0):
            found.append((n, t[3:] / np.linalg.norm(t[3:]), int(dof)))
    if len(found) != 1:
        raise ValueError(f"steady_rotation needs exactly one hinge (a node with fixed position and one "
                         f"free rotation); this model has {len(found)}")
    return found[0]


@small_problems_single_threaded
def steady_rotation(model, *, omega_guess: Optional[float] = None, mass_flow: Optional[float] = None,
                    state=None, continuation_steps: int = 4, tol: float = 1e-12,
                    max_iterations: int = 30) -> SteadyRotation:
    """Steady rotation of a model about its single hinge under the prescribed mass flow.

    Args:
        model: a model with exactly one hinge (e.g. :func:`pipeflex.scenes.sprinkler`).
        omega_guess: starting angular velocity [rad/s] (default: from a rigid-body balance
            of the undeformed structure at the first continuation step).
        mass_flow: mdot [kg/s] (default the model's).
        state: starting deformation (default the reference configuration).
        continuation_steps: the flow is raised from mdot/steps to mdot in this many steps.
        tol: relative tolerance on the Newton correction (to the model size and to omega);
            a correction within 1e3 tolerances that stops halving is taken as converged
            (round-off; ``pipeflex.analysis._newton.converged``).
        max_iterations: Newton iterations per continuation step.

    Raises:
        ValueError: no or several hinges; bad options.
        ConvergenceError: Newton failed (the message gives the step and the residual;
            attributes ``mass_flow`` of the continuation step, ``iteration``, ``residual``).
    """
    require_model(model)
    node, axis, hinge_dof = _hinge(model)
    steps = _checks.positive_int("continuation_steps", continuation_steps)
    tol = _checks.positive("tol", tol)
    max_iterations = _checks.positive_int("max_iterations", max_iterations)
    mdot = model.mass_flow if mass_flow is None else _checks.finite("mass_flow", mass_flow)
    omega = np.nan if omega_guess is None else _checks.finite("omega_guess", omega_guess)
    st = as_core(model, state)
    size = max(float(np.ptp(model.positions, axis=0).max()), 1e-3)
    out = _core.steady_rotation(model.core, st, model.load_state(mass_flow=mdot), node, hinge_dof, axis, omega,
                                size, steps, tol, max_iterations, DENSE_BELOW)
    if not out["converged"]:
        k, m_k, w, rnorm = out["step"], out["mass_flow"], out["omega"], out["residual"]
        if out["singular"]:
            it = out["step_iterations"]
            raise SingularMatrixError(f"steady_rotation: singular Jacobian at flow step {k}/{steps}, "
                                      f"iteration {it} (omega = {w:.6g} rad/s)", iteration=it,
                                      residual=rnorm, mass_flow=m_k)
        raise ConvergenceError(f"steady_rotation: no convergence at flow step {k}/{steps} "
                               f"(mdot = {m_k:.6g} kg/s) after {out['step_iterations']} iterations; "
                               f"residual {rnorm:.3e} N, omega = {w:.6g} rad/s", iteration=out["step_iterations"],
                               residual=rnorm, mass_flow=m_k)
    return SteadyRotation(float(out["omega"]), State.from_core(st, model), axis, node, int(out["iterations"]),
                          float(out["residual"]))
