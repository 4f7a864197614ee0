"""Rotation helpers: the skew matrix of a vector, the exponential map of a rotation vector and its inverse."""
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


def rotation_log(R) -> np.ndarray:
    """The rotation vector phi [rad] with exp(phi~) = R, for rotations by less than pi;
    R may be stacked (..., 3, 3), phi is then (..., 3)."""
    R = np.asarray(R, dtype=float)
    angle = np.arccos(np.clip((np.trace(R, axis1=-2, axis2=-1) - 1.0) / 2.0, -1.0, 1.0))
    w = 0.5 * np.stack([R[..., 2, 1] - R[..., 1, 2], R[..., 0, 2] - R[..., 2, 0], R[..., 1, 0] - R[..., 0, 1]], -1)
    # |w| = sin(angle): phi = w angle / sin(angle), -> w for small angles
    with np.errstate(invalid="ignore", divide="ignore"):
        scale = np.where(angle > 1e-8, angle / np.sin(angle), 1.0)
    return w * scale[..., None]
