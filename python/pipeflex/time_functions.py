"""Time functions of loads, drives and flows: a number, a table, a :class:`Sine` or a :class:`Pulse`."""
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


@dataclass(frozen=True)
class Pulse:
    """A pulse of the given duration: 0 before ``start``, ``amplitude`` (rectangle) or
    ``amplitude sin(pi (t - start) / duration)`` (half sine) during ``duration``, 0 after.

    Times a load's force F [N] it is an impulse ``F * pulse.integral`` [N s]. The half sine
    is continuous; the rectangle jumps at both ends, which a fixed-step integrator samples
    as a step and IDA may step over unless an output time falls on each jump.

    Attributes:
        start: t0 [s] (finite).
        duration: d [s] (> 0).
        shape: ``"half_sine"`` or ``"rectangle"``.
        amplitude: A [the function's unit] (finite).
    """

    start: float
    duration: float
    shape: str = "half_sine"
    amplitude: float = 1.0

    @property
    def integral(self) -> float:
        """The integral over time [the function's unit s]: A d (rectangle), 2 A d / pi (half sine)."""
        return self.amplitude * self.duration * (1.0 if self.shape == "rectangle" else 2.0 / np.pi)


def time_function(name, f) -> "_core.TimeTable":
    """A number, a table (times [s], values), a :class:`Sine` or a :class:`Pulse`, as a core TimeTable."""
    tab = _core.TimeTable()
    if isinstance(f, Pulse):
        t0 = _checks.finite(f"{name}.start", f.start)
        d = _checks.positive(f"{name}.duration", f.duration)
        a = _checks.finite(f"{name}.amplitude", f.amplitude)
        if f.shape not in ("half_sine", "rectangle"):
            raise ValueError(f"{name}.shape must be 'half_sine' or 'rectangle', got {f.shape!r}")
        # a table with repeated times jumps there (TimeTable interpolates between
        # neighbours, right-continuous); the half sine is its carrier times that window
        tab.t, tab.value = [t0, t0, t0 + d, t0 + d], [0.0, a, a, 0.0]
        if f.shape == "half_sine":
            tab.omega, tab.phase = np.pi / d, -np.pi * t0 / d
        return tab
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
        raise ValueError(f"{name} must be a number, a pair (times [s], values), a Sine or a Pulse") from None
    if ts.ndim != 1 or ts.shape != vs.shape or len(ts) < 1 or not np.all(np.isfinite(ts)) or not np.all(np.isfinite(vs)):
        raise ValueError(f"{name} table: times and values must be finite 1D arrays of equal length")
    if np.any(np.diff(ts) <= 0):
        raise ValueError(f"{name} table: times must increase strictly")
    tab.t, tab.value = list(ts), list(vs)
    return tab
