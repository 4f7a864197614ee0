"""A system of bodies' part of the static driver (:func:`pipeflex.static_equilibrium`):
its Newton solve with the mechanisms' penalty and the floating frame's step acceptance,
and its errors (MultibodySystem._static_newton, _static_failure)."""
from __future__ import annotations

from dataclasses import replace
from typing import Tuple

import numpy as np

from ..errors import ConvergenceError, SingularMatrixError


#: :func:`pipeflex.static_equilibrium` refuses a converged state whose residual exceeds this
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


def _bending_force(system) -> float:
    """The bodies' bending force scale [N]: the largest EI / L^2 (either bending stiffness,
    L the body's length), the force that bends a body by about its length."""
    return max(max(b.section.EI, b.section.EIz) / b.length**2 for b in system.bodies)


def _largest_deformation(system, state) -> Tuple[float, int]:
    """The largest elastic displacement of a node in its body's frame, Phi_u (eta - eta0),
    as a fraction of that body's length, and the body."""
    worst, body = 0.0, 0
    for j, b in enumerate(system.bodies):
        u = (b.basis @ (system.eta(state, j) - b.eta0)).reshape(-1, 6)[:, :3]
        d = float(np.sqrt((u * u).sum(axis=1)).max(initial=0.0)) / b.length
        if not d <= worst:  # NaN too
            worst, body = d, j
    return worst, body


def static_newton(system, trial, solve, *, mass_flow: float, load_factor: float,
                  max_iterations: int, start=None) -> dict:
    """A system of bodies' static Newton (MultibodySystem._static_newton) from ``trial``
    (updated in place when accepted): the driver's ``solve(system, mechanism=)`` on the
    core's system object, with the mechanisms' penalty where the joints leave a rigid
    motion free at ``start`` (the solve's start; default ``trial``) or the KKT matrix is
    singular; a converged step that stretches a body beyond :data:`DEFORMATION_LIMIT` is
    refused (``refused``, ``stretched`` (deformation, body)); loads that drive a mechanism
    raise SingularMatrixError. The core's dict, with ``why`` when not accepted and the
    ``load_factor``."""
    mdot, lf = mass_flow, load_factor
    start = trial if start is None else start
    core = system.core
    # the applied force level (loads, gravity, flow at the start, multipliers 0), to judge
    # the residual along the free motions
    at_start = replace(start, lam=np.zeros_like(start.lam))
    applied = float(np.abs(system.evaluate(at_start, mass_flow=mdot, tangent=False,
                                           jacobian=False)[0]).max(initial=0.0))
    floor = FORCE_FLOOR * _bending_force(system)
    # The core's Newton (static_newton: one sparse LU of the KKT matrix per iteration, the
    # equations the integrator uses). A mechanism's KKT matrix is singular: the frames' free
    # motions are then penalised (not the residual) and the corrections filtered so that a
    # free motion without stiffness keeps its value; the loads drive it if the residual under
    # the full loads has a generalised force on it (driven): then no step, however short, reaches
    # an equilibrium, and a failed step is not halved. The free motions, their force and the
    # joint reactions come from the core's one frame Gram matrix (FrameGram).
    mechanism = core.free_motions(start.r, start.R, start.eta, start.lam, start.t, mdot)["count"] > 0
    total = 0

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

    sys = system.system(trial)
    out = solve(sys, mechanism=mechanism)
    total += out["iterations"]
    if (out["singular"] or out["diverged"]) and not mechanism:
        # (nearly) singular: a mechanism after all, from here with the penalty
        mechanism = True
        sys = system.system(trial)
        out = solve(sys, mechanism=True)
        total += out["iterations"]
    error, ok, stretched = None, bool(out["converged"]), None
    if ok:
        end = system._state_of(sys)
        deformation, body = _largest_deformation(system, end)
        if not deformation <= DEFORMATION_LIMIT:  # refused: trial unchanged, the step halved
            ok, stretched = False, (deformation, body)
        else:
            trial.r[...], trial.R[...], trial.eta[...], trial.lam[...] = end.r, end.R, end.eta, end.lam
            if mechanism and lf == 1.0:
                error = driven(trial, "the increments converged but", out.get("free"))
    if not ok and mechanism:  # from the last equilibrium (trial unchanged): halving does not help if the loads drive it
        error = driven(trial, "the increments did not converge and" if stretched is None else
                       f"the step's equilibrium stretched body {stretched[1]} beyond DEFORMATION_LIMIT and")
    if error is not None:
        raise error
    out["load_factor"] = lf
    if stretched is not None:
        out["refused"], out["stretched"] = True, stretched
    if not ok:
        out["why"] = str(_not_converged(lf, out, stretched, max_iterations, mdot))
    return out


def static_failure(system, out: dict, *, load_factor, mass_flow, max_iterations,
                   earlier) -> ConvergenceError:
    """The error of a load stepping whose step failed with :func:`static_newton`'s ``out``;
    ``earlier``: the outcomes of the failed steps before it (the last refused one is named)."""
    refused = [o for o in earlier if o.get("stretched") is not None]
    rejected = None if not refused else (refused[-1]["load_factor"], *refused[-1]["stretched"])
    return _not_converged(load_factor, out, out.get("stretched"), max_iterations, mass_flow, rejected)


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


