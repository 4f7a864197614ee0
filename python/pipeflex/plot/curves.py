"""Line charts of results: time histories, curves against a parameter, computed values
against published ones, error against cost, and centre lines or paths in a plane."""
from __future__ import annotations

from typing import Optional, Sequence

import numpy as np

from . import _axes

#: The package's convention for computed against published values (matplotlib line
#: options): computed curves are lines ("computed"), the points of a computation where
#: they matter filled markers ("computed points"), published values open circles
#: ("published", in the colour of the computed curve they belong to; drawn on top).
#: Nothing computed is drawn as an open circle.
STYLES = {
    "computed": dict(ls="-", lw=1.5),
    "computed points": dict(marker="s", ms=4),
    "published": dict(ls="none", marker="o", mfc="none", ms=7, mew=1.3, zorder=4),
}

#: Markers of the groups of :func:`error_cost` (filled: computed; no circle, the published symbol).
MARKERS = ("s", "^", "D", "v", "<", ">", "p")


def is_published_style(line) -> bool:
    """Is the matplotlib line drawn in the "published" style (open circles, no line)?"""
    return (line.get_marker() == STYLES["published"]["marker"] and line.get_linestyle() in ("None", "none", "")
            and str(line.get_markerfacecolor()).lower() == "none")


def new_axes(ax=None, figsize=(6.4, 4.5)):
    """``ax``, or new 2D axes of ``figsize`` [in]."""
    if ax is not None:
        return ax
    import matplotlib.pyplot as plt

    _, ax = plt.subplots(figsize=figsize)
    return ax


def _per_curve(x, n: int):
    """One abscissa per curve: ``x`` shared (a 1-D array) or a sequence of ``n`` arrays."""
    try:
        arr = np.asarray(x, dtype=float)
    except (TypeError, ValueError):
        arr = None
    if arr is not None and arr.ndim == 1:
        return [arr] * n
    xs = [np.asarray(v, dtype=float) for v in x]
    if len(xs) != n:
        raise ValueError(f"got {len(xs)} abscissae for {n} curves")
    return xs


def _curves(ys):
    """A sequence of 1-D arrays from one array (one curve) or a sequence of them."""
    try:
        arr = np.asarray(ys, dtype=float)
    except (TypeError, ValueError):
        arr = None
    if arr is not None and arr.ndim == 1:
        return [arr]
    return [np.asarray(y, dtype=float) for y in ys]


def _style(styles, i):
    """(fmt, kwargs) of curve ``i``: ``styles[i]`` is a format string or a dict of kwargs."""
    if styles is None or i >= len(styles) or styles[i] is None:
        return (), {}
    s = styles[i]
    if isinstance(s, str):
        return (s,), {}
    return (), dict(s)


def _label(text: str, unit: Optional[str]) -> str:
    return text if not unit else f"{text} [{unit}]"


def readable_log_ticks(ax, axes: str = "xy"):
    """Label a log axis that spans less than two decades at 1, 2, 3 and 5 times the powers
    of ten (plain numbers): matplotlib labels only the powers of ten there, which can
    leave a single tick label. Decided on the current limits; other axes are left alone.

    Args:
        ax: the axes. axes: which of them, "x", "y" or "xy".
    """
    from matplotlib.ticker import LogLocator, NullFormatter, ScalarFormatter

    for name in axes:
        axis = ax.xaxis if name == "x" else ax.yaxis
        if axis.get_scale() != "log":
            continue
        lo, hi = sorted(ax.get_xlim() if name == "x" else ax.get_ylim())
        if lo <= 0.0 or np.log10(hi / lo) >= 2.0:
            continue
        axis.set_major_locator(LogLocator(base=10.0, subs=(1.0, 2.0, 3.0, 5.0)))
        fmt = ScalarFormatter()
        fmt.set_scientific(not 1e-3 <= hi < 1e5)
        axis.set_major_formatter(fmt)
        axis.set_minor_formatter(NullFormatter())


def _finish(ax, *, title, legend, legend_title=None, grid_which="major"):
    if title:
        ax.set_title(title, fontsize=10)
    ax.grid(True, which=grid_which, lw=0.3)
    if legend and any(not h.get_label().startswith("_") for h in ax.get_lines() + ax.collections):
        ax.legend(fontsize=8, title=legend_title, title_fontsize=8)
    return ax


