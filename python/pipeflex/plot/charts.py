"""Charts of results: Campbell diagram, stability map, work-precision diagram."""
from __future__ import annotations

from typing import Optional, Sequence

import numpy as np

#: Colour and line style of each Campbell family.
FAMILY_STYLES = {"in-plane": ("C0", "-"), "flapwise": ("C1", "--"), "axial": ("C2", "-.")}


def _axes(ax, figsize=(6.4, 4.5)):
    if ax is not None:
        return ax
    import matplotlib.pyplot as plt

    _, ax = plt.subplots(figsize=figsize)
    return ax


def campbell(result, *, ax=None, dimensionless: Optional[bool] = None, excitation: bool = True,
             crossings: bool = True, legend: bool = True):
    """Campbell diagram of a :class:`~pipeflex.analysis.campbell.Campbell` result: each branch
    against the rotation rate (colour and style by family), the excitation lines
    omega = k Omega (grey, labelled), and the crossings with them (red circles).

    Args:
        result: the Campbell result.
        ax: axes to draw on; default new ones.
        dimensionless: plot omega/omega0 against gamma = Omega/omega0; default: if the
            result was computed for ``gamma``.
        excitation: draw the lines omega = k Omega.
        crossings: mark the crossings.
        legend: add a legend (one entry per family).

    Returns:
        The axes.
    """
    ax = _axes(ax)
    dimless = (result.gamma is not None) if dimensionless is None else bool(dimensionless)
    unit = float(result.omega0) if dimless else 1.0
    if dimless and not np.isfinite(unit):
        raise ValueError("the result has no omega0: use dimensionless=False")
    x = np.asarray(result.speeds) / unit
    seen = set()
    for b, fam in enumerate(result.family):
        c, ls = FAMILY_STYLES.get(str(fam), ("C3", ":"))
        ax.plot(x, result.frequencies[:, b] / unit, ls, color=c, lw=1.5,
                label=None if fam in seen else f"{fam}")
        seen.add(fam)
    top = 1.08 * np.nanmax(result.frequencies) / unit
    if excitation:
        for k in result.harmonics:
            xe = np.array([0.0, min(x[-1], top / k)])
            ax.plot(xe, k * xe, ":", color="0.45", lw=1)
            ax.annotate(rf"${k}\Omega$" if k > 1 else r"$\Omega$", (xe[-1], k * xe[-1]), fontsize=8, color="0.35",
                        textcoords="offset points", xytext=(2, -8))
    if crossings and len(result.crossing_speed):
        ax.plot(np.asarray(result.crossing_speed) / unit, np.asarray(result.crossing_frequency) / unit, "o",
                mfc="none", mec="C3", ms=7, label=r"$\omega = k\Omega$")
    ax.set_xlim(x[0], x[-1])
    ax.set_ylim(0.0, top)
    if dimless:
        ax.set_xlabel(r"$\gamma = \Omega/\omega_0$ [-]")
        ax.set_ylabel(r"$\omega/\omega_0$ [-]")
    else:
        ax.set_xlabel(r"rotation rate $\Omega$ [rad/s]")
        ax.set_ylabel(r"frequency $\omega$ [rad/s]")
    ax.grid(lw=0.3)
    if legend:
        ax.legend(fontsize=8)
    return ax


def stability_map(mass_ratio, u_cr, frequency, *, ax=None, kind: Optional[Sequence[str]] = None,
                  xlabel: str = r"mass ratio $\beta$ [-]", ylabel: str = r"critical flow speed $u_{cr}$ [-]",
                  frequency_label: str = r"frequency $\omega_{cr}$ [-]"):
    """Stability map: the critical flow speed against the mass ratio (left axis, solid) and
    the frequency at the onset (right axis, dashed), e.g. Gregory & Paidoussis's cantilever.

    Args:
        mass_ratio: (n,) beta [-] = rho_f A_f / (rho_f A_f + m), or another abscissa.
        u_cr: (n,) critical flow speed (dimensionless by default; set ``ylabel``).
        frequency: (n,) frequency at the critical flow (0 for divergence), or None.
        ax: axes to draw on; default new ones. The frequency goes on ``ax.twinx()``.
        kind: (n,) "flutter"/"divergence" per point: divergence points are marked by squares.
        xlabel, ylabel, frequency_label: axis labels (with units).

    Returns:
        The axes (the twin axes of the frequency: ``ax.frequency_axes``).
    """
    ax = _axes(ax)
    b = np.asarray(mass_ratio, dtype=float)
    u = np.asarray(u_cr, dtype=float)
    if b.shape != u.shape or b.ndim != 1:
        raise ValueError("mass_ratio and u_cr must be 1-D arrays of one length")
    ax.plot(b, u, "-", color="C0", lw=1.6, label=ylabel.split(" [")[0])
    if kind is not None:
        div = np.array([str(k) == "divergence" for k in kind])
        if div.any():
            ax.plot(b[div], u[div], "s", mfc="none", mec="C0", label="divergence")
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel, color="C0")
    ax.grid(lw=0.3)
    if frequency is not None:
        w = np.asarray(frequency, dtype=float)
        if w.shape != b.shape:
            raise ValueError("frequency must have the shape of mass_ratio")
        twin = ax.twinx()
        twin.plot(b, w, "--", color="C1", lw=1.2, label=frequency_label.split(" [")[0])
        twin.set_ylabel(frequency_label, color="C1")
        ax.frequency_axes = twin
    return ax


