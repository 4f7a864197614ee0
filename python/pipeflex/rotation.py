"""Rotation helpers: the skew matrix of a vector and the exponential map of a rotation vector."""
from __future__ import annotations

import numpy as np

from . import _core


def skew(a) -> np.ndarray:
    """The matrix a~ with a~ b = a x b."""
    return np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])


def planar_triad(slope) -> np.ndarray:
    """Rotation (columns e1, e2, e3) of a planar ANCF node: e1 along the slope dr/dx [-],
    e3 = z (the core's formula)."""
    return np.asarray(_core.planar_triad(np.asarray(slope, dtype=float)))


def rotation_exp(phi) -> np.ndarray:
    """exp(phi~) of a rotation vector phi [rad] (the core's Rodrigues formula)."""
    return np.asarray(_core.rotation_exp(np.asarray(phi, dtype=float)))
