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
from dataclasses import dataclass, replace
from typing import Optional, Tuple

import numpy as np

from .. import _checks, _core
from ..analysis._continuation import follow
from .._options import MAX_NEWTON, MAX_STEPS, NEWTON_TOL, RHO_INF, renamed
from ..errors import ConvergenceError, SingularMatrixError
from ..results import _REGISTRY, Result
from ..analysis.linearize import Linearization, linearize as _linearize
from ..analysis.transient import TransientResult, simulate as _simulate
from .system import MultibodyResult, MultibodyState, MultibodySystem, TimeFunction

# results saved when MultibodyResult lived here load as the class it is now
_REGISTRY[f"{__name__}:MultibodyResult"] = MultibodyResult


#: :func:`static_equilibrium` refuses a converged state whose residual exceeds this
#: fraction of the applied force level and the round-off of the stiffest forces
#: (converged solves reach either; a loaded mechanism's neutral direction, left alone,
#: keeps a residual of order the load).
RESIDUAL_TOL = 1e-6

#: The absolute floor of the same judgement, relative to the bodies' bending force scale
#: (the largest EI / L^2): a generalised force that would bend a body by less than this
#: fraction of its length is round-off, not a load that drives a mechanism.
FORCE_FLOOR = 1e3 * float(np.finfo(float).eps)

#: The floating frame's small elastic deformation: a converged static step in which a node
#: of a body moves elastically, in the body's frame, by more than this fraction of the
#: body's length is rejected (and halved), an equilibrium of the equations far outside the
#: model's validity (the bodies' reduction bases are linear).
DEFORMATION_LIMIT = 0.5


@dataclass(frozen=True)
class MultibodyStatic(Result):
    """Converged static state.

    Attributes:
        state: the equilibrium, with the joint reactions in ``state.lam``.
        iterations: total Newton iterations.
        residual: final residual norm [N].
        mass_flow: mdot [kg/s] of the equilibrium.
    """

    state: MultibodyState
    iterations: int
    residual: float
    mass_flow: float


def _bending_force(system: MultibodySystem) -> float:
    """The bodies' bending force scale [N]: the largest EI / L^2 (either bending stiffness,
    L the body's length), the force that bends a body by about its length."""
    return max(max(b.section.EI, b.section.EIz) / b.length**2 for b in system.bodies)


def _largest_deformation(system: MultibodySystem, state: MultibodyState) -> Tuple[float, int]:
    """The largest elastic displacement of a node in its body's frame, Phi_u (eta - eta0),
    as a fraction of that body's length, and the body."""
    worst, body = 0.0, 0
    for j, b in enumerate(system.bodies):
        u = (b.basis @ (system.eta(state, j) - b.eta0)).reshape(-1, 6)[:, :3]
        d = float(np.sqrt((u * u).sum(axis=1)).max(initial=0.0)) / b.length
        if not d <= worst:  # NaN too
            worst, body = d, j
    return worst, body


