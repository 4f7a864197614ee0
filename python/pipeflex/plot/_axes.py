"""Axes helpers shared by the drawings: new 3D or 2D axes, projection, equal scaling."""
from __future__ import annotations

import numpy as np

PLANES = {"xy": (0, 1), "xz": (0, 2), "yz": (1, 2)}
AXIS_LABELS = ("$x$ [m]", "$y$ [m]", "$z$ [m]")


def is_3d(ax) -> bool:
    return getattr(ax, "name", "") == "3d"


def space_axes(ax=None, *, plane=None):
    """``ax``, or new axes: 3D, or 2D in ``plane`` ("xy", "xz", "yz") if given."""
    if ax is not None:
        return ax
    import matplotlib.pyplot as plt

    if plane is None:
        fig = plt.figure(figsize=(6.4, 5.2))
        return fig.add_subplot(projection="3d")
    _, ax = plt.subplots(figsize=(6.4, 4.8))
    return ax


def plane_of(ax, plane):
    """The two coordinate indices drawn on 2D axes (default x-y)."""
    if plane is None:
        return PLANES["xy"]
    if plane not in PLANES:
        raise ValueError(f"plane must be one of {tuple(PLANES)}, got {plane!r}")
    return PLANES[plane]


def coords(ax, pts, plane):
    """The columns of the points ``pts`` (n, 3) to draw on ``ax``."""
    pts = np.atleast_2d(pts)
    if is_3d(ax):
        return pts[:, 0], pts[:, 1], pts[:, 2]
    i, j = plane_of(ax, plane)
    return pts[:, i], pts[:, j]


def label_space(ax, plane):
    if is_3d(ax):
        ax.set_xlabel(AXIS_LABELS[0])
        ax.set_ylabel(AXIS_LABELS[1])
        ax.set_zlabel(AXIS_LABELS[2])
    else:
        i, j = plane_of(ax, plane)
        ax.set_xlabel(AXIS_LABELS[i])
        ax.set_ylabel(AXIS_LABELS[j])


def equal_scale(ax, pts, plane, *, margin: float = 0.08):
    """Equal scaling on all axes around the points ``pts`` (n, 3)."""
    pts = np.atleast_2d(pts)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    span = max(float((hi - lo).max()), 1e-12)
    mid = 0.5 * (lo + hi)
    half = 0.5 * span * (1 + 2 * margin)
    if is_3d(ax):
        ax.set_xlim(mid[0] - half, mid[0] + half)
        ax.set_ylim(mid[1] - half, mid[1] + half)
        ax.set_zlim(mid[2] - half, mid[2] + half)
        ax.set_box_aspect((1, 1, 1))
    else:
        i, j = plane_of(ax, plane)
        ax.set_aspect("equal", adjustable="datalim")
        ax.update_datalim(np.array([[mid[i] - half, mid[j] - half], [mid[i] + half, mid[j] + half]]))
        ax.autoscale_view()


def arrows(ax, base, vec, plane, **kw):
    """Arrows from ``base`` (n, 3) along ``vec`` (n, 3) [m] (data units)."""
    base, vec = np.atleast_2d(base), np.atleast_2d(vec)
    if is_3d(ax):
        return ax.quiver(base[:, 0], base[:, 1], base[:, 2], vec[:, 0], vec[:, 1], vec[:, 2],
                         arrow_length_ratio=0.25, **kw)
    i, j = plane_of(ax, plane)
    return ax.quiver(base[:, i], base[:, j], vec[:, i], vec[:, j], angles="xy", scale_units="xy", scale=1,
                     width=0.008, **kw)
