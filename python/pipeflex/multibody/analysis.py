"""Static, linearised and transient analyses of a :class:`MultibodySystem` (``linearize``
and ``simulate`` are aliases of :func:`pipeflex.linearize` and :func:`pipeflex.simulate`,
the one driver of every formulation).

Time integration (C++): the index-3 equations (positions constrained exactly) with the
project's one Lie group generalised-alpha integrator (``GeneralizedAlpha`` in
``cpp/src/generalized_alpha.cpp``, Arnold & Bruls 2007 / Bruls, Cardona & Arnold 2012),
the same that integrates element models: rotations are updated as R <- exp(Dq~) R with
the step's increment Dq, so there is no rotation singularity and no normalisation
constraint.
Index 3 rather than van Voorthuizen et al.'s index-1 form (eq. 70, accelerations of the constraints)
because the position constraints then hold to the Newton tolerance at every step with
no drift stabilisation; the velocity-level drift ``max abs(C_q v)`` (not enforced) is
reported. Constraint rows are scaled by the iteration matrix's size. Newton is
modified: the sparse iteration matrix is kept over steps while the corrections contract
fast, and re-evaluated when they contract slowly.
"""
from __future__ import annotations

import warnings
from dataclasses import replace
from typing import Optional

import numpy as np  # noqa: F401

from .. import _checks
from ..analysis.static import StaticResult
from .._options import MAX_NEWTON, MAX_STEPS, NEWTON_TOL, RHO_INF, renamed
from ..results import _REGISTRY
from ..analysis.transient import TransientResult, simulate as _simulate
# the statics' constants and helpers, where they were (docs and tests name them here)
from .statics import (DEFORMATION_LIMIT, FORCE_FLOOR, RESIDUAL_TOL, _bending_force,  # noqa: F401
                      _largest_deformation, _not_converged)  # noqa: F401
from .system import MultibodyResult, MultibodyState, MultibodySystem, TimeFunction

# results saved when MultibodyResult lived here load as the class it is now
_REGISTRY[f"{__name__}:MultibodyResult"] = MultibodyResult


#: A system of bodies' static equilibrium is :func:`pipeflex.static_equilibrium`'s one
#: result type (``state``: a :class:`MultibodyState` with the joint reactions in ``lam``).
MultibodyStatic = StaticResult


def static_equilibrium(system: MultibodySystem, *, state: Optional[MultibodyState] = None,
                       mass_flow: Optional[float] = None, t: float = 0.0, load_steps: int = 1,
                       tol: float = 1e-10, max_iterations: int = 30, max_bisections: int = 8,
                       **options) -> StaticResult:
    """Static equilibrium (at rest) under the loads at time ``t``, gravity and the flow:
    :func:`pipeflex.static_equilibrium` (its load stepping, arc-length and flow
    continuation: ``options`` ``from_mass_flow``, ``path``, ``arc_steps``) from ``state``
    at time ``t`` [s].

    Loads and gravity are applied in ``load_steps`` equal increments (halved
    automatically, at most ``max_bisections`` times, when Newton fails); Newton's method
    on the coordinates and the Lagrange multipliers, converged when the increment is below
    ``tol`` times the model's size (``system.length_scale``: the assembly's largest
    extent) (or stalls at round-off within 1e3 tol).

    Step acceptance: a converged step in which a body's elastic displacement (a node's,
    in the body's frame: its reduction basis times its elastic coordinates) exceeds
    :data:`DEFORMATION_LIMIT` of the body's length is a root of the equations outside the
    floating frame's small elastic deformation; it is rejected and the step halved.

    Mechanisms (the joints leave a rigid motion of the frames free; the core's frame Gram
    matrix tells): neutral directions keep their assembly value; loads that drive one (the
    residual's generalised force on a free rigid motion above :data:`RESIDUAL_TOL` of the
    applied force level, the round-off of the joint reactions and :data:`FORCE_FLOOR` of
    the bodies' bending force scale EI / L^2) raise.

    Args:
        state: starting guess (default: the assembly configuration).
        mass_flow: mdot [kg/s] (default: the system's).
        t: time [s] at which the loads' time functions are evaluated.
        load_steps: increments of the loads and gravity.
        tol: Newton tolerance on the increment, relative to the model's size [-].
        max_iterations: Newton iterations per load step.
        max_bisections: halvings of the increment allowed in all.

    Raises:
        ValueError: bad options or a state that does not fit the system.
        ConvergenceError: with the load factor, iteration and residual where it failed;
            also when the halved steps still end beyond :data:`DEFORMATION_LIMIT` (the
            message names the body: the floating frame's small-deformation assumption).
        SingularMatrixError: the loads drive a mechanism: the residual's generalised force
            on the rigid motions the joints leave free exceeds the allowance above (no
            static equilibrium near the assembly).
    """
    from ..analysis.static import static_equilibrium as solve

    t = _checks.finite("t", t)
    if state is not None:
        system.check_state(state)
    st = replace(system.initial_state() if state is None else state, t=t)
    return solve(system, state=st, mass_flow=mass_flow, load_steps=load_steps, tol=tol,
                 max_iterations=max_iterations, max_bisections=max_bisections, **options)


