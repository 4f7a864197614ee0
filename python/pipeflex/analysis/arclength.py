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
It runs on the core's system object of any formulation (element model, bodies, coupled:
the model class's ``_system``), whose analyses compute the residual, its tangent and
dR/dt (``_core.static_arc_tangent``).

A limit point is where the t component of the tangent changes sign; it is located by
the Illinois method on the arc length of the step.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, List, Optional

import numpy as np

from .. import _core
from ._roots import Illinois


@dataclass
class Arc:
    """The spherical constraint of one continuation step (the core's static_newton solves
    the bordered system with it: ``pipeflex.analysis.static._arc_newton``).

    ``t`` is the current path parameter, ``dq``/``dt`` the increment accumulated from
    the step's start (updated by the corrector); ``predict``: the corrector's state is the
    step's start, to be moved by ``dq`` first (else it is there already)."""

    at: Callable  # t -> (mdot [kg/s], load factor [-]), affine in t
    w2: np.ndarray  # squared weights of the coordinates
    psi2: float
    ds: float
    t: float
    dq: np.ndarray
    dt: float = 0.0
    predict: bool = False

    def path(self) -> tuple:
        """(m0, m1, l0, l1): mdot = m0 + m1 t [kg/s], the load factor l0 + l1 t."""
        return path_of(self.at)


def path_of(at) -> tuple:
    """(m0, m1, l0, l1) of the affine t -> (mdot [kg/s], load factor) ``at``."""
    (m0, l0), (m1, l1) = at(0.0), at(1.0)
    return m0, m1 - m0, l0, l1 - l0


def tangent(model, state, at, t, w2, psi2, previous):
    """Unit tangent (dq/ds, dt/ds) of the path at a converged point ``state`` (a working
    state of ``model``) at t, oriented along ``previous`` (a tangent, or None: t
    increasing); None if the bordered system is singular. The core's, on the model's system
    object (dR/dt exact by central differences: R is a polynomial of degree <= 2 in t)."""
    pq, pt = (np.zeros(len(w2)), 1.0) if previous is None else previous
    out = _core.static_arc_tangent(model._system(state, mass_flow=at(t)[0]), path_of(at), t, w2, psi2,
                                   np.asarray(pq, float), float(pt))
    if out is None:
        return None
    v, s = out
    return np.asarray(v), float(s)


@dataclass
class Point:
    state: object  # a working state of the model (its _static_start's type)
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
    """Squared weights of the system's coordinates: lengths 1/size^2 [1/m^2] (positions,
    a body's elastic amplitudes), the rest 1 (rotations, slopes)."""
    lengths = np.asarray(model._system().length_coordinates)
    return np.where(lengths != 0.0, 1.0 / size**2, 1.0)


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
        trial = p.state.copy()  # moved by the predictor sigma v in the corrector
        arc = Arc(at, w2, psi2, sigma, p.t + sigma * s, sigma * v, sigma * s, predict=True)
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
        lo, hi, flo = 0.0, sigma, f(p)
        q_hi, _ = step(p, sigma)
        if q_hi is None:
            return None
        bracket, best = Illinois(lo, hi, flo, f(q_hi)), q_hi
        for _ in range(30):
            if bracket.width <= 1e-7 * sigma or abs(f(best)) <= 1e-12:
                break
            x = bracket.trial()
            q, _ = step(p, x)
            if q is None:
                break
            best = q
            bracket.update(x, f(q))
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
