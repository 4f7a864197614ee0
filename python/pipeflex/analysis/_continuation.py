"""The one continuation in a scalar parameter with step halving.

Every static Newton runs in the core's ``static_newton``; the continuation around it
(:func:`pipeflex.static_equilibrium`'s load and flow stepping, :func:`pipeflex.rotating_state`'s
steps in Omega^2) is :func:`follow`: it steps a parameter t from ``start`` to ``end``, one
Newton solve per step from the last converged state, and halves a step whose solve fails.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Optional

import numpy as np

#: A failed step shorter than this many ulps of the path's largest |t| stops the path.
RESOLUTION = 64

#: How a failed step is halved (see :func:`follow`).
HALVINGS = ("step", "interval")


@dataclass
class Continuation:
    """Where a continuation stopped.

    Attributes:
        state: the last converged state (the start if no step converged).
        t: its parameter.
        done: t reached the end.
        target: the parameter of the failed solve it stopped at (None when done).
        step: the step of the last solve (after the halvings before it).
        failures: failed solves in all.
        outcome: the last solve's outcome (the failed one when not done).
        stop: why it stopped short: ``"failures"`` (more than ``max_failures``),
            ``"min_step"`` (a failed step below ``min_step``); None when done.
    """

    state: Any
    t: float
    done: bool = False
    target: Optional[float] = None
    step: float = 0.0
    failures: int = 0
    outcome: Any = None
    stop: Optional[str] = None


def follow(solve: Callable[[Any, float], tuple], state, *, start: float, end: float, steps: int,
           halving: str, max_failures: int, min_step: Optional[float] = None,
           steps_name: str = "steps") -> Continuation:
    """Continue the converged ``state`` at t = ``start`` to t = ``end`` in ``steps`` equal steps.

    ``solve(trial, t) -> (converged, outcome)`` solves at t from ``trial`` (a copy of the
    last converged state, updated in place); ``outcome`` is the caller's (kept in
    :attr:`Continuation.outcome`). A failed solve is retried closer, by ``halving``:

    * ``"step"``: t + h, the step h halved for the rest of the path (load stepping; needs
      start < end; a step landing within 1e-14 of the span before the end lands on the end);
    * ``"interval"``: the scheduled t_k = start + k (end - start) / steps in turn, a failed
      one approached from the last converged t by bisection, after which the schedule
      resumes (its step is the schedule's again).

    It stops short after more than ``max_failures`` failed solves, or (``min_step``) when a
    failed step, |target - t|, is below ``min_step`` or below the resolution of t itself
    (RESOLUTION ulps of the path's largest |t|: a smaller step would not move t, and the
    halving would go on without end whatever ``max_failures``), either way along the path.
    A ``"step"`` schedule whose step is below that resolution is refused (ValueError)
    naming ``steps`` as the caller's user knows it: ``steps_name`` (e.g. "load_steps").
    """
    if halving not in HALVINGS:
        raise ValueError(f"halving must be one of {HALVINGS}, got {halving!r}")
    if halving == "step" and not start < end:
        raise ValueError(f"halving='step' needs start < end, got start = {start!r}, end = {end!r}")
    way = Continuation(state, start)
    floor = max(min_step or 0.0, RESOLUTION * np.spacing(max(abs(start), abs(end))))
    h = (end - start) / steps
    if halving == "step" and h < floor:  # t + h would not move t: the loop would never end
        raise ValueError(f"{steps_name} = {steps} over [{start:g}, {end:g}]: a step of {h:.3g} is below the "
                         f"resolution {floor:.3g} of the parameter; use fewer steps (lower {steps_name})")
    pending = list(np.linspace(start, end, steps + 1)[1:]) if halving == "interval" else None
    last = end - 1e-14 * (end - start)
    while (bool(pending) if pending is not None else way.t < last):
        # the step that lands within the end's round-off lands on the end itself (ten steps
        # of 0.1 add up to 0.9999999999999999)
        target = pending[0] if pending is not None else (end if way.t + h >= last else way.t + h)
        trial = way.state.copy()
        ok, way.outcome = solve(trial, target)
        way.step = target - way.t if pending is not None else h
        if ok:
            way.state, way.t = trial, target
            if pending is not None:
                pending.pop(0)
            continue
        way.failures += 1
        way.target = target
        if way.failures > max_failures:
            way.stop = "failures"
            return way
        if abs(target - way.t) < floor:
            way.stop = "min_step"
            return way
        if pending is not None:
            pending.insert(0, 0.5 * (target + way.t))
        else:
            h /= 2
    way.done, way.target = True, None
    return way
