"""Model choice: "model no more than a scene needs".

Accuracy against cost of the seed-004 floating-frame (FFRF) bodies and of seed 000's
element for two quantities:

* the straight cantilever's critical mass flow [kg/s] (seed 004, sec. 8.1; seed 000,
  Table 2), against seed 000's Richardson-extrapolated 25.005520 kg/s;
* the semicircular pipe's final angular velocity [rad/s] (seed 004, sec. 8.2), against a
  fine seed-000 element mesh of the same tube.

Each candidate model is run once (or a few times for the cheap ones, keeping the fastest
wall time) and reported as a :class:`Candidate`: its state size, wall time [s], value and
relative error. :func:`choose` picks the cheapest candidate within a tolerance with
:func:`pipeflex.seeds.seed004.studies.cheapest`. Used by ``notebooks/seed004_model_choice.ipynb``.
SI units throughout.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Dict, List, Optional, Sequence

import numpy as np

from ... import _checks
from ...analysis import critical_mass_flow
from ..seed000 import scenes as seed000_scenes
from ..seed000.references import TABLE2_EXTRAPOLATED
from . import scenes, studies
from .studies import element_curved_model

#: Seed 000, Table 2: the extrapolated critical mass flow [kg/s].
CRITICAL_FLOW_REFERENCE = TABLE2_EXTRAPOLATED
#: Seed 004, sec. 8.2: flow speed [m/s] of the semicircular pipe.
CURVED_FLOW_SPEED = 10.0
#: Smallest relative error drawn on the log axes (an error of exactly 0 is drawn here).
ERROR_FLOOR = 1e-9


@dataclass(frozen=True)
class Candidate:
    """One model of a scene with its cost and accuracy.

    Attributes:
        family: the kind of model (e.g. "FFRF", "seed-000 element").
        label: a short description (bodies, modes, elements, analysis).
        size: size of the first-order state vector, 2 x (independent DOF).
        wall_time: [s] of the analysis that produced ``value`` (fastest of the repeats).
        value: the quantity (kg/s for critical flows, rad/s for angular velocities).
        error: abs(value / reference - 1).
    """

    family: str
    label: str
    size: int
    wall_time: float
    value: float
    error: float


def best_time(fn, *args, repeats: int = 3, budget: float = 0.5, **kwargs):
    """(result, wall time [s]) of ``fn(*args, **kwargs)``: the fastest of up to ``repeats``
    calls; no further call is made once the calls so far took ``budget`` [s] in total
    (so only cheap runs are repeated, which damps the timer noise where it matters)."""
    repeats = _checks.positive_int("repeats", repeats)
    budget = _checks.non_negative("budget", budget)
    best, total, out = np.inf, 0.0, None
    for _ in range(repeats):
        w = time.perf_counter()
        out = fn(*args, **kwargs)
        dt = time.perf_counter() - w
        best, total = min(best, dt), total + dt
        if total >= budget:
            break
    return out, best


def _relative_error(value: float, reference: float) -> float:
    return abs(value / reference - 1.0)


# -- straight cantilever: critical mass flow ---------------------------------------------

def straight_pipe_candidates(*, bodies: Sequence[int] = (1, 2, 4, 8, 16), modes: Sequence[int] = (0, 2, 4, 8),
                             elements: Sequence[int] = (2, 4, 8, 16, 32, 64), elements_per_body: int = 20,
                             reference: float = CRITICAL_FLOW_REFERENCE, repeats: int = 3) -> List[Candidate]:
    """Critical mass flow [kg/s] of the straight cantilever (seed 000 Table 2's pipe) from
    FFRF chains (every combination of ``bodies`` and Craig-Bampton internal ``modes`` per
    body, ``elements_per_body`` elements each) and from seed 000's element with
    ``elements`` elements, by :func:`pipeflex.critical_mass_flow` (default rtol 1e-10).
    Wall time: the critical-flow search; model assembly is not counted."""
    ref = _checks.positive("reference", reference)
    out = []
    for nb in bodies:
        for m in modes:
            s = scenes.ffrf_cantilever_pipe(n_bodies=nb, internal_modes=m, elements_per_body=elements_per_body)
            c, wall = best_time(critical_mass_flow, s, repeats=repeats)
            label = f"FFRF {nb} b." + (f" + {m} modes" if m else "")
            out.append(Candidate("FFRF", label, 2 * s.n_dofs, wall, c.mass_flow, _relative_error(c.mass_flow, ref)))
    for n in elements:
        mdl = seed000_scenes.cantilever_pipe(n_elements=n)
        c, wall = best_time(critical_mass_flow, mdl, repeats=repeats)
        out.append(Candidate("seed-000 element", f"element {n} el.", 2 * mdl.n_dofs, wall, c.mass_flow,
                             _relative_error(c.mass_flow, ref)))
    return out


# -- semicircular pipe: final angular velocity -------------------------------------------

def element_curved_transient(E: float, *, n_elements: int = 8, t_end: float = 4.0, step: float = 1e-3) -> float:
    """Final angular velocity [rad/s] of :func:`element_curved_model` from a transient
    (generalised-alpha, ``step`` [s], from rest, flow from t = 0), averaged as
    :func:`pipeflex.seeds.seed004.studies.final_angular_velocity` over the last 0.5 s."""
    t, w = studies.element_curved_run(E, n_elements=n_elements, t_end=t_end, step=step)
    return studies.final_angular_velocity(t, w)


def _ffrf_curved(E, n_bodies, modes, elements_per_body, t_end, step):
    s, res, w = studies.curved_pipe_run(E, n_bodies=n_bodies, internal_modes=modes,
                                             elements_per_body=elements_per_body, t_end=t_end, step=step)
    return studies.final_angular_velocity(res.t, w), 2 * s.n_dofs


def curved_pipe_candidates(E: float, *, reference: float, bodies: Sequence[int] = (2, 4, 8, 16),
                           modes: Sequence[int] = (0,), elements_per_body: int = 10,
                           elements: Sequence[int] = (2, 4, 8, 16), t_end: float = 4.0, step: float = 1e-3,
                           transient_elements: bool = True, repeats: int = 3) -> List[Candidate]:
    """Final angular velocity [rad/s] of the semicircular pipe (Young's modulus ``E``
    [Pa]) from:

    * FFRF chains of ``bodies`` bodies times ``modes`` internal Craig-Bampton modes per
      body (``elements_per_body`` elements each; with boundary modes only the body mesh
      does not change the result): transient to ``t_end`` [s] with ``step`` [s];
    * seed 000's element with ``elements`` elements by the direct steady-rotation solver
      (:func:`pipeflex.seeds.seed004.studies.element_curved_pipe`);
    * if ``transient_elements``, the same elements by the same transient as the FFRF
      chains (so that the model and the analysis can be told apart in the cost).

    ``reference``: the converged angular velocity [rad/s] the errors are taken against.
    """
    ref = _checks.positive("reference", reference)
    out = []
    for nb in bodies:
        for m in modes:
            (w, size), wall = best_time(_ffrf_curved, E, nb, m, elements_per_body, t_end, step, repeats=repeats)
            label = f"FFRF {nb} b." + (f" {m} m." if m else "")
            out.append(Candidate("FFRF, transient", label, size, wall, w, _relative_error(w, ref)))
    for n in elements:
        size = 2 * element_curved_model(E, n_elements=n).n_dofs
        w, wall = best_time(studies.element_curved_pipe, E, n_elements=n, repeats=repeats)
        out.append(Candidate("seed-000 element, steady solver", f"element {n} el.", size, wall, w,
                             _relative_error(w, ref)))
        if transient_elements:
            w, wall = best_time(element_curved_transient, E, n_elements=n, t_end=t_end, step=step, repeats=repeats)
            out.append(Candidate("seed-000 element, transient", f"element {n} el., transient", size, wall, w,
                                 _relative_error(w, ref)))
    return out


# -- choosing and showing ----------------------------------------------------------------

def choose(candidates: Sequence[Candidate], tolerances: Sequence[float], *,
           cost: str = "wall_time") -> Dict[float, Optional[str]]:
    """Per relative tolerance, the label of the cheapest candidate (by ``cost``:
    ``"wall_time"`` [s] or ``"size"``) whose error is within it (None if none is)."""
    if cost not in ("wall_time", "size"):
        raise ValueError(f"cost must be 'wall_time' or 'size', got {cost!r}")
    costs = [getattr(c, cost) for c in candidates]
    errors = [c.error for c in candidates]
    labels = [c.label for c in candidates]
    return {tol: studies.cheapest(costs, errors, labels, tolerance=tol) for tol in tolerances}


def format_candidates(candidates: Sequence[Candidate], *, unit: str) -> str:
    """A fixed-width table of the candidates (``unit`` of their value)."""
    lines = [f"{'model':34s} {'state':>6s} {'wall [s]':>9s} {'value [' + unit + ']':>16s} {'rel. error':>10s}"]
    for c in candidates:
        lines.append(f"{c.label:34s} {c.size:6d} {c.wall_time:9.4f} {c.value:16.7f} {c.error:10.2e}")
    return "\n".join(lines)


def error_cost_figure(candidates: Sequence[Candidate], *, title: str, tolerance: Optional[float] = None,
                      cost: str = "wall_time", annotate: bool = True):
    """Relative error against cost (``"wall_time"`` [s] or ``"size"``) on log axes, one
    marker per family (:func:`pipeflex.plot.error_cost`); the horizontal line is
    ``tolerance``. Errors below :data:`ERROR_FLOOR` are drawn at it."""
    import matplotlib.pyplot as plt

    from ...plot import error_cost

    if cost not in ("wall_time", "size"):
        raise ValueError(f"cost must be 'wall_time' or 'size', got {cost!r}")
    if tolerance is not None:
        _checks.positive("tolerance", tolerance)
    fig, ax = plt.subplots(figsize=(7.5, 4.8))
    labels = [c.label.replace("element ", "").replace("FFRF ", "").replace(", transient", "") for c in candidates]
    error_cost([getattr(c, cost) for c in candidates], [c.error for c in candidates],
               groups=[c.family for c in candidates], labels=labels if annotate else None, tolerance=tolerance,
               floor=ERROR_FLOOR, xlabel="wall time [s]" if cost == "wall_time" else "size of the state vector [-]",
               ylabel="relative error [-]", ax=ax, title=title)
    fig.tight_layout()
    return fig
