"""Arc-length (Riks/Crisfield) continuation of static equilibria through limit points.

The equilibrium path R(q, t) = 0 is followed in (q, t), t the path parameter of
:func:`~pipeflex.static_equilibrium` (the load factor, or the flow-ramp parameter), with
the spherical constraint::

    |W dq|^2 + psi^2 dt^2 = ds^2

on the increment (dq, dt) from the last converged point; W scales translations by
1/size [1/m] (rotations and ANCF slopes count as they are), psi^2 [-] makes the load
and the displacements of the first tangent count equally. Each step is a predictor along
the path tangent (oriented by the previous tangent, so that the path turns at a limit
point instead of reversing) and a Newton corrector on the bordered system

    [K  R_t] [dq]     [R]
    [c^T  d] [dt] = - [g]

solved by block elimination with one sparse LU of the tangent K (two solves), or the
full bordered matrix when K is exactly singular: the core's static Newton with the
constraint as its border (passed in as ``newton``); this module keeps the step control.

A limit point is where the t component of the tangent changes sign; it is located by
the Illinois method on the arc length of the step.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, List, Optional

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .. import _core
from ._assembly import residual_and_tangent


def dR_dt(model, state, at, t):
    """dR/dt [N per unit t] at ``state``: R is a polynomial of degree <= 2 in t (loads
    and gravity linear in the load factor, the flow forces quadratic in mdot), so the
    central difference with step 1/2 is exact."""
    h = 0.5
    out = []
    for s in (t + h, t - h):
        mdot, lf = at(s)
        r, _ = residual_and_tangent(model, state, model.load_state(mass_flow=mdot, gravity_factor=lf),
                                    load_factor=lf, matrix=False)
        out.append(r)
    return (out[0] - out[1]) / (2 * h)


@dataclass
class Arc:
    """The spherical constraint of one continuation step (the core's static_newton solves
    the bordered system with it: ``pipeflex.analysis.static._arc_newton``).

    ``t`` is the current path parameter, ``dq``/``dt`` the increment accumulated from
    the step's start (updated by the corrector)."""

    at: Callable  # t -> (mdot [kg/s], load factor [-]), affine in t
    w2: np.ndarray  # squared weights of the coordinates
    psi2: float
    ds: float
    t: float
    dq: np.ndarray
    dt: float = 0.0


def tangent(model, state, at, t, w2, psi2, previous):
    """Unit tangent (dq/ds, dt/ds) of the path at a converged point, oriented along
    ``previous`` (a tangent, or None: t increasing); None if the bordered system is
    singular."""
    mdot, lf = at(t)
    _, J = residual_and_tangent(model, state, model.load_state(mass_flow=mdot, gravity_factor=lf),
                                load_factor=lf)
    rt = dR_dt(model, state, at, t)
    pq, pt = (np.zeros(model.n_dofs), 1.0) if previous is None else previous
    try:
        b = spla.splu(J).solve(-rt)
        if not np.all(np.isfinite(b)):
            raise RuntimeError("not finite")
        v, s = b, 1.0
    except RuntimeError:  # exactly singular: the bordered matrix [J rt; W^2 p^T psi^2 p_t]
        A = sp.bmat([[J, sp.csc_matrix(rt[:, None])],
                     [sp.csc_matrix((w2 * pq)[None, :]), sp.csc_matrix([[psi2 * pt]])]], format="csc")
        try:
            z = spla.splu(A).solve(np.concatenate([np.zeros(model.n_dofs), [1.0]]))
        except RuntimeError:
            return None
        v, s = z[:-1], float(z[-1])
    n = np.sqrt(float(np.dot(w2 * v, v)) + psi2 * s * s)
    if not np.isfinite(n) or n == 0.0:
        return None
    v, s = v / n, s / n
    if float(np.dot(w2 * v, pq)) + psi2 * s * pt < 0:
        v, s = -v, -s
    return v, s


@dataclass
class Point:
    state: object  # _core.State
    t: float
    tangent: tuple


@dataclass
class Path:
    """Outcome of :func:`follow`: ``end`` the point at t = 1 (None if not reached),
    ``limits`` the limit points passed (in order), ``steps`` and ``iterations`` the work,
    ``why`` the reason it stopped short."""

    end: Optional[Point]
    limits: List[Point] = field(default_factory=list)
    steps: int = 0
    iterations: int = 0
    why: str = ""
    last: Optional[Point] = None
    residual: float = 0.0


def weights(model, size):
    """Squared weights of the reduced coordinates: translations 1/size^2 [1/m^2], the rest 1."""
    return np.array([1.0 / size**2 if comp.startswith("u") else 1.0 for _, comp in model.dof_labels])


