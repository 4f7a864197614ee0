"""Seed 002 studies beyond the tables: Southwell coefficients (eqs. 67-69, Figs. 13-14),
spin-up manoeuvres (Figs. 2-7) and the rotation rate at which Model 0 fails."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ... import _checks
from ..._options import renamed
from ...analysis.rotating import rotating_frequencies
from ...analysis.transient import simulate
from ...errors import ConvergenceError
from . import scenes
from .references import SCHILHANSL, SLENDERNESS



def schilhansl(mode: int, hub_radius_ratio: float) -> float:
    """Southwell coefficient of eqs. 68-69 for transverse mode 1 or 2."""
    a, b = SCHILHANSL[mode]
    return a + b * hub_radius_ratio


@dataclass
class Southwell:
    """Southwell coefficients of one configuration: ``fitted`` from omega^2 = omega_0^2 +
    phi Omega^2 by least squares over ``gammas``; ``slope`` = d(omega^2)/d(Omega^2) at
    Omega -> 0 from the eigen-analysis (difference at gamma = 1e-3)."""

    mode: int
    hub_radius_ratio: float
    fitted: float
    slope: float
    gammas: np.ndarray


def southwell(*, mode: int = 1, hub_radius_ratio: float = 0.0, gammas: Sequence[float] = (0.0, 1.0, 2.0, 3.0, 4.0, 5.0),
              n_elements: int = 10) -> Southwell:
    """Southwell coefficient of transverse ``mode`` (N = 0), fitted and limiting."""
    model = scenes.rotating_cantilever(n_elements=n_elements, hub_radius_ratio=hub_radius_ratio)
    g = np.asarray(gammas, float)
    w = rotating_frequencies(model, gamma=g, n_modes=mode).transverse[:, mode - 1]
    A = np.column_stack([np.ones_like(g), g**2])
    fitted = float(np.linalg.lstsq(A, w**2, rcond=None)[0][1])
    eps = 1e-3
    w0, w1 = rotating_frequencies(model, gamma=[0.0, eps], n_modes=mode).transverse[:, mode - 1]
    return Southwell(mode, hub_radius_ratio, fitted, float((w1**2 - w0**2) / eps**2), g)


def tip_deflection(model, result) -> np.ndarray:
    """Transverse tip deflection [m] in the rotating frame (the co-rotating coordinates of
    an ANCF hub model): the tip's displacement normal to the reference beam axis."""
    tip = model.info["tip_node"]
    axis = model.hub.axis
    x0 = model.positions[tip] - model.hub.center
    er = x0 / np.linalg.norm(x0)
    return (result.x[:, tip, :] - model.positions[tip]) @ np.cross(axis, er)


@renamed(model="elastic")
def spin_up(*, reference: str = "ref21", n_elements: int = 2, elastic: str = "A", omega=None,
            t_end: float = 20.0, step: float = None, rtol: float = 0.1, n_outputs: int = 401):
    """Simulate the spin-up manoeuvre (eq. 13, T = 15 s) of a Table 1 beam with
    generalised-alpha; returns (times [s], tip deflection [m]). ``elastic``: ANCF elastic
    force model ``"A"`` or ``"0"`` (``model=`` is its deprecated name); ``step`` [s]: a
    fixed step if given, else ``rtol`` [-]: the error-controlled step (its tolerance
    follows a diverging run's motion once that outgrows the beam). A diverging run raises
    :class:`~pipeflex.ConvergenceError`."""
    m = scenes.spin_up_beam(reference=reference, n_elements=n_elements, elastic=elastic, omega=omega)
    # rtol: the stable runs take the outputs' 401 steps (the tip within 5.2 mm of a fine
    # step's), the diverging one's steps follow its growth to 8 km with a tolerance
    # relative to the motion (3.7e-3 of it), fewer steps in all than fixed 2 ms ones
    accuracy = dict(rtol=rtol) if step is None else dict(step=step)
    r = simulate(m, t_end, integrator="generalized_alpha", n_outputs=n_outputs, work=False, progress=False,
                 **accuracy)
    return r.t, tip_deflection(m, r)


@renamed(model="elastic")
def unstable(*, n_elements: int, omega: float, elastic: str = "0", reference: str = "ref21") -> bool:
    """Is the steady rotation at ``omega`` [rad/s] unstable (linear analysis about the
    nonlinear steady state in the rotating frame), or has it no steady state? ``elastic``:
    ANCF elastic force model (``model=`` is its deprecated name)."""
    m = scenes.spin_up_beam(reference=reference, n_elements=n_elements, elastic=elastic, omega=omega)
    gamma = omega / m.info["omega0"]
    try:
        r = rotating_frequencies(m, gamma=[gamma], linearization="steady_state", n_modes=1)
    except ConvergenceError:
        return True
    return bool(r.growth[0] > 0.0)


@renamed(model="elastic", rtol="tol")
def critical_rate(*, n_elements: int, elastic: str = "0", reference: str = "ref21", low: float = 0.5,
                  high: float = 400.0, tol: float = 1e-3) -> float:
    """Smallest rotation rate [rad/s] at which the steady rotation loses stability
    (bisection between ``low`` stable and ``high`` unstable); inf if stable at ``high``.
    ``elastic``: ANCF elastic force model (``model=`` is its deprecated name); ``tol`` [-]:
    relative tolerance on the rate, as :func:`pipeflex.critical_mass_flow`'s (``rtol=`` is
    its deprecated name)."""
    _checks.positive_int("n_elements", n_elements)
    rtol = _checks.positive("tol", tol)
    if unstable(n_elements=n_elements, omega=low, elastic=elastic, reference=reference):
        raise ValueError(f"already unstable at the lower bound {low} rad/s")
    if not unstable(n_elements=n_elements, omega=high, elastic=elastic, reference=reference):
        return float("inf")
    while high - low > rtol * high:
        mid = 0.5 * (low + high)
        if unstable(n_elements=n_elements, omega=mid, elastic=elastic, reference=reference):
            high = mid
        else:
            low = mid
    return 0.5 * (low + high)