def static_equilibrium(system: MultibodySystem, *, state: Optional[MultibodyState] = None,
                       mass_flow: Optional[float] = None, t: float = 0.0, load_steps: int = 1,
                       tol: float = 1e-10, max_iterations: int = 30, max_bisections: int = 8) -> MultibodyStatic:
    """Static equilibrium (at rest) under the loads at time ``t``, gravity and the flow.

    Loads and gravity are applied in ``load_steps`` equal increments (halved
    automatically, at most ``max_bisections`` times, when Newton fails: the one
    continuation, :func:`pipeflex.analysis._continuation.follow`, as
    :func:`pipeflex.static_equilibrium`'s); Newton's method on the coordinates and the
    Lagrange multipliers, converged when the increment is below ``tol`` times the model's
    size (``system.length_scale``: the assembly's largest extent) (or stalls at round-off
    within 1e3 tol).

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
    steps = _checks.positive_int("load_steps", load_steps)
    tol = _checks.positive("tol", tol)
    max_iterations = _checks.positive_int("max_iterations", max_iterations)
    max_bisections = _checks.non_negative_int("max_bisections", max_bisections)
    t = _checks.finite("t", t)
    mdot = system.mass_flow if mass_flow is None else _checks.finite("mass_flow", mass_flow)
    if state is not None:
        system.check_state(state)
    st = replace(system.initial_state() if state is None else state.copy(), t=t)
    st.v[:] = 0.0
    st.a[:] = 0.0
    # the applied force level (loads, gravity, flow at the start, multipliers 0), to judge
    # the residual along the free motions
    start = replace(st, lam=np.zeros_like(st.lam))
    applied = float(np.abs(system.evaluate(start, mass_flow=mdot, tangent=False, jacobian=False)[0]).max(initial=0.0))
    floor = FORCE_FLOOR * _bending_force(system)
    core = system.core
    total = 0
    rejected = None  # the last step rejected by the acceptance test: (load factor, deformation, body)
    # The core's Newton (static_newton: one sparse LU of the KKT matrix per iteration, the
    # equations the integrator uses). A mechanism's KKT matrix is singular: the frames' free
    # motions are then penalised (not the residual) and the corrections filtered so that a
    # free motion without stiffness keeps its value; the loads drive it if the residual under
    # the full loads has a generalised force on it (driven): then no step, however short, reaches
    # an equilibrium, and a failed step is not halved. The free motions, their force and the
    # joint reactions come from the core's one frame Gram matrix (FrameGram).
    mechanism = core.free_motions(st.r, st.R, st.eta, st.lam, st.t, mdot)["count"] > 0

    def driven(s, how, free=None):
        """The mechanism error if the residual at ``s`` under the full loads drives a free
        motion, else None: its generalised force (N) against RESIDUAL_TOL of the applied force
        level, the round-off of the forces it sums (the loads and the joint reactions on the
        frames) and the absolute floor; nothing drives where nothing is applied. ``free``: the
        core's free motions at ``s`` if known (static_newton's at the full loads). (The full
        loads, not a step's: the flow is not stepped, so a stepped load may balance it only at
        the end.)"""
        if free is None:
            free = core.free_motions(s.r, s.R, s.eta, s.lam, s.t, mdot)
        g = np.abs(free["force"])
        force = float(g.max(initial=0.0))
        level = max(applied, free["reaction"])
        if not applied > 0.0 or force <= max(RESIDUAL_TOL * applied, 1e3 * np.finfo(float).eps * level, floor):
            return None
        worst = int(np.argmax(g.max(axis=1)))
        F = system.evaluate(s, mass_flow=mdot, tangent=False, jacobian=False)[0]
        return SingularMatrixError(
            f"static solve: {how} the residual along the rigid motions the joints leave free (its generalised force) "
            f"is {force:.3g} N, {force / max(applied, 1e-300):.3g} of the applied force level {applied:.3g} N (largest "
            f"at body {worst}): the loads drive a mechanism (e.g. about a spherical joint or a free hinge) without "
            f"stiffness here; there is no static equilibrium in that direction: support it",
            load_factor=1.0, iteration=total, residual=float(np.abs(F).max()), mass_flow=mdot)

    def _static(trial, lf, mechanism):
        """The core's static_equilibrium from ``trial`` (not changed): its dict with the end
        state (r, R, eta, v, a, lam, t) as 'state'."""
        sys = system.system(trial)
        out = _core.static_equilibrium(sys, mdot, lf, tol, max_iterations, mechanism=mechanism)
        out["state"] = sys.body_state
        return out

    def solve(trial, lf):
        nonlocal mechanism, total, rejected
        out = _static(trial, lf, mechanism)
        total += out["iterations"]
        if (out["singular"] or out["diverged"]) and not mechanism:
            # (nearly) singular: a mechanism after all, from here with the penalty
            mechanism = True
            out = _static(trial, lf, True)
            total += out["iterations"]
        error, ok, stretched = None, out["converged"], None
        if ok:
            r, R, eta, _, _, lam, _ = out["state"]
            deformation, body = _largest_deformation(system, replace(trial, r=r, R=R, eta=eta, lam=lam))
            if not deformation <= DEFORMATION_LIMIT:  # rejected: trial unchanged, the step halved
                ok, stretched = False, (deformation, body)
                rejected = (lf, deformation, body)
            else:
                trial.r[...], trial.R[...], trial.eta[...], trial.lam[...] = r, R, eta, lam
                if mechanism and lf == 1.0:
                    error = driven(trial, "the increments converged but", out.get("free"))
        if not ok and mechanism:  # from the last equilibrium (trial unchanged): halving does not help if the loads drive it
            error = driven(trial, "the increments did not converge and" if stretched is None else
                           f"the step's equilibrium stretched body {stretched[1]} beyond DEFORMATION_LIMIT and")
        if error is not None:
            raise error
        return ok, (lf, out, stretched)

    way = follow(solve, st, start=0.0, end=1.0, steps=steps, halving="step", max_failures=max_bisections,
                 steps_name="load_steps")
    if not way.done:
        raise _not_converged(*way.outcome, max_iterations, mdot, rejected)
    st = way.state
    F = system.evaluate(st, mass_flow=mdot, tangent=False, jacobian=False)[0]
    return MultibodyStatic(st, total, float(np.abs(F).max()), mdot)


def _not_converged(lf, out, stretched, max_iterations, mdot, rejected=None) -> ConvergenceError:
    """The error of a load step's static_newton that did not converge (its dict ``out``), or
    whose equilibrium was rejected (``stretched``: the deformation and the body); ``rejected``:
    an earlier step's rejection (load factor, deformation, body), named too."""
    if stretched is not None:
        deformation, body = stretched
        return ConvergenceError(
            f"static solve: at load factor {lf:.3g} the equilibrium found stretches body {body} elastically by "
            f"{deformation:.3g} of its length (in its frame), more than DEFORMATION_LIMIT = {DEFORMATION_LIMIT:g}: "
            f"the floating frame's small elastic deformation assumption is violated (halved steps end there too); "
            f"stiffen the body, split it into more bodies, or lower the loads", load_factor=lf,
            iteration=out["iterations"], residual=out["residual"], mass_flow=mdot)
    why = ("a singular KKT matrix" if out["singular"] else "a correction beyond the model" if out["diverged"]
           else f"after {max_iterations} iterations")
    earlier = "" if rejected is None else (
        f"; the step to load factor {rejected[0]:.3g} was rejected: it stretched body {rejected[2]} elastically by "
        f"{rejected[1]:.3g} of its length, more than DEFORMATION_LIMIT = {DEFORMATION_LIMIT:g} (the floating "
        f"frame's small elastic deformation)")
    return ConvergenceError(f"static solve did not converge at load factor {lf:.3g} ({why}; last increment "
                            f"{out['correction']:.3g}){earlier}", load_factor=lf, iteration=out["iterations"],
                            residual=out["residual"], mass_flow=mdot)


#: The linearisation of a system of bodies: :class:`pipeflex.Linearization` (one type for every
#: formulation; ``state`` a :class:`~pipeflex.multibody.MultibodyState` with its multipliers).
MultibodyLinearization = Linearization


def linearize(system: MultibodySystem, state: Optional[MultibodyState] = None, *,
              mass_flow: Optional[float] = None) -> Linearization:
    """:func:`pipeflex.linearize` of a system of bodies (the same driver): about ``state``
    with its multipliers, default the static equilibrium at ``mass_flow`` mdot [kg/s]."""
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