def __getattr__(name):
    # MultibodyLinearization: the linearisation of a system of bodies is
    # :class:`pipeflex.Linearization` (one type for every formulation; ``state`` a
    # MultibodyState with its multipliers), imported when asked: a transient of bodies
    # loads no scipy.sparse
    if name == "MultibodyLinearization":
        from ..analysis.linearize import Linearization

        return Linearization
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def linearize(system: MultibodySystem, state: Optional[MultibodyState] = None, *,
              mass_flow: Optional[float] = None):
    """:func:`pipeflex.linearize` of a system of bodies (the same driver): about ``state``
    with its multipliers, default the static equilibrium at ``mass_flow`` mdot [kg/s]."""
    from ..analysis.linearize import linearize as _linearize

    return _linearize(system, state, mass_flow=mass_flow)


@renamed(tol="newton_tol", max_iterations="max_newton")
def simulate(system: MultibodySystem, t_end: float, *, step: float, state: Optional[MultibodyState] = None,
             mass_flow: Optional[TimeFunction] = None, n_outputs: int = 201, rho_inf: float = RHO_INF,
             newton_tol: float = NEWTON_TOL, max_newton: int = MAX_NEWTON, refresh: Optional[int] = None,
             max_steps: int = MAX_STEPS) -> TransientResult:
    """:func:`pipeflex.simulate` of a system of bodies (the same driver, generalised-alpha)
    from ``state`` (default: the assembly configuration at rest), at its time, to ``t_end``
    [s] with the step ``step`` h [s]: the result's ``bodies`` (a :class:`MultibodyResult`:
    frames, elastic coordinates, velocities, constraint drift; its accessors such as
    ``node_position`` also on the result itself). Option names and defaults as
    :func:`pipeflex.simulate`'s (pipeflex._options); ``rho_inf`` must be < 1 (the index-3
    equations need numerical damping of the multipliers). The outputs lie at whole steps:
    the interval is split into ceil((t_end - t0) / step) equal steps and ``n_outputs``
    of them, evenly spaced and rounded to steps, are kept. ``tol=`` and ``max_iterations=``
    are deprecated names of ``newton_tol`` and ``max_newton``; ``refresh`` is deprecated,
    without effect (the iteration matrix is re-evaluated when Newton contracts slowly).

    Raises:
        ValueError: bad options.
        ConvergenceError: with the time, iteration and residual where Newton failed.
    """
    if refresh is not None:
        warnings.warn("simulate(): 'refresh' is deprecated and has no effect (the iteration matrix is re-evaluated "
                      "when Newton contracts slowly)", DeprecationWarning, stacklevel=2)
    t_end = _checks.finite("t_end", t_end)
    h = _checks.positive("step", step)
    n_out = _checks.positive_int("n_outputs", n_outputs)
    max_steps = _checks.positive_int("max_steps", max_steps)
    t0 = 0.0 if state is None else float(state.t)
    if t_end <= t0:
        raise ValueError(f"t_end = {t_end} must be after the start time {t0}")
    steps = np.ceil((t_end - t0) / h - 1e-9)  # may be inf
    if not steps <= max_steps:  # refused before the output steps are laid out (the core checks again)
        raise ValueError(f"step = {h} s gives {steps:.6g} steps to t_end = {t_end} s; max_steps = {max_steps} "
                         "(raise step or max_steps, or shorten the run)")
    # the outputs at whole steps of the interval in equal steps (at most n_outputs of them)
    n_steps = max(1, int(steps))
    out_steps = np.unique(np.round(np.linspace(0, n_steps, max(n_out, 2))).astype(int))
    times = [t_end if k == n_steps else t0 + k * (t_end - t0) / n_steps for k in out_steps]
    return _simulate(system, t_end, integrator="generalized_alpha", state=state, t_start=t0, times=times,
                     mass_flow=mass_flow, progress=False, step=h, rho_inf=rho_inf, newton_tol=newton_tol,
                     max_newton=max_newton, max_steps=max_steps)
