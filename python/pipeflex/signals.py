"""Post-processing of sampled time signals: zero crossings, amplitude, period."""
from __future__ import annotations

from typing import Tuple

import numpy as np


def zero_crossings(t: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Times [s] of upward zero crossings of y(t), by linear interpolation."""
    k = np.nonzero((y[:-1] < 0.0) & (y[1:] >= 0.0))[0]
    return t[k] - y[k] * (t[k + 1] - t[k]) / (y[k + 1] - y[k])


def cycle_metrics(t: np.ndarray, y: np.ndarray, *, after: float) -> Tuple[float, float, float]:
    """(amplitude [m], period [s], mean [m]) of the signal y(t) for t >= after; the period
    from linearly interpolated upward crossings of the mean (nan if fewer than two)."""
    s = t >= after
    ts, ys = t[s], y[s]
    if len(ys) < 3:
        raise ValueError("too few samples after the settling time")
    mean = float(ys.mean())
    c = ys - mean
    up = np.nonzero((c[:-1] < 0) & (c[1:] >= 0))[0]
    tz = ts[up] - c[up] * (ts[up + 1] - ts[up]) / (c[up + 1] - c[up])
    period = float(np.diff(tz).mean()) if len(tz) > 1 else float("nan")
    return float((ys.max() - ys.min()) / 2), period, mean
