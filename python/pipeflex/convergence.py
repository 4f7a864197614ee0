"""Convergence with mesh refinement: Richardson extrapolation and observed orders."""
from __future__ import annotations

import numpy as np

from .analysis import critical_mass_flow


def richardson(coarse: float, fine: float, order: float = 4.0) -> float:
    """Richardson extrapolation of two results on meshes halved in size, for an error
    that falls as h^order."""
    return fine + (fine - coarse) / (2**order - 1)


def critical_flow_convergence(scene, elements, reference):
    """Critical mass flows [kg/s] and their errors against ``reference`` per mesh."""
    flows = np.array([critical_mass_flow(scene(n_elements=n)).mass_flow for n in elements])
    return flows, np.abs(flows - reference)


def observed_order(elements, errors):
    """Convergence order between successive meshes: log(e_i / e_{i+1}) / log(n_{i+1} / n_i)."""
    e, n = np.asarray(errors, float), np.asarray(elements, float)
    return np.log(e[:-1] / e[1:]) / np.log(n[1:] / n[:-1])
