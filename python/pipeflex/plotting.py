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
