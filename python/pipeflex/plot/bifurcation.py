"""Bifurcation diagrams of branches of periodic orbits (:func:`pipeflex.continue_orbits`)."""
from __future__ import annotations

from typing import Optional, Sequence

import numpy as np

QUANTITIES = ("amplitude", "period")
_COMPONENTS = "xyz"


def _as_list(branches):
    return list(branches) if isinstance(branches, (list, tuple)) else [branches]


def _per_branch(value, n, name):
    if value is None or np.isscalar(value):
        return [value] * n
    value = list(value)
    if len(value) != n:
        raise ValueError(f"{name}: {len(value)} entries for {n} branches")
    return value


def branch_curve(branch, *, node: int = 0, component: int = 1, quantity: str = "amplitude"):
    """The points drawn of ``branch``: mass flows [kg/s] from the Hopf point on, and the
    amplitude [m] of ``node``'s ``component`` (0 at the Hopf point) or the period [s]
    (2 pi / omega_c at the Hopf point)."""
    if quantity not in QUANTITIES:
        raise ValueError(f"quantity must be one of {QUANTITIES}, got {quantity!r}")
    mdot_c, omega_c = float(branch.hopf[0]), float(branch.hopf[1])
    if quantity == "amplitude":
        y, y0 = np.asarray(branch.amplitude)[:, int(node), int(component)], 0.0
    else:
        y, y0 = np.asarray(branch.period, dtype=float), 2 * np.pi / omega_c
    return np.concatenate([[mdot_c], np.asarray(branch.mass_flow, dtype=float)]), np.concatenate([[y0], y])


def bifurcation(branches, *, node, component: int = 1, stable=None, quantity: str = "amplitude",
                labels: Optional[Sequence[str]] = None, colors: Optional[Sequence[str]] = None, ax=None,
                ylabel: Optional[str] = None, legend: bool = True, stability_labels=("stable", "unstable"),
                lw: float = 1.4):
    """Bifurcation diagram of branches of periodic orbits (:class:`~pipeflex.OrbitBranch`):
    the amplitude of a node's motion (or the period) against the mass flow, solid between
    stable orbits, dashed where one of two neighbours is unstable, the Hopf point (where
    the amplitude is 0 and the period 2 pi / omega_c) as a dot.

    Args:
        branches: one branch or a sequence of them (one colour each).
        node: the node whose amplitude is drawn; one per branch if a sequence.
        component: 0, 1, 2 for x, y, z.
        stable: the stability of each orbit: default each branch's ``stable``; else a (k,)
            boolean array (one branch) or one per branch (e.g. the stability in a larger
            model); an empty array also means the branch's own.
        quantity: "amplitude" [m] or "period" [s].
        labels: one legend label per branch. colors: one colour per branch (default C0, C1, ...).
        ax: axes to draw on; default new ones.
        ylabel: default "amplitude $A_y$ [m]" (by ``component``) or "period $T$ [s]".
        legend: add a legend: the branches, and solid/dashed as ``stability_labels``.
        lw: line width.

    Returns:
        The axes.
    """
    from matplotlib.lines import Line2D

    from .curves import new_axes

    ax = new_axes(ax)
    bs = _as_list(branches)
    nodes = _per_branch(node, len(bs), "node")
    if len(bs) == 1 and stable is not None and np.ndim(stable) == 1 and len(stable) and np.isscalar(stable[0]):
        stable = [stable]
    stables = _per_branch(stable, len(bs), "stable")
    colors = list(colors) if colors is not None else [f"C{i}" for i in range(len(bs))]
    handles = []
    for i, (b, n, st) in enumerate(zip(bs, nodes, stables)):
        x, y = branch_curve(b, node=n, component=component, quantity=quantity)
        ok = np.asarray(b.stable if st is None or len(st) == 0 else st, dtype=bool)
        if ok.shape != np.shape(b.mass_flow):
            raise ValueError(f"branch {i}: {ok.size} stabilities for {len(b.mass_flow)} orbits")
        ok = np.concatenate([ok[:1], ok])  # the Hopf point as its first orbit
        color = colors[i % len(colors)]
        # one line per segment: the dashes start at each orbit, so that branches drawn on
        # top of each other keep their dashes in phase
        for k in range(len(x) - 1):
            ax.plot(x[k:k + 2], y[k:k + 2], "-" if ok[k] and ok[k + 1] else "--", color=color, lw=lw)
        ax.plot(x[0], y[0], "o", color=color, ms=4)
        if labels is not None and i < len(labels):
            handles.append(Line2D([], [], color=color, lw=lw, label=labels[i]))
    ax.set_xlabel(r"mass flow $\dot m$ [kg/s]")
    if ylabel is None:
        ylabel = (rf"amplitude $A_{_COMPONENTS[component]}$ [m]" if quantity == "amplitude" else r"period $T$ [s]")
    ax.set_ylabel(ylabel)
    ax.grid(True, lw=0.3)
    if legend:
        handles += [Line2D([], [], color="0.5", ls="-", label=stability_labels[0]),
                    Line2D([], [], color="0.5", ls="--", label=stability_labels[1]),
                    Line2D([], [], color="0.5", ls="none", marker="o", ms=4, label="Hopf point")]
        ax.legend(handles=handles, fontsize=8)
    return ax
