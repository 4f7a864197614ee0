"""A mode shape drawn with the elements' shape functions."""
from __future__ import annotations

from typing import Optional, Sequence

import numpy as np

from ..state import State
from . import _axes
from .centreline import centre_line, mode_displacement, model_size


def mode_shape(model, mode, *, state=None, scale: Optional[float] = None, component: Optional[Sequence[float]] = None,
               ax=None, plane: Optional[str] = None, reference: bool = True, n_points: int = 17,
               flip: bool = False, color=None, linestyle: str = "-", label: Optional[str] = None):
    """Draw a mode shape with the elements' shape functions.

    The mode (complex ones turned to the phase of largest real translations) is normalised
    to a largest nodal translation of 1 (:func:`~pipeflex.plot.centreline.mode_displacement`)
    and its linear increments of positions and end tangents (``l0 dtheta x e_x`` for pipe
    elements, ``l dr'`` for ANCF ones) are added to the centre line of ``state``; the
    drawing of a rigid-body mode is rigid.

    Args:
        model: the :class:`~pipeflex.Model`.
        mode: (n_dofs,) mode shape in reduced coordinates (a column of
            ``EigenResult.vectors``, ``CriticalFlow.mode``, ``Campbell.modes[i, b]``), or
            (6 n_nodes,) nodal.
        state: the state the mode belongs to (default the reference configuration).
        scale: [m] largest nodal translation drawn; default 0.15 of the model's size (3D or
            ``plane``). With ``component``: the largest nodal ``|u . d|``, default 1.
        component: a direction d [-] (3,): draw instead the displacement along d, u . d,
            against the arc length s [m] of the elements (in the order of
            ``model.elements``), on 2D axes.
        ax: axes to draw on (3D, or 2D with ``plane`` or ``component``); default new ones.
        plane: "xy", "xz" or "yz": draw the projection on 2D axes.
        reference: also draw the undeformed centre line (grey, dashed; not with ``component``).
        n_points: points per element.
        flip: draw the mode with the opposite sign (the normalisation fixes the sign:
            largest nodal translation, or the largest value along ``component``, positive).
        color, linestyle, label: of the mode's line.

    Returns:
        The axes.
    """
    d = mode_displacement(model, mode) * (-1.0 if flip else 1.0)
    st = state if state is None or isinstance(state, State) else State.from_core(state, model)
    if component is not None:
        return _component(model, d, st, np.asarray(component, dtype=float), scale, ax, n_points, color, linestyle,
                           label)
    amp = 0.15 * model_size(model) if scale is None else float(scale)
    ax = _axes.space_axes(ax, plane=plane)
    base = centre_line(model, st, n_points=n_points)
    moved = centre_line(model, st, displacement=amp * d, n_points=n_points)
    if reference:
        for k, pts in enumerate(base):
            ax.plot(*_axes.coords(ax, pts, plane), "--", color="0.6", lw=1, label="undeformed" if k == 0 else None)
    for k, pts in enumerate(moved):
        line, = ax.plot(*_axes.coords(ax, pts, plane), linestyle, color=color, lw=1.8,
                        label=(label or "mode") if k == 0 else None)
        color = line.get_color()
    _axes.label_space(ax, plane)
    _axes.equal_scale(ax, np.vstack(base + moved), plane)
    return ax


def _component(model, d, st, direction, scale, ax, n_points, color, linestyle, label):
    n = np.linalg.norm(direction)
    if direction.shape != (3,) or n == 0:
        raise ValueError("component must be a non-zero 3-vector")
    direction = direction / n
    u = d.reshape(-1, 6)[:, :3] @ direction
    big = u[np.argmax(np.abs(u))]
    if big == 0:
        raise ValueError("the mode has no nodal displacement along component")
    amp = (1.0 if scale is None else float(scale)) / abs(big)
    base = centre_line(model, st, n_points=n_points)
    moved = centre_line(model, st, displacement=amp * d, n_points=n_points)
    if ax is None:
        import matplotlib.pyplot as plt

        _, ax = plt.subplots(figsize=(6.4, 4.0))
    xi = np.linspace(0.0, 1.0, int(n_points))
    s0 = 0.0
    for k, (e, p0, p1) in enumerate(zip(model.elements, base, moved)):
        line, = ax.plot(s0 + e.length * xi, (p1 - p0) @ direction, linestyle, color=color,
                        label=label if k == 0 else None)
        color = line.get_color()
        s0 += e.length
    ax.set_xlabel("arc length $s$ [m]")
    ax.set_ylabel(r"$\mathbf{u}\cdot\mathbf{d}$ [-] (largest nodal value %g)" % (1.0 if scale is None else scale))
    return ax
