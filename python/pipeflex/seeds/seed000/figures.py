"""Seed 000's figures: convergence of the critical flows (Tables 1, 2), the sprinkler's
spin-up (Fig. 5), drawn with :mod:`pipeflex.plot` where it has a helper."""
from __future__ import annotations

from typing import Optional

import numpy as np

from ... import _checks
from ...analysis import simulate
from ...convergence import critical_flow_convergence, richardson
from . import scenes
from .references import SPRINKLER


def convergence_figure():
    """Log-log error of the critical mass flow versus number of elements (Tables 1, 2),
    drawn by :func:`pipeflex.plot.parameter_curves`."""
    import matplotlib.pyplot as plt

    from ...plot import parameter_curves

    fig, ax = plt.subplots(figsize=(6, 4))
    n1 = np.array([1, 2, 4, 8, 16])
    exact = np.pi * np.sqrt(0.25 * 1.0 / 1.0)
    _, e1 = critical_flow_convergence(scenes.simply_supported_pipe, n1, exact)
    n2 = np.array([2, 4, 8, 16, 32])
    f2, _ = critical_flow_convergence(scenes.cantilever_pipe, n2, 0.0)
    ref = richardson(f2[-2], f2[-1])
    parameter_curves([n1, n2[:-1], n1], [e1, np.abs(f2[:-1] - ref), e1[0] * (n1 / n1[0]) ** -4.0],
                     xlabel="number of elements $n$ [-]",
                     ylabel=r"error of the critical mass flow $\dot m_{cr}$ [kg/s]",
                     labels=["simply supported (Table 1), vs exact", "cantilever (Table 2), vs extrapolated",
                             "order 4"], styles=["o-", "s-", dict(color="k", ls="--", lw=0.8)],
                     xscale="log", yscale="log", ax=ax)
    fig.tight_layout()
    return fig


def sprinkler_figure(*, step: float = 1e-3, rtol: Optional[float] = None, t_end: float = 1.0):
    """Fig. 5: the angular velocity [rad/s] of the semicircular rotating pipe as the flow
    spins it up, for EI = 10, 100, 1000 N m^2 and the rigid pipe (generalised-alpha with the
    fixed ``step`` [s], or, if ``rtol`` [-] is given, with its error-controlled step instead;
    the seed's line styles: dotted, dash-dotted, dashed, solid); the published final
    angular velocities (sec. 3.3, :data:`~pipeflex.seeds.seed000.references.SPRINKLER`) as
    open circles at ``t_end`` [s]. Left, the pipe drawn by :func:`pipeflex.plot.model`
    (hinge, flow direction); right, :func:`pipeflex.plot.time_history`."""
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    from ...plot import STYLES, model as draw_model, published_points, time_history

    fig, (ax0, ax) = plt.subplots(1, 2, figsize=(10, 4), gridspec_kw={"width_ratios": [1, 1.6]})
    draw_model(scenes.sprinkler(EI=10.0), ax=ax0, plane="xy")
    ax0.set_title("the pipe: hinge about $z$ at the inlet", fontsize=10)
    t, omega, labels, styles, finals = [], [], [], [], []
    steps = dict(step=_checks.positive("step", step)) if rtol is None else dict(rtol=_checks.positive("rtol", rtol))
    for k, (label, EI, ls) in enumerate((("$EI$ = 10 N m$^2$", 10.0, ":"), ("$EI$ = 100 N m$^2$", 100.0, "-."),
                                         ("$EI$ = 1000 N m$^2$", 1000.0, "--"), ("rigid", "rigid", "-"))):
        model = scenes.sprinkler(EI=1.0, rigid=True) if EI == "rigid" else scenes.sprinkler(EI=EI)
        r = simulate(model, t_end, integrator="generalized_alpha", n_outputs=201, progress=False, **steps)
        t.append(r.t)
        omega.append(r.omega[:, 0, 2])
        labels.append(label)
        styles.append(dict(color=f"C{k}", ls=ls, lw=1.6))
        finals.append(SPRINKLER[EI])
    time_history(t, omega, quantity=r"angular velocity $\omega_z$", unit="rad/s", labels=labels, styles=styles,
                 ax=ax, title="seed 000, Fig. 5: semicircular rotating pipe", legend=False)
    for k, w in enumerate(finals):
        published_points([t_end], [w], ax=ax, color=f"C{k}")
    ax.set_xlim(-0.02 * t_end, 1.05 * t_end)
    handles, _ = ax.get_legend_handles_labels()
    handles.append(Line2D([], [], **dict(STYLES["published"], color="0.3"),
                          label="published final value (sec. 3.3)"))
    ax.legend(handles=handles, fontsize=8, loc="lower right")
    fig.tight_layout()
    return fig
