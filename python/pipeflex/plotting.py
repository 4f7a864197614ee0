"""Figures shared by `pipeflex validate` and the notebooks."""
from __future__ import annotations

import numpy as np

from . import scenes
from .analysis import critical_mass_flow


def critical_flow_convergence(scene, elements, reference):
    """Critical mass flows [kg/s] and their errors against ``reference`` per mesh."""
    flows = np.array([critical_mass_flow(scene(n_elements=n)).mass_flow for n in elements])
    return flows, np.abs(flows - reference)


def observed_order(elements, errors):
    """Convergence order between successive meshes: log(e_i / e_{i+1}) / log(n_{i+1} / n_i)."""
    e, n = np.asarray(errors, float), np.asarray(elements, float)
    return np.log(e[:-1] / e[1:]) / np.log(n[1:] / n[:-1])


def convergence_figure():
    """Log-log error of the critical mass flow versus number of elements (Tables 1, 2)."""
    import matplotlib.pyplot as plt

    from .validate import richardson

    fig, ax = plt.subplots(figsize=(6, 4))
    n1 = np.array([1, 2, 4, 8, 16])
    exact = np.pi * np.sqrt(0.25 * 1.0 / 1.0)
    _, e1 = critical_flow_convergence(scenes.simply_supported_pipe, n1, exact)
    ax.loglog(n1, e1, "o-", label="simply supported (Table 1), vs exact")
    n2 = np.array([2, 4, 8, 16, 32])
    f2, _ = critical_flow_convergence(scenes.cantilever_pipe, n2, 0.0)
    ref = richardson(f2[-2], f2[-1])
    ax.loglog(n2[:-1], np.abs(f2[:-1] - ref), "s-", label="cantilever (Table 2), vs extrapolated")
    ax.loglog(n1, e1[0] * (n1 / n1[0]) ** -4.0, "k--", lw=0.8, label="order 4")
    ax.set_xlabel("number of elements")
    ax.set_ylabel("error of critical mass flow [kg/s]")
    ax.legend()
    ax.grid(True, which="both", lw=0.3)
    fig.tight_layout()
    return fig


def eigenvalue_paths(model, mass_flows, *, n_modes=4):
    """Eigenvalues of the lowest ``n_modes`` (by frequency at zero flow, Im > 0) along
    ``mass_flows`` [kg/s], followed by proximity (an overdamped mode continues on the
    real axis). Returns a complex array (flows, modes)."""
    from .analysis import eigenvalues, linearize

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