def published_points(x, y, *, ax=None, color="k", label: Optional[str] = None, **options):
    """Published values drawn as the package draws them: open circles
    (:data:`STYLES` ["published"]) above the computed curves.

    Args:
        x: (n,) their abscissae (e.g. a parameter, or the time [s] of a final value).
        y: (n,) the published values, in the units of the axes.
        ax: axes to draw on; default new ones.
        color: of the circles (that of the computed curve they belong to).
        label: legend entry (None: no entry).
        options: further line options (e.g. ``ms``).

    Returns:
        The matplotlib line of the circles.
    """
    ax = new_axes(ax)
    xs, ys = np.atleast_1d(np.asarray(x, dtype=float)), np.atleast_1d(np.asarray(y, dtype=float))
    if xs.shape != ys.shape or xs.ndim != 1:
        raise ValueError(f"x and y must be 1-D arrays of one length, got shapes {xs.shape} and {ys.shape}")
    kw = dict(STYLES["published"], color=color)
    kw.update(options)
    if label is not None:
        kw["label"] = label
    line, = ax.plot(xs, ys, **kw)
    return line


def parameter_curves(x, ys, *, xlabel: str, ylabel: str, labels: Optional[Sequence[str]] = None,
                     styles: Optional[Sequence] = None, scale: float = 1.0, xscale: str = "linear",
                     yscale: str = "linear", ax=None, title: Optional[str] = None, legend: bool = True,
                     legend_title: Optional[str] = None):
    """Curves of quantities against a parameter (a sweep, a refinement, a convergence study).

    Args:
        x: (n,) the parameter, shared; or one array per curve.
        ys: (n,) one curve, or a sequence of curves.
        xlabel, ylabel: axis labels with units, e.g. ``r"mass flow $\\dot m$ [kg/s]"``.
        labels: one legend label per curve (None: no entry).
        styles: per curve a matplotlib format string (``"o-"``) or a dict of line options.
        scale: factor applied to every y before drawing (e.g. 1e3 for mm).
        xscale, yscale: "linear" or "log".
        ax: axes to draw on; default new ones.
        title: of the axes. legend: add a legend (if any curve has a label).
        legend_title: title of the legend.

    Returns:
        The axes.
    """
    ax = new_axes(ax)
    curves = _curves(ys)
    xs = _per_curve(x, len(curves))
    for i, (xi, yi) in enumerate(zip(xs, curves)):
        if xi.shape != yi.shape:
            raise ValueError(f"curve {i}: {yi.shape[0] if yi.ndim else 0} values for {xi.shape[0]} parameters")
        fmt, kw = _style(styles, i)
        if labels is not None and i < len(labels) and labels[i] is not None:
            kw.setdefault("label", labels[i])
        ax.plot(xi, scale * yi, *fmt, **kw)
    ax.set_xscale(xscale)
    ax.set_yscale(yscale)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    logs = "log" in (xscale, yscale)
    readable_log_ticks(ax)
    return _finish(ax, title=title, legend=legend, legend_title=legend_title, grid_which="both" if logs else "major")


def time_history(t, series, *, quantity: str, unit: str, labels: Optional[Sequence[str]] = None,
                 styles: Optional[Sequence] = None, scale: float = 1.0, yscale: str = "linear", ax=None,
                 title: Optional[str] = None, legend: bool = True):
    """Time histories: each series against time t [s].

    Args:
        t: (n,) times [s], shared; or one array per series (runs of different lengths).
        series: (n,) one series, or a sequence of them.
        quantity: what is drawn (e.g. ``"tip deflection $w$"``); unit: its unit after
            ``scale`` (e.g. ``"m"``, ``"rad/s"``): the label is "quantity [unit]".
        labels, styles, scale, yscale, ax, title, legend: as :func:`parameter_curves`.

    Returns:
        The axes.
    """
    return parameter_curves(t, series, xlabel="time $t$ [s]", ylabel=_label(quantity, unit), labels=labels,
                            styles=styles, scale=scale, yscale=yscale, ax=ax, title=title, legend=legend)


