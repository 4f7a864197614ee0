"""Time functions of loads, drives and flows: a number, a table or a :class:`Sine`."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence, Tuple, Union

import numpy as np

from . import _checks, _core


@dataclass(frozen=True)
class Sine:
    """A time function mean + envelope(t) * sin(omega t + phase).

    Attributes:
        omega: angular frequency [rad/s] (> 0).
        envelope: a number, or a table (times [s], values) interpolated linearly (e.g. a
            ramp that starts a drive smoothly).
        phase: [rad].
        mean: a constant [the function's unit] about which it oscillates (default 0), e.g.
            the mean flow mdot0 of a pulsating flow mdot0 (1 + mu sin(Omega t)) =
            ``Sine(omega=Omega, envelope=mu * mdot0, mean=mdot0)``.
    """

    omega: float
    envelope: Union[float, Tuple[Sequence[float], Sequence[float]]] = 1.0
    phase: float = 0.0
    mean: float = 0.0


def time_function(name, f) -> "_core.TimeTable":
    """A number, a table (times [s], values) or a :class:`Sine`, as a core TimeTable."""
    tab = _core.TimeTable()
    if isinstance(f, Sine):
        tab = time_function(f"{name}.envelope", f.envelope)
        tab.omega = _checks.positive(f"{name}.omega", f.omega)
        tab.phase = _checks.finite(f"{name}.phase", f.phase)
        tab.mean = _checks.finite(f"{name}.mean", f.mean)
        return tab
    if np.isscalar(f):
        tab.t, tab.value = [0.0], [_checks.finite(name, f)]
        return tab
    try:
        ts, vs = (np.asarray(a, float) for a in f)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a number, a pair (times [s], values) or a Sine") from None
    if ts.ndim != 1 or ts.shape != vs.shape or len(ts) < 1 or not np.all(np.isfinite(ts)) or not np.all(np.isfinite(vs)):
        raise ValueError(f"{name} table: times and values must be finite 1D arrays of equal length")
    if np.any(np.diff(ts) <= 0):
        raise ValueError(f"{name} table: times must increase strictly")
    tab.t, tab.value = list(ts), list(vs)
    return tab
