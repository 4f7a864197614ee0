"""Steady rotation about a hinge: the relative equilibrium of a spinning structure.

The motion sought is a rigid rotation at constant rate omega about the hinge axis a
through the hinge point x_h, carrying a fixed deformation: node i moves with
    x_dot = omega a x (x - x_h),  x_ddot = omega^2 a x (a x (x - x_h)),
and turns with spatial angular velocity omega a. Unknowns: the reduced coordinates,
except the hinge angle (arbitrary), and omega; equations: R(q, v, a) = 0, whose hinge
row is the balance of moments about the axis. The core's one static Newton
(``static_newton``; the equations in cpp/src/rigid_rotation.cpp, the one driver of every
system in cpp/src/rotating_systems.cpp) with the analytic tangent
K + omega C Av + omega^2 M Aa and omega as its border (omega's column in place of the
hinge angle's), one solve per step of the continuation in the mass flow from rest
(:func:`_flow_continuation`: a step that fails or lands on another branch is bisected).

A :class:`~pipeflex.multibody.MultibodySystem` or a :class:`~pipeflex.CoupledSystem`
turns about its one hinge: a body hinged to the ground (or, in a coupled system, an
element hinge). Its bodies move rigidly with the rotation too (frame r_dot =
omega a x (r - x_h), spatial angular velocity omega a, modal rates 0), and the same
Newton runs on the bordered KKT matrix of the joints and couplings
(cpp/src/rotating_systems.cpp); the result is the same :class:`SteadyRotation`, with the bodies' state.

Why only a hinge to the ground: everything turns. A part turning on a hinge to another
flexible part (a rotor hinged to a flexible stand, a body hinged to a body) is not in a
relative equilibrium in general: the standing part carries the rotor's hinge reactions,
which turn with the rotor, so it deforms periodically in the ground frame and is not
steady in the rotating one either. (Only an axisymmetric rotor, whose reactions do not
turn, has such a state; simulate it with :func:`pipeflex.simulate`.)
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from .. import _checks, _core
from ..errors import ConvergenceError, SingularMatrixError
from ..results import Result
from ..state import State
from ._continuation import follow
from ._protocol import require_system
from .._blas import pinned as blas_pinned


# below this many coordinates the Newton systems are solved densely (cheaper than sparse
# bookkeeping); above, sparsely (linear in the model size): the core's crossover
DENSE_BELOW = _core.DENSE_LU_BELOW


@dataclass(frozen=True)
class SteadyRotation(Result):
    """Steady rotation found by :func:`steady_rotation`, of every formulation.

    Attributes:
        omega: angular velocity [rad/s] about the hinge axis (right-hand rule).
        state: the element model's deformed, rotating :class:`~pipeflex.state.State`
            (positions, rotation vectors, velocities, accelerations of the rigid rotation);
            None for bodies alone.
        axis: (3,) unit hinge axis [-].
        hinge_node: the element hinge's node (-1 for a body's hinge).
        iterations: Newton iterations over all flow steps (bisected ones included);
            residual: final residual norm [N].
        body_state: the bodies' :class:`~pipeflex.multibody.MultibodyState` (frames, modal
            amplitudes, the rotation's rates, joint multipliers); None without bodies.
        coupling_forces: the couplings' multipliers [N, N m] (empty without couplings).
        point: (3,) a point of the hinge axis [m].
        hinge: which hinge ("element node i", or a body joint's name).
    """

    omega: float
    state: Optional[State]
    axis: np.ndarray
    hinge_node: int
    iterations: int
    residual: float
    body_state: object = None
    coupling_forces: np.ndarray = field(default_factory=lambda: np.zeros(0))
    point: Optional[np.ndarray] = None
    hinge: str = ""


#: The steady rotation of a system with bodies: :class:`SteadyRotation` (one type for every
#: formulation).
SystemSteadyRotation = SteadyRotation


@blas_pinned
def steady_rotation(model, *, omega_guess: Optional[float] = None, mass_flow: Optional[float] = None,
                    state=None, continuation_steps: int = 4, tol: float = 1e-12,
                    max_iterations: int = 30):
    """Steady rotation of a system about its single hinge under the prescribed mass flow.

    Args:
        model: a model with exactly one hinge (e.g. :func:`pipeflex.scenes.sprinkler`);
            or a :class:`~pipeflex.multibody.MultibodySystem` with one body hinged to the
            ground, or a :class:`~pipeflex.CoupledSystem` with one such body or one element
            hinge (e.g. :func:`pipeflex.scenes.sprinkler_on_hub`): the same driver, the
            result holds the bodies' state and the couplings' forces too.
        omega_guess: starting angular velocity [rad/s] (default: from a rigid-body balance
            of the undeformed structure at the first continuation step: the moment about
            the hinge).
        mass_flow: mdot [kg/s] (default the model's).
        state: starting deformation (default the reference configuration); of a coupled
            system a :class:`~pipeflex.coupled.CoupledStatic`, a
            :class:`~pipeflex.coupled.CoupledState` or a :class:`SteadyRotation`, of bodies
            a :class:`~pipeflex.multibody.MultibodyState` or a :class:`SteadyRotation`.
        continuation_steps: the flow is raised from mdot/steps to mdot in this many steps
            (a step whose Newton fails, or whose omega falls more than ``OMEGA_JUMP`` = 0.5
            of its prediction away, i.e. on another branch of steady states, is bisected, up
            to ``MAX_CONTINUATION_FAILURES`` failed solves; the prediction is the last step's
            omega scaled with the flow, so the first step, from ``omega_guess`` or the rigid
            balance, is not checked).
        tol: relative tolerance on the Newton correction (to the model size and to omega);
            a correction within 1e3 tolerances that stops halving is taken as converged
            (round-off; the core's static_newton, as every static analysis).
        max_iterations: Newton iterations per solve (a flow step, or a bisection of one).

    Returns:
        :class:`SteadyRotation` (of a system with bodies also its ``body_state``,
        ``coupling_forces``, ``point`` and ``hinge``).

    Raises:
        ValueError: no or several hinges (named), or only hinges between two bodies (no
            steady rotation in general: see the module doc); mass_flow = 0 (no flow, no
            rotation); bad options.
        ConvergenceError: Newton failed (the message gives the step and the residual;
            attributes ``mass_flow`` of the continuation step, ``iteration``, ``residual``).
    """
    require_system(model)
    name, point, axis, body, node, dof = model._rotation_hinge()
    steps, tol, max_iterations, mdot, omega = _options(model, omega_guess, mass_flow, continuation_steps, tol,
                                                       max_iterations)
    # (a state foreign to the system: its error here, before the continuation)
    constrained = model._system(state).n_constraints > 0

    def solve_at(state, m, guess):
        system = model._system(state, mass_flow=m)
        out = _core.steady_rotation(system, m, point, axis, body, node, dof, guess, tol, max_iterations, DENSE_BELOW)
        return out, model._state_of(system)

    singular = ("singular Jacobian" if not constrained else
                f"singular bordered KKT matrix (hinge {name}: a mechanism the hinge does not turn, or a motion "
                f"locked twice)")
    end, iterations, out = _flow_continuation(solve_at, state, omega, mdot, steps, singular=singular)
    return SteadyRotation(float(end.omega), axis=axis, hinge_node=node, iterations=iterations,
                          residual=float(out["residual"]), point=point, hinge=name,
                          **{"coupling_forces": np.zeros(0), **model._steady_rotation_parts(end.state)})


def _flow_continuation(solve_at, state, omega, mdot, steps, *, singular):
    """steady_rotation's continuation in the mass flow from 0 to ``mdot`` in ``steps``
    scheduled steps (``_continuation.follow``, interval halving). ``solve_at(state, m,
    guess) -> (outcome dict, state)`` runs the core's Newton (one flow step) at the flow m
    from ``state`` (the system's user-level state, not changed) with omega starting at ``guess``: the last
    steady state's omega scaled with the flow (the first step: ``omega``, NaN for the rigid
    balance). A failed step, or one whose omega is off the path (:func:`_on_the_path`), is
    bisected. Returns (the last point, Newton iterations in all, its outcome); raises
    ConvergenceError or SingularMatrixError (``singular`` names the matrix) otherwise."""
    iterations = [0]

    def solve(trial, m):
        predicted = trial.mass_flow != 0.0  # (else the user's guess, or the rigid balance)
        guess = trial.omega * m / trial.mass_flow if predicted else trial.omega
        out, trial.state = solve_at(trial.state, m, guess)
        iterations[0] += out["iterations"]
        ok = out["converged"] and (not predicted or _on_the_path(out["omega"], guess))
        trial.omega, trial.mass_flow = float(out["omega"]), m
        return ok, (out, m, guess)

    way = follow(solve, _Spin(state, omega, 0.0), start=0.0, end=mdot, steps=steps, halving="interval",
                 max_failures=MAX_CONTINUATION_FAILURES)
    if way.done:
        return way.state, iterations[0], way.outcome[0]
    out, m_k, guess = way.outcome
    w, rnorm, it = out["omega"], out["residual"], out["iterations"]
    k = min(int(np.floor(way.t / mdot * steps + 1e-9)) + 1, steps) if mdot != 0.0 else 1
    scheduled = mdot * k / steps
    where = (f"flow step {k}/{steps} (mdot = {scheduled:.6g} kg/s; the last steady state at {way.t:.6g} kg/s, "
             f"{way.failures} failed solves, the last at {m_k:.6g} kg/s)")
    if out["singular"]:
        raise SingularMatrixError(f"steady_rotation: {singular} at {where}, iteration {it} (omega = {w:.6g} rad/s)",
                                  iteration=it, residual=rnorm, mass_flow=scheduled)
    if out["converged"]:
        raise ConvergenceError(f"steady_rotation: no steady state on the path at {where}: Newton converged to "
                               f"omega = {w:.6g} rad/s, off the path's {guess:.6g} rad/s (another branch)",
                               iteration=it, residual=rnorm, mass_flow=scheduled)
    raise ConvergenceError(f"steady_rotation: no convergence at {where} after {it} iterations; residual "
                           f"{rnorm:.3e} N, omega = {w:.6g} rad/s", iteration=it, residual=rnorm,
                           mass_flow=scheduled)


#: Failed Newton solves (each bisecting its flow step) before steady_rotation gives up.
MAX_CONTINUATION_FAILURES = 16
#: How far a flow step's converged omega may fall from its prediction (the last steady
#: state's omega scaled with the flow speed) as a fraction of it: further, Newton has
#: jumped to another branch of steady states (a two-element semicircle in 4 flow steps
#: landed on 0.11 rad/s, in 2 steps on -6.1 rad/s; in 6 or more on 4.92, beside the
#: finer meshes' 5.1-5.2), and the step is bisected instead.
OMEGA_JUMP = 0.5


def _on_the_path(omega, predicted):
    """Whether a flow step's omega continues the path from its prediction (OMEGA_JUMP); a
    prediction of 0 (a structure at rest on the path) admits any omega."""
    return predicted == 0.0 or abs(omega - predicted) <= OMEGA_JUMP * abs(predicted)


@dataclass
class _Spin:
    """A point of steady_rotation's continuation: the system's user-level state (None: the
    model's default start; not changed: each solve starts on a copy), omega [rad/s] and the
    mass flow [kg/s] it holds at (omega: the guess before the first)."""

    state: object
    omega: float
    mass_flow: float

    def copy(self):
        return _Spin(self.state, self.omega, self.mass_flow)


def _options(model, omega_guess, mass_flow, continuation_steps, tol, max_iterations):
    """steady_rotation's options checked: (steps, tol, max_iterations, mdot, omega_guess or NaN)."""
    steps = _checks.positive_int("continuation_steps", continuation_steps)
    tol = _checks.positive("tol", tol)
    max_iterations = _checks.positive_int("max_iterations", max_iterations)
    mdot = model.mass_flow if mass_flow is None else _checks.finite("mass_flow", mass_flow)
    if mdot == 0.0:  # omega's column of the Jacobian vanishes: a singular matrix, not an answer
        hint = f" (the model's is {model.mass_flow:g} kg/s: leave mass_flow out)" if model.mass_flow != 0.0 else ""
        raise ValueError("mass_flow = 0 kg/s: no flow, no rotation. steady_rotation finds the rate at which the "
                         "flow's reaction moment about the hinge balances; without flow the structure rests "
                         f"(omega = 0) or spins freely at any rate: give mass_flow != 0 [kg/s]{hint}")
    omega = np.nan if omega_guess is None else _checks.finite("omega_guess", omega_guess)
    return steps, tol, max_iterations, mdot, omega


def hinge_of(name: str, *, bodies, model=None):
    """The one hinge of a system with bodies (named ``name`` in the errors), for
    :func:`steady_rotation`: (hinge name, point [m], unit axis, body or -1, -1, element
    coordinate or -1): a joint of ``bodies`` (a :class:`~pipeflex.multibody.MultibodySystem`)
    of kind hinge to the ground, or an element node of ``model`` (a coupled system's) with
    fixed position and one free rotation. ValueError if none or several."""
    found = []
    for jt in bodies.joints:
        if jt.kind == "hinge" and jt.b is None:
            axis = np.asarray(jt.ref["A_ground"]) @ np.asarray(jt.ref["axis_b"])
            found.append((jt.name, np.array(jt.ref["p_ground"], float), axis / np.linalg.norm(axis), int(jt.a[0]),
                          -1, -1))
    if model is not None:
        positions = np.asarray(model.positions, float)
        for node, axis, dof in model._element_hinges():
            found.append((f"element node {node}", positions[node].copy(), axis, -1, -1, dof))  # (the point)
    if not found:
        between = [jt.name for jt in bodies.joints if jt.kind == "hinge" and jt.b is not None]
        if between:
            raise ValueError(f"steady_rotation needs a hinge to the ground; this {name}'s hinges "
                             f"join two bodies ({', '.join(between)}): the standing body would carry the turning "
                             f"body's reactions, which turn with it, so there is no steady rotation in general "
                             f"(simulate it with pipeflex.simulate)")
    if len(found) != 1:
        where = "" if not found else ": " + ", ".join(f[0] for f in found)
        element = ", or an element node with fixed position and one free rotation" if model is not None else ""
        raise ValueError(f"steady_rotation needs exactly one hinge (a body hinged to the ground{element}); "
                         f"this {name} has {len(found)}{where}")
    return found[0]
