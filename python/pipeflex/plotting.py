"""Figures of a model's eigenvalues as a parameter varies."""
from __future__ import annotations

import numpy as np

from .analysis import eigenvalues, linearize



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


def root_locus_figure(model, mass_flows, *, n_modes=4, critical=None):
    """Argand diagram and growth rate of the lowest modes as the mass flow rises."""
    import matplotlib.pyplot as plt

    paths = eigenvalue_paths(model, mass_flows, n_modes=n_modes)
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 4))
    for k in range(paths.shape[1]):
        a1.plot(paths[:, k].real, paths[:, k].imag, ".-", ms=3, label=f"mode {k + 1}")
        a2.plot(mass_flows, paths[:, k].real, label=f"mode {k + 1}")
    a1.axvline(0, color="k", lw=0.6)
    a1.set_xlabel("Re $\\lambda$ [1/s]")
    a1.set_ylabel("Im $\\lambda$ [rad/s]")
    a2.axhline(0, color="k", lw=0.6)
    if critical is not None:
        a2.axvline(critical, color="r", ls="--", lw=0.8, label="critical")
    a2.set_xlabel("mass flow [kg/s]")
    a2.set_ylabel("Re $\\lambda$ [1/s]")
    a1.legend()
    a2.legend()
    fig.tight_layout()
    return fig