def mode_shape_figure(*, gammas: Sequence[float] = (0.0, 50.0), n_modes: int = 3):
    """Figs. 11-12: the first ``n_modes`` transverse mode shapes at ``gammas`` (solid,
    dashed, ...), for R = 0, N = 0 (Fig. 11) and R = 2L, N = 3 (Fig. 12): the tangential
    displacement in the rotating frame against x / L (the dynamic part q_delta of eq. 45),
    largest value 1, tip positive; drawn between the nodes with the element shape functions
    (:func:`pipeflex.plot.mode_shape`), the nodal values being ``transverse_shapes``."""
    import matplotlib.pyplot as plt

    from ...analysis.campbell import rotating_modes
    from ...plot import mode_shape
    from ...plot.centreline import mode_displacement

    styles = ("-", "--", ":", "-.")
    fig, axes = plt.subplots(1, 2, figsize=(11, 4), sharey=True)
    for ax, (R, N, title) in zip(axes, ((0.0, 0.0, "Fig. 11: R = 0, N = 0"), (2.0, 3.0, "Fig. 12: R = 2L, N = 3"))):
        beam = scenes.rotating_cantilever(hub_radius_ratio=R, tip_mass_ratio=N, slenderness=SLENDERNESS)
        tangential = np.cross(beam.hub.axis, [1.0, 0.0, 0.0])
        for k, g in enumerate(gammas):
            modes = rotating_modes(beam, omega=g * beam.info["omega0"])
            inplane = np.flatnonzero(np.argmax(modes["share"], axis=1) == 1)[:n_modes]
            for j, col in enumerate(inplane):
                v = modes["shapes"][:, col]
                tip = mode_displacement(beam, v).reshape(-1, 6)[beam.info["tip_node"], :3] @ tangential
                mode_shape(beam, v, component=tangential, flip=bool(tip < 0), ax=ax, color=f"C{j}",
                           linestyle=styles[k % len(styles)], label=f"mode {j + 1}" if k == 0 else None)
        ax.set_title(title)
        ax.set_xlabel("$x/L$ [-]")
        ax.grid(lw=0.3)
    axes[0].set_ylabel("transverse displacement [-] (largest 1)")
    axes[1].set_ylabel("")
    names = ("solid", "dashed", "dotted", "dash-dot")
    axes[0].legend(title=", ".join(f"{n}: $\\gamma$ = {g:g}" for n, g in zip(names, gammas)), fontsize=8,
                   title_fontsize=8)
    fig.tight_layout()
    return fig


def spin_up_figure(*, omega: float = 10.0, t_end: float = 20.0,
                   cases=((2, "A"), (1, "0"), (2, "0"), (10, "0"))):
    """Fig. 6: spin-up to ``omega`` [rad/s] of the ref. 21 beam, Models A and 0 (``cases``:
    (elements, elastic model)); a diverging run is drawn up to shortly before it failed,
    the failure marked by a cross and named in the legend. Drawn by
    :func:`pipeflex.plot.time_history` (Model A solid, Model 0 dashed and dotted, so that
    curves lying on one another stay visible). Returns the figure."""
    import matplotlib.pyplot as plt

    from ...plot import time_history

    fig, ax = plt.subplots(figsize=(7, 4))
    ts, ys, labels, styles, failures = [], [], [], [], []
    dashes = ("--", ":", "-.", (0, (5, 1, 1, 1, 1, 1)))
    for k, (n, model) in enumerate(cases):
        label = f"Model {model}, {n} element{'s' * (n > 1)}"
        style = dict(color=f"C{k}", lw=2.4 if model == "A" else 1.4,
                     ls="-" if model == "A" else dashes[k % len(dashes)], zorder=2 if model == "A" else 3)
        try:
            t, y = spin_up(n_elements=n, elastic=model, omega=omega, t_end=t_end)
        except ConvergenceError as e:
            if e.time is None:
                raise
            t, y = _until_failure(n, model, omega, e.time)
            label += f": diverged at $t$ = {e.time:.2f} s"
            failures.append((k, e.time))
        ts.append(t)
        ys.append(y)
        labels.append(label)
        styles.append(style)
    time_history(ts, ys, quantity="tip deflection", unit="m", labels=labels, styles=styles, ax=ax, legend=False,
                 title=f"seed 002, Fig. 6: spin-up to {omega:g} rad/s (ref. 21 beam)")
    ax.set_ylim(-1.5, 1.5)
    for k, t_fail in failures:
        # where the run failed: a cross on the axes' edge the diverging curve leaves by
        y_end = ys[k][-1] if len(ys[k]) else 0.0
        ax.plot([t_fail], [float(np.clip(y_end, -1.45, 1.45))], "x", color=f"C{k}", ms=9, mew=2, zorder=4)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def _until_failure(n_elements: int, elastic: str, omega: float, t_fail: float):
    """(times [s], tip deflection [m]) of a diverging spin-up up to shortly before it
    failed at ``t_fail`` [s] (the last margin whose run completes)."""
    for margin in (0.05, 0.25, 1.0):
        if t_fail - margin <= 0.0:
            break
        try:
            return spin_up(n_elements=n_elements, elastic=elastic, omega=omega, t_end=t_fail - margin)
        except ConvergenceError:
            continue
    return np.zeros(0), np.zeros(0)
