"""Animations of a time integration (matplotlib.animation) and a writer helper."""
from __future__ import annotations

import shutil
from pathlib import Path
from typing import Optional, Union

import numpy as np

from . import _axes
from .centreline import centre_line_from_frames


def animate(result, model, *, every: int = 1, ax=None, plane: Optional[str] = None, interval: float = 40.0,
            n_points: int = 9, trace: Optional[int] = None, color: str = "k"):
    """An animation of a :class:`~pipeflex.TransientResult`: the centre line at each output
    time, drawn with the shape functions from the node positions and rotations
    (:func:`~pipeflex.plot.centreline.centre_line_from_frames`).

    Args:
        result: the transient result (``x``, ``R`` at the times ``t``).
        model: the model it was computed with.
        every: draw every ``every``-th output time.
        ax: 3D axes (or 2D with ``plane``); default new ones.
        plane: "xy", "xz" or "yz" for a 2D projection.
        interval: [ms] delay between frames.
        n_points: points per element.
        trace: a node whose path is drawn as it goes (None: no trace).
        color: colour of the centre line.

    Returns:
        A ``matplotlib.animation.FuncAnimation`` (its figure: ``.fig``; write it with
        :func:`save`).
    """
    from matplotlib.animation import FuncAnimation

    every = max(1, int(every))
    frames = np.arange(0, len(result.t), every)
    if len(frames) == 0:
        raise ValueError("the result has no output times")
    ax = _axes.space_axes(ax, plane=plane)
    lines = []
    first = centre_line_from_frames(model, result.x[0], result.R[0], n_points=n_points)
    for pts in first:
        line, = ax.plot(*_axes.coords(ax, pts, plane), "-", color=color, lw=2)
        lines.append(line)
    path = None
    if trace is not None:
        path, = ax.plot(*_axes.coords(ax, result.x[:1, trace], plane), "-", color="C1", lw=0.8,
                        label=f"node {trace}")
        ax.legend(fontsize=8)
    stamp = (ax.text2D if _axes.is_3d(ax) else ax.text)(0.02, 0.95, "", transform=ax.transAxes)
    _axes.label_space(ax, plane)
    _axes.equal_scale(ax, result.x[frames].reshape(-1, 3), plane)

    def draw(i):
        for line, pts in zip(lines, centre_line_from_frames(model, result.x[i], result.R[i], n_points=n_points)):
            c = _axes.coords(ax, pts, plane)
            if _axes.is_3d(ax):
                line.set_data_3d(*c)
            else:
                line.set_data(*c)
        if path is not None:
            c = _axes.coords(ax, result.x[:i + 1, trace], plane)
            if _axes.is_3d(ax):
                path.set_data_3d(*c)
            else:
                path.set_data(*c)
        stamp.set_text(f"$t$ = {result.t[i]:.4g} s")
        return lines + ([path] if path is not None else []) + [stamp]

    anim = FuncAnimation(ax.figure, draw, frames=frames, interval=interval, blit=False)
    anim.ax = ax
    return anim


def save(animation, path: Union[str, Path], *, fps: Optional[float] = None, dpi: int = 100) -> Path:
    """Write an animation: mp4 (FFMpegWriter) when ``ffmpeg`` is on PATH and ``path`` ends in
    ``.mp4``, else a gif (PillowWriter; ``path`` with the suffix ``.gif``). ``fps``: frames
    per second (default from the animation's interval). Returns the path written."""
    from matplotlib.animation import FFMpegWriter, PillowWriter

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fps = fps if fps is not None else 1000.0 / max(float(getattr(animation, "_interval", 40.0)), 1.0)
    if path.suffix == ".mp4" and shutil.which("ffmpeg"):
        writer = FFMpegWriter(fps=fps)
    else:
        path = path.with_suffix(".gif")
        writer = PillowWriter(fps=fps)
    animation.save(str(path), writer=writer, dpi=dpi)
    return path