def comparison(x, ours, published, *, xlabel: str, ylabel: str, x_published=None,
               labels: Optional[Sequence[str]] = None, ours_label: str = "lines: ours",
               published_label: str = "circles: published", ax=None, title: Optional[str] = None,
               legend: bool = True, yscale: str = "linear"):
    """Computed curves (lines) against published values (open circles of the same colour).

    Args:
        x: (n,) the parameter of the computed curves (shared, or one array per curve).
        ours: (n,) one computed curve, or a sequence of them.
        published: the published values, one array per curve (at ``x_published``).
        x_published: their parameter (shared, or one array per curve); default ``x``.
        xlabel, ylabel: axis labels with units.
        labels: one legend label per case.
        ours_label, published_label: the legend entries saying which is which.
        ax, title, legend, yscale: as :func:`parameter_curves`.

    Returns:
        The axes.
    """
    from matplotlib.lines import Line2D

    ax = new_axes(ax)
    curves, pubs = _curves(ours), _curves(published)
    if len(curves) != len(pubs):
        raise ValueError(f"{len(curves)} computed curves but {len(pubs)} published ones")
    xs = _per_curve(x, len(curves))
    xp = _per_curve(x if x_published is None else x_published, len(pubs))
    for i, (xi, yi, xpi, pi) in enumerate(zip(xs, curves, xp, pubs)):
        if xpi.shape != pi.shape or xi.shape != yi.shape:
            raise ValueError(f"case {i}: the values and their parameters differ in length")
        label = labels[i] if labels is not None and i < len(labels) else None
        line, = ax.plot(xi, yi, **STYLES["computed"], label=label)
        published_points(xpi, pi, ax=ax, color=line.get_color())
    ax.set_yscale(yscale)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    if title:
        ax.set_title(title, fontsize=10)
    ax.grid(True, lw=0.3)
    if legend:
        handles, _ = ax.get_legend_handles_labels()
        handles += [Line2D([], [], color="0.3", ls="-", label=ours_label),
                    Line2D([], [], **dict(STYLES["published"], color="0.3"), label=published_label)]
        ax.legend(handles=handles, fontsize=8)
    return ax


def error_cost(costs, errors, *, groups: Optional[Sequence[str]] = None, labels: Optional[Sequence[str]] = None,
               tolerance: Optional[float] = None, floor: float = 0.0, xlabel: str = "wall time [s]",
               ylabel: str = "relative error [-]", ax=None, title: Optional[str] = None, legend: bool = True):
    """Error against cost on log axes: one marker and colour per group (e.g. a family of
    models), each point annotated with its label; a horizontal line at ``tolerance``.

    Args:
        costs: (n,) the cost of each point (wall time [s], size of the state, ...).
        errors: (n,) its error; values below ``floor`` are drawn at ``floor``.
        groups: (n,) group name of each point (legend entries); default one group.
        labels: (n,) text next to each point; default none.
        tolerance: an error to reach: a dashed horizontal line.
        xlabel, ylabel: axis labels with units. ax, title, legend: as :func:`parameter_curves`.

    Returns:
        The axes.
    """
    ax = new_axes(ax, figsize=(7.5, 4.8))
    c = np.asarray(costs, dtype=float)
    e = np.maximum(np.asarray(errors, dtype=float), floor)
    if c.shape != e.shape or c.ndim != 1:
        raise ValueError("costs and errors must be 1-D arrays of one length")
    g = np.asarray(["" for _ in c] if groups is None else list(groups), dtype=object)
    if len(g) != len(c) or (labels is not None and len(labels) != len(c)):
        raise ValueError("groups and labels need one entry per point")
    for k, name in enumerate(dict.fromkeys(g)):
        sel = np.flatnonzero(g == name)
        ax.loglog(c[sel], e[sel], MARKERS[k % len(MARKERS)], color=f"C{k}", ms=6, alpha=0.85, label=name or None)
    if tolerance is not None:
        ax.axhline(float(tolerance), color="0.4", ls="--", lw=0.8, label=f"tolerance {float(tolerance):g}")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    if labels is not None:
        colour = {name: f"C{k}" for k, name in enumerate(dict.fromkeys(g))}
        label_points(ax, np.column_stack([c, e]), [str(t) for t in labels], colors=[colour[n] for n in g])
    readable_log_ticks(ax)
    return _finish(ax, title=title, legend=legend, grid_which="both")


#: Offsets [pt] of a label from its point tried by :func:`label_points`, nearest first:
#: (dx, dy, horizontal alignment, vertical alignment).
_LABEL_OFFSETS = tuple((f * dx, f * dy, ha, va) for f in (1, 2.2, 3.6) for dx, dy, ha, va in (
    (5, 0, "left", "center"), (4, 4, "left", "bottom"), (4, -4, "left", "top"), (-5, 0, "right", "center"),
    (0, 6, "center", "bottom"), (0, -6, "center", "top"), (-4, 4, "right", "bottom"), (-4, -4, "right", "top")))


