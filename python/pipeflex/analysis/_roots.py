"""Brent's root bracketing (R. Brent, Algorithms for Minimization without Derivatives,
1973, ch. 4), in the variant of scipy.optimize.brentq (C. Harris): the same steps and the
same floating-point operations, so the same roots to the bit.

Why not scipy's: ``import scipy.optimize`` costs 70-90 ms of CPU (its whole package loads
for one function), a tenth of a 1024-element critical flow and of a Table 2 process.
tests/test_roots.py compares the two on every step.
"""
from __future__ import annotations

import math
from typing import Callable

import numpy as np

#: scipy.optimize.brentq's defaults.
XTOL = 2e-12
RTOL = 4 * np.finfo(float).eps
MAX_ITERATIONS = 100


def brentq(f: Callable[[float], float], a: float, b: float, *, xtol: float = XTOL, rtol: float = RTOL,
           max_iterations: int = MAX_ITERATIONS) -> float:
    """A root of f in [a, b], where f(a) and f(b) differ in sign, to
    |x - root| <= xtol + rtol |x|.

    Each step takes the inverse quadratic (or secant) interpolation through the last three
    (two) points if it falls well inside the bracket and shrinks it fast enough, else
    bisects; a step is never shorter than the tolerance.

    Raises:
        ValueError: xtol <= 0 or rtol < 4 eps; f(a) and f(b) have the same sign; f is not
            finite at a point tried (named).
        RuntimeError: no convergence in ``max_iterations`` steps.
    """
    if not xtol > 0.0:
        raise ValueError(f"xtol must be > 0, got {xtol!r}")
    if not rtol >= RTOL:
        raise ValueError(f"rtol must be >= 4 eps = {RTOL:g}, got {rtol!r}")

    def value(x):
        y = float(f(x))
        if not math.isfinite(y):
            raise ValueError(f"brentq: f({x!r}) = {y} is not finite")
        return y

    xpre, xcur = float(a), float(b)
    fpre, fcur = value(xpre), value(xcur)
    if fpre == 0.0:
        return xpre
    if fcur == 0.0:
        return xcur
    if math.copysign(1.0, fpre) == math.copysign(1.0, fcur):
        raise ValueError("f(a) and f(b) must have different signs")
    xblk = fblk = spre = scur = 0.0
    for _ in range(max_iterations):
        if fpre != 0.0 and fcur != 0.0 and math.copysign(1.0, fpre) != math.copysign(1.0, fcur):
            xblk, fblk = xpre, fpre  # the bracket's other end
            spre = scur = xcur - xpre
        if abs(fblk) < abs(fcur):  # xcur: the best point so far
            xpre, xcur, xblk = xcur, xblk, xcur
            fpre, fcur, fblk = fcur, fblk, fcur
        delta = (xtol + rtol * abs(xcur)) / 2
        sbis = (xblk - xcur) / 2
        if fcur == 0.0 or abs(sbis) < delta:
            return xcur
        if abs(spre) > delta and abs(fcur) < abs(fpre):
            if xpre == xblk:  # secant
                stry = -fcur * (xcur - xpre) / (fcur - fpre)
            else:  # inverse quadratic interpolation
                dpre = (fpre - fcur) / (xpre - xcur)
                dblk = (fblk - fcur) / (xblk - xcur)
                stry = -fcur * (fblk * dblk - fpre * dpre) / (dblk * dpre * (fblk - fpre))
            if 2 * abs(stry) < min(abs(spre), 3 * abs(sbis) - delta):
                spre, scur = scur, stry  # accept the interpolation
            else:
                spre = scur = sbis  # bisect
        else:
            spre = scur = sbis
        xpre, fpre = xcur, fcur
        xcur += scur if abs(scur) > delta else (delta if sbis > 0 else -delta)
        fcur = value(xcur)
    raise RuntimeError(f"brentq: no convergence in {max_iterations} iterations (bracket [{a!r}, {b!r}], "
                       f"last x = {xcur!r}, f = {fcur!r})")


class Illinois:
    """The Illinois variant of regula falsi (Dowell & Jarratt, BIT 11, 1971) on a bracket
    [lo, hi] whose ends' values flo, fhi differ in sign, one evaluation at a time, for
    roots whose every evaluation is a solve the caller makes (a continuation step, a
    shooting): :meth:`trial` is the next point, :meth:`update` takes its value. When an
    end is kept twice running, its value is halved: the secant then leaves it (plain
    regula falsi can stall on a convex f)."""

    def __init__(self, lo: float, hi: float, flo: float, fhi: float) -> None:
        self.lo, self.hi, self.flo, self.fhi = lo, hi, flo, fhi
        self._side = 0

    @property
    def width(self) -> float:
        return self.hi - self.lo

    def trial(self) -> float:
        """The secant's root in (lo, hi), or the midpoint where the secant leaves it."""
        s = self.hi - self.fhi * (self.hi - self.lo) / (self.fhi - self.flo)
        return s if self.lo < s < self.hi else 0.5 * (self.lo + self.hi)

    def update(self, s: float, f: float) -> None:
        """The bracket after the value f at s."""
        if np.sign(f) == np.sign(self.fhi):
            self.hi, self.fhi = s, f
            if self._side == -1:
                self.flo /= 2
            self._side = -1
        else:
            self.lo, self.flo = s, f
            if self._side == 1:
                self.fhi /= 2
            self._side = 1
