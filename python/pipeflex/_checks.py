"""Input validation helpers: every message names the parameter and the rule."""
from __future__ import annotations

import math

import numpy as np


def finite(name: str, value) -> float:
    if isinstance(value, (str, bytes)):  # float("3") would accept text
        raise ValueError(f"{name} must be a real number, got {value!r}")
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a real number, got {value!r}") from None
    if not math.isfinite(x):
        raise ValueError(f"{name} must be finite, got {x}")
    return x


def positive(name: str, value) -> float:
    x = finite(name, value)
    if x <= 0.0:
        raise ValueError(f"{name} must be > 0, got {x}")
    return x


def non_negative(name: str, value) -> float:
    x = finite(name, value)
    if x < 0.0:
        raise ValueError(f"{name} must be >= 0, got {x}")
    return x


def vector3(name: str, value) -> np.ndarray:
    try:
        v = np.asarray(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a 3-vector of real numbers, got {value!r}") from None
    if v.shape != (3,):
        raise ValueError(f"{name} must be a 3-vector, got shape {v.shape}")
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{name} must be finite, got {v}")
    return v


def unit_vector(name: str, value) -> np.ndarray:
    v = vector3(name, value)
    n = np.linalg.norm(v)
    if n < 1e-12:
        raise ValueError(f"{name} must be a non-zero vector, got {v}")
    return v / n


def _integer(name: str, value, low: int, rule: str) -> int:
    x = 0.5 if isinstance(value, bool) else finite(name, value)  # True is not a count
    if x != int(x) or x < low:
        raise ValueError(f"{name} must be a {rule} integer, got {value!r}")
    return int(x)


def non_negative_int(name: str, value) -> int:
    return _integer(name, value, 0, "non-negative")


def positive_int(name: str, value) -> int:
    return _integer(name, value, 1, "positive")