def label_points(ax, points, texts: Sequence[str], *, colors=None, fontsize: float = 6.5, marker_size: float = 8.0):
    """Write ``texts`` next to their ``points`` without overlapping one another or the
    points' markers: each label takes the nearest free place around its point (right,
    above right, below right, left, above, below, ..., then farther out with a thin
    leader line); where none is free, the least covered one. Call it once the axes
    limits are final (it works in display space).

    Args:
        ax: the axes (2D, linear or log scales).
        points: (n, 2) data coordinates of the points.
        texts: (n,) the labels. colors: (n,) their colours (default black).
        fontsize: [pt] of the labels. marker_size: [pt] the size of the markers to keep clear.

    Returns:
        The list of matplotlib annotations.
    """
    pts = np.atleast_2d(np.asarray(points, dtype=float))
    if pts.shape[1] != 2 or len(pts) != len(texts) or (colors is not None and len(colors) != len(texts)):
        raise ValueError(f"points must be (n, 2) with one text (and colour) per point, got {pts.shape} "
                         f"and {len(texts)} texts")
    fig = ax.figure
    ax.autoscale_view()
    renderer = fig.canvas.get_renderer()
    to_px = fig.dpi / 72.0
    disp = ax.transData.transform(pts)
    half = 0.5 * marker_size * to_px
    markers = np.column_stack([disp - half, disp + half])      # (x0, y0, x1, y1) per marker
    frame = ax.get_window_extent(renderer)
    taken = [m for m in markers]
    out = []

    def covered(b):
        area = 0.0
        for o in taken:
            w = min(b[2], o[2]) - max(b[0], o[0])
            h = min(b[3], o[3]) - max(b[1], o[1])
            if w > 0 and h > 0:
                area += w * h
        outside = (max(0.0, frame.x0 - b[0]) + max(0.0, b[2] - frame.x1)) * (b[3] - b[1]) + \
                  (max(0.0, frame.y0 - b[1]) + max(0.0, b[3] - frame.y1)) * (b[2] - b[0])
        return area + 4.0 * outside

    for i, text in enumerate(texts):
        color = "k" if colors is None else colors[i]
        note = ax.annotate(text, pts[i], textcoords="offset points", xytext=(0, 0), fontsize=fontsize, color=color)
        best = None
        for dx, dy, ha, va in _LABEL_OFFSETS:
            note.set_position((dx, dy))
            note.set_ha(ha)
            note.set_va(va)
            e = note.get_window_extent(renderer)
            box = (e.x0 - 1, e.y0 - 1, e.x1 + 1, e.y1 + 1)
            cost = covered(box)
            if best is None or cost < best[0]:
                best = (cost, dx, dy, ha, va, box)
            if cost == 0.0:
                break
        _, dx, dy, ha, va, box = best
        note.set_position((dx, dy))
        note.set_ha(ha)
        note.set_va(va)
        if abs(dx) > 6 or abs(dy) > 7:     # moved away from its point: a leader line
            note.remove()
            note = ax.annotate(text, pts[i], textcoords="offset points", xytext=(dx, dy), ha=ha, va=va,
                               fontsize=fontsize, color=color,
                               arrowprops=dict(arrowstyle="-", lw=0.4, color=color, shrinkA=0, shrinkB=3))
        taken.append(np.array(box))
        out.append(note)
    return out


def paths(curves, *, plane: str = "xy", labels: Optional[Sequence[str]] = None, styles: Optional[Sequence] = None,
          xlabel: Optional[str] = None, ylabel: Optional[str] = None, equal: bool = True, ax=None,
          title: Optional[str] = None, legend: bool = True, legend_title: Optional[str] = None):
    """Points in space drawn in a plane: centre lines (deformed shapes), trajectories.

    Args:
        curves: a sequence of (n, 3) arrays of points [m].
        plane: "xy", "xz" or "yz": the coordinates drawn.
        labels, styles: per curve, as :func:`parameter_curves`.
        xlabel, ylabel: default "$x$ [m]" etc. of the plane.
        equal: equal scaling of both axes.
        ax, title, legend, legend_title: as :func:`parameter_curves`.

    Returns:
        The axes.
    """
    ax = new_axes(ax, figsize=(6, 4.5))
    i, j = _axes.plane_of(ax, plane)
    for k, p in enumerate(curves):
        p = np.atleast_2d(np.asarray(p, dtype=float))
        if p.shape[1] != 3:
            raise ValueError(f"curve {k}: points must be (n, 3), got {p.shape}")
        fmt, kw = _style(styles, k)
        if labels is not None and k < len(labels) and labels[k] is not None:
            kw.setdefault("label", labels[k])
        ax.plot(p[:, i], p[:, j], *fmt, **kw)
    ax.set_xlabel(xlabel or _axes.AXIS_LABELS[i])
    ax.set_ylabel(ylabel or _axes.AXIS_LABELS[j])
    if equal:
        ax.set_aspect("equal")
    return _finish(ax, title=title, legend=legend, legend_title=legend_title)
