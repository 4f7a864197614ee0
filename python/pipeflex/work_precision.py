"""Work-precision studies: error of a quantity of interest against wall time for both
integrators over a range of step sizes / tolerances."""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable, Dict, List, Mapping, Optional, Sequence

import numpy as np

from .analysis import simulate


@dataclass
class Run:
    """One integration: its setting, quantity of interest, error and wall time [s]."""

    integrator: str
    setting: float  # step [s] (generalised-alpha) or rtol (IDA)
    value: float
    error: float
    wall_time: float
    stats: dict = field(default_factory=dict)
    label: Optional[str] = None  # a named setting's (work_precision(settings=...)); None: the integrator's defaults


def work_precision(model, t_end: float, qoi: Callable, reference: float, *,
                   steps: Sequence[float] = (), rtols: Sequence[float] = (), state=None,
                   ida_atol_factor: float = 1e-2, repeat: int = 1, n_outputs: int = 2,
                   settings: Optional[Mapping[str, Mapping]] = None) -> List[Run]:
    """Run generalised-alpha with each step in ``steps`` and IDA with each rtol in
    ``rtols`` (atol = ida_atol_factor * rtol), evaluate ``qoi(result)`` and its error
    against ``reference``; the wall time is the best of ``repeat`` runs. ``n_outputs``
    equally spaced outputs (the generalised-alpha step is at most their spacing).

    ``settings``: named sets of further generalised-alpha options, each also run at every
    step of ``steps`` and charted as its own line (``Run.label``), e.g.
    ``{"damped": dict(rho_inf=0.6, newton_tol=1e-6, work=False)}``: speed and accuracy of
    the settings side by side."""
    named = dict(settings or {})
    for name, opts in named.items():
        if not isinstance(name, str) or not isinstance(opts, Mapping):
            raise TypeError(f"settings must map names (str) to option dicts, got {name!r}: {opts!r}")
        fixed = {"step", "integrator", "state", "n_outputs"} & set(opts)
        if fixed:
            raise ValueError(f"settings[{name!r}] sets {sorted(fixed)}: work_precision sets those itself "
                             "(the step from steps)")
    plan = [("generalized_alpha", h, dict(step=h), None) for h in steps]
    plan += [("generalized_alpha", h, dict(opts, step=h), name) for name, opts in named.items() for h in steps]
    plan += [("ida", r, dict(rtol=r, atol=ida_atol_factor * r), None) for r in rtols]
    runs = []
    for integ, s, opts, label in plan:
        best = np.inf
        for _ in range(repeat):
            t0 = time.perf_counter()
            res = simulate(model, t_end, integrator=integ, state=state, n_outputs=n_outputs, progress=False, **opts)
            best = min(best, time.perf_counter() - t0)
        v = float(qoi(res))
        runs.append(Run(integ, s, v, abs(v - reference), best, res.stats, label))
    return runs


def reference_by_extrapolation(model, t_end: float, qoi: Callable, *, step: float, state=None,
                               n_outputs: int = 2) -> Dict[str, float]:
    """Generalised-alpha at ``step`` and ``step/2`` and their Richardson extrapolation
    (second order): a reference value and an estimate of its error."""
    v = [float(qoi(simulate(model, t_end, integrator="generalized_alpha", state=state, step=h,
                            n_outputs=n_outputs, progress=False))) for h in (step, step / 2)]
    ref = v[1] + (v[1] - v[0]) / 3.0
    return {"reference": ref, "fine": v[1], "coarse": v[0], "error_estimate": abs(v[1] - v[0]) / 3.0}


def work_precision_figure(runs: List[Run], *, title: str, quantity: str, reference_name: Optional[str] = None,
                          target: Optional[float] = None):
    """Log-log chart: error of the quantity of interest versus wall time (a figure; drawn
    by :func:`pipeflex.plot.work_precision`)."""
    from .plot.charts import work_precision as draw

    ax = draw(runs, reference_name=reference_name, target=target, quantity=quantity, title=title)
    ax.figure.tight_layout()
    return ax.figure


def mean_hinge_speed(result, *, start: float, node: int = 0) -> float:
    """Mean angular velocity about z [rad/s] of ``node`` over [start, t_end]: the change
    of its rotation angle divided by the time (``start`` must be an output time). An
    integrated quantity, insensitive to the phase of lightly damped high-frequency
    vibrations, unlike the angular velocity at one instant."""
    i = int(np.argmin(np.abs(result.t - start)))
    if abs(result.t[i] - start) > 1e-12 * max(1.0, abs(start)):
        raise ValueError(f"start = {start} s is not an output time")
    ang = result.angle(node)
    return float((ang[-1] - ang[i]) / (result.t[-1] - result.t[i]))
