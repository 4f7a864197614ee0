"""Eigenvalues of a model as a parameter varies: paths and root-locus charts."""
from __future__ import annotations

from typing import Optional, Sequence

import numpy as np

from ..analysis import eigenvalues, linearize

PANELS = ("argand", "frequency", "growth")


def eigenvalue_paths(model, mass_flows, *, n_modes=4):
    """Eigenvalues of the lowest ``n_modes`` (by frequency at zero flow, Im > 0) along
    ``mass_flows`` [kg/s], followed by proximity (an overdamped mode continues on the
    real axis). Returns a complex array (flows, modes)."""
    paths = []
    prev = None
    for m in mass_flows:
        lam = eigenvalues(linearize(model, mass_flow=m)).values
        lam = lam[lam.imag >= 0]
        if prev is None:
            lam = lam[lam.imag > 0]
            prev = []
            for x in lam[np.argsort(lam.imag)]:  # lowest frequencies; planes counted once
                if not any(abs(x - y) <= 1e-9 * abs(x) for y in prev):
                    prev.append(x)
            prev = prev[:n_modes]
        # nearest; on a tie (a pair splitting on the real axis) follow the growing one
        cur = np.array([lam[np.argmin(np.abs(lam - p) - 1e-9 * lam.real)] for p in prev])
        paths.append(cur)
        prev = cur
    return np.array(paths)


def root_locus(paths, parameter, *, axes=None, panels: Sequence[str] = ("argand", "growth"),
               parameter_label: str = r"mass flow $\dot m$ [kg/s]", critical: Optional[float] = None,
               labels: Optional[Sequence[str]] = None):
    """Charts of eigenvalue paths ``paths`` (n_parameter, n_modes) [1/s] along ``parameter``:
    "argand" (Im against Re), "frequency" (Im against the parameter), "growth" (Re against
    the parameter), one panel each.

    Args:
        paths: complex eigenvalues lambda [1/s], e.g. from :func:`eigenvalue_paths`.
        parameter: (n_parameter,) the varied parameter.
        axes: one axes per panel; default a new figure with a row of them.
        panels: which panels, in order.
        parameter_label: the parameter's axis label (with unit).
        critical: a parameter value to mark (dashed line) on the panels against it.
        labels: one legend label per mode (default "mode 1", ...).

    Returns:
        The list of axes.
    """
    paths = np.asarray(paths)
    for p in panels:
        if p not in PANELS:
            raise ValueError(f"panels must be among {PANELS}, got {p!r}")
    if axes is None:
        import matplotlib.pyplot as plt

        _, axes = plt.subplots(1, len(panels), figsize=(5 * len(panels), 3.9))
    axes = list(np.atleast_1d(axes))
    labels = labels or [f"mode {k + 1}" for k in range(paths.shape[1])]
    for ax, panel in zip(axes, panels):
        for k in range(paths.shape[1]):
            lam = paths[:, k]
            if panel == "argand":
                ax.plot(lam.real, lam.imag, ".-", ms=3, label=labels[k])
            else:
                ax.plot(parameter, lam.imag if panel == "frequency" else lam.real, label=labels[k])
        if panel == "argand":
            ax.axvline(0, color="k", lw=0.6)
            ax.set_xlabel(r"Re $\lambda$ [1/s]")
            ax.set_ylabel(r"Im $\lambda$ [rad/s]")
        else:
            ax.set_xlabel(parameter_label)
            ax.set_ylabel(r"Im $\lambda$ [rad/s]" if panel == "frequency" else r"Re $\lambda$ [1/s]")
            if panel == "growth":
                ax.axhline(0, color="k", lw=0.6)
            if critical is not None:
                ax.axvline(critical, color="r", ls="--", lw=0.8, label="critical")
        ax.grid(lw=0.3)
        ax.legend(fontsize=8)
    return axes


def root_locus_figure(model, mass_flows, *, n_modes=4, critical=None):
    """Argand diagram and growth rate of the lowest modes as the mass flow rises (a figure)."""
    paths = eigenvalue_paths(model, mass_flows, n_modes=n_modes)
    axes = root_locus(paths, mass_flows, critical=critical)
    fig = axes[0].figure
    fig.tight_layout()
    return fig