def work_precision(runs, *, reference_name: Optional[str] = None, target: Optional[float] = None, ax=None,
                   quantity: str = "the quantity of interest", title: Optional[str] = None,
                   annotate: bool = True, labels: Optional[dict] = None):
    """Work-precision diagram: error of a quantity against wall time, log-log, one line per
    method (``run.integrator``, or a named setting's ``run.label``; the runs of
    :func:`pipeflex.work_precision.work_precision` or any objects with ``integrator``,
    ``setting``, ``error``, ``wall_time``).

    Args:
        runs: the runs.
        reference_name: what the errors are measured against (shown on the error axis).
        target: an error [unit of the quantity] to reach: a horizontal line.
        ax: axes to draw on; default new ones.
        quantity: name (and unit) of the quantity of interest.
        title: of the axes.
        annotate: write each run's setting (step [s] or rtol) next to its point.
        labels: method name -> legend label (default: generalised-alpha (step), IDA (rtol),
            a named setting "generalised-alpha, <name> (step)").

    Returns:
        The axes.
    """
    ax = _axes(ax, figsize=(6, 4.2))
    names = {"generalized_alpha": "generalised-alpha (step $h$ [s])", "ida": "IDA (rtol [-])"}

    def method(r):
        return getattr(r, "label", None) or r.integrator

    for r in runs:
        if getattr(r, "label", None):
            names.setdefault(r.label, f"generalised-alpha, {r.label} (step $h$ [s])")
    names.update(labels or {})
    methods = list(dict.fromkeys(method(r) for r in runs))
    markers = "os^vD<>"
    for i, m in enumerate(methods):
        rs = [r for r in runs if method(r) == m]
        err = [max(r.error, 1e-16) for r in rs]
        ax.loglog([r.wall_time for r in rs], err, markers[i % len(markers)] + "-", label=names.get(m, m))
        if annotate:
            for r, e in zip(rs, err):
                ax.annotate(f"{r.setting:.0e}", (r.wall_time, e), fontsize=7, textcoords="offset points",
                            xytext=(4, 2))
    if target is not None:
        ax.axhline(float(target), color="C3", ls="--", lw=1, label=f"target {float(target):.0e}")
    ax.set_xlabel("wall time [s]")
    ax.set_ylabel(f"error of {quantity}" + (f"\nagainst {reference_name}" if reference_name else ""))
    if title:
        ax.set_title(title)
    ax.grid(True, which="both", lw=0.3)
    ax.legend(fontsize=8)
    return ax


def deviation_map(deviations, *, row_labels: Optional[Sequence[str]] = None,
                  column_labels: Optional[Sequence[str]] = None, xlabel: str = "", ylabel: str = "",
                  vmin: float = -7.0, vmax: float = -1.0, floor: float = 1e-8, flag: Optional[float] = None,
                  flag_mask=None, divider: Optional[float] = None, ax=None, title: Optional[str] = None,
                  colorbar: bool = True, colorbar_label: str = r"$\log_{10}|\delta|$ [-]"):
    """A table of relative deviations as a colour map of ``log10 |deviation|`` (e.g. computed
    against published values, one row per configuration, one column per parameter value).

    Args:
        deviations: (rows, columns) relative deviations [-]; values of magnitude below ``floor`` are drawn at it.
        row_labels, column_labels: tick labels. xlabel, ylabel: axis labels.
        vmin, vmax: colour range in log10 [-].
        flag: cells whose deviation exceeds it in magnitude are outlined in red (within ``flag_mask``,
            a boolean (rows, columns) array, if given).
        divider: a column position (e.g. 5.5) to draw a white vertical line at.
        ax: axes to draw on; default new ones. title: of the axes.
        colorbar: add a colour bar (on the axes' figure, labelled ``colorbar_label``).

    Returns:
        The axes (the image as ``ax.deviation_image``).
    """
    import matplotlib.patches as patches

    ax = _axes(ax)
    d = np.abs(np.asarray(deviations, dtype=float))
    if d.ndim != 2:
        raise ValueError(f"deviations must be 2-D, got shape {d.shape}")
    im = ax.imshow(np.log10(np.maximum(d, floor)), vmin=vmin, vmax=vmax, cmap="viridis", aspect="auto")
    if divider is not None:
        ax.axvline(float(divider), color="w", lw=1.5)
    if column_labels is not None:
        ax.set_xticks(range(d.shape[1]), list(column_labels))
    if row_labels is not None:
        ax.set_yticks(range(d.shape[0]), list(row_labels), fontsize=7)
    if flag is not None:
        sel = d > float(flag)
        if flag_mask is not None:
            sel &= np.asarray(flag_mask, dtype=bool)
        for i, j in zip(*np.nonzero(sel)):
            ax.add_patch(patches.Rectangle((j - 0.5, i - 0.5), 1, 1, fill=False, ec="r", lw=2))
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    if title:
        ax.set_title(title, fontsize=10)
    if colorbar:
        ax.figure.colorbar(im, ax=ax, shrink=0.7, label=colorbar_label)
    ax.deviation_image = im
    return ax
