"""Rotation helpers: the skew matrix of a vector and the exponential map of a rotation vector."""
from __future__ import annotations

import numpy as np

from . import _core


def skew(a) -> np.ndarray:
    """The matrix a~ with a~ b = a x b."""
    return np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])


def rotation_exp(phi) -> np.ndarray:
    """exp(phi~) of a rotation vector phi [rad] (the core's Rodrigues formula)."""
    return np.asarray(_core.rotation_exp(np.asarray(phi, dtype=float)))