def follow(model, state, t0, *, at, newton, size, tol, max_iterations, max_steps, dt0, secant=None):
    """Follow the path from the converged ``state`` at t0 until t = 1 (see the module).

    ``newton(state, arc)`` is the static solver's Newton iteration with the constraint
    ``arc`` (returns ok, iterations, residual, reason, singular); ``dt0`` the first
    increment of t [-]; at most ``max_steps`` steps; ``secant``: dq/dt of the path so far
    (scales t against q; default the tangent at the start, which is too steep near a
    limit point)."""
    w2 = weights(model, size)
    first = tangent(model, state, at, t0, w2, 1.0, None)
    out = Path(None)
    if first is None:
        out.why = f"the tangent is singular at the start of the continuation (t = {t0:.6g})"
        return out
    v, s = first
    slope = secant if secant is not None else (v / s if s != 0 else None)
    psi2 = float(np.dot(w2 * slope, slope)) if slope is not None else 1.0  # |W dq/dt|^2
    psi2 = psi2 if np.isfinite(psi2) and psi2 > 0 else 1.0
    start = Point(state, t0, tangent(model, state, at, t0, w2, psi2, None))
    ds0 = dt0 * np.sqrt(2 * psi2)  # the first step moves t by about dt0
    ds, ds_min, ds_max = ds0, ds0 * 2.0**-12, max(8 * ds0, 0.25 * np.sqrt(2 * psi2), 0.25)
    here, its, last_it = start, 0, 0
    out.last = start

    def step(p, sigma):
        """Converged point at arc length sigma from p along the path, or (None, reason)."""
        nonlocal its, last_it
        v, s = p.tangent
        trial = p.state.copy()
        _core.add_increment(model.core, trial, sigma * v, "q")
        trial.rebase(np.pi)
        arc = Arc(at, w2, psi2, sigma, p.t + sigma * s, sigma * v, sigma * s)
        ok, it, rn, why, _ = newton(trial, arc)
        its += it
        last_it = it
        if not ok:
            return None, why
        if float(np.dot(w2 * arc.dq, v)) + psi2 * arc.dt * s <= 0:  # went back along the path
            return None, "the corrector turned back"
        tg = tangent(model, trial, at, arc.t, w2, psi2, p.tangent)
        if tg is None:
            return None, "singular bordered tangent"
        out.residual = rn
        return Point(trial, arc.t, tg), ""

    def locate(p, sigma, f):
        """Illinois method on sigma in (0, sigma) for f(point) = 0 (f(p) and f(end) differ in sign)."""
        lo, hi, flo, fhi = 0.0, sigma, f(p), None
        q_hi, _ = step(p, sigma)
        if q_hi is None:
            return None
        fhi, best, side = f(q_hi), q_hi, 0
        for _ in range(30):
            if hi - lo <= 1e-7 * sigma or abs(f(best)) <= 1e-12:
                break
            x = hi - fhi * (hi - lo) / (fhi - flo)
            if not lo < x < hi:
                x = 0.5 * (lo + hi)
            q, _ = step(p, x)
            if q is None:
                break
            fx = f(q)
            best = q
            if np.sign(fx) == np.sign(fhi):
                hi, fhi = x, fx
                if side == -1:
                    flo /= 2
                side = -1
            else:
                lo, flo = x, fx
                if side == 1:
                    fhi /= 2
                side = 1
        return best

    while out.steps < max_steps:
        nxt, why = step(here, ds)
        if nxt is None:
            ds /= 2
            if not ds >= ds_min or ds == 0.0:  # (ds_min itself may underflow to 0)
                short = (f"fell below {ds_min:.3g}" if ds_min > 0.0 else  # a subnormal first step
                         f"was halved to 0 from its first {ds0:.3g}")
                out.why = f"the arc-length step {short} at t = {here.t:.6g}: {why}"
                return out
            continue
        out.steps += 1
        it_step = last_it
        if (here.tangent[1] > 0) != (nxt.tangent[1] > 0):  # t turns: a limit point
            fold = locate(here, ds, lambda p: p.tangent[1])
            turn = (here if here.t >= nxt.t else nxt) if here.tangent[1] > 0 else (here if here.t <= nxt.t else nxt)
            out.limits.append(fold if fold is not None else turn)
        if (here.t - 1.0) * (nxt.t - 1.0) <= 0 and nxt.t != here.t:  # crossed t = 1
            end = locate(here, ds, lambda p: p.t - 1.0)
            out.end = end if end is not None else nxt
            out.iterations = its
            return out
        here, out.last = nxt, nxt
        ds = min(ds_max, max(ds_min, ds * min(2.0, max(0.5, np.sqrt(8.0 / max(1, it_step))))))
    out.iterations = its
    out.why = f"the path did not reach t = 1 in {max_steps} arc-length steps (at t = {here.t:.6g})"
    return out
