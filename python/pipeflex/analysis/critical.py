"""Critical mass flow: where the static equilibrium loses stability.

Method: (1) scan mdot upward in steps of a quarter of the model's natural flow unit
(:meth:`Model.flow_scale`), each point a static solve, a linearisation and a dense
block eigen-analysis, up to the first unstable point; (2) flutter: Brent's method on
the real part of the crossing eigenvalue over the scan bracket, the eigenvalue followed
by Newton refinement in its block (bisection on full eigen-analyses only if the
tracking is lost); divergence: bisection to 1e-3 relative, then Brent's method on the
stiffness eigenvalue through zero (det K = 0); (3) a full eigen-analysis at the result
checks that no other eigenvalue is unstable.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np
import scipy.linalg as sla
from scipy.optimize import brentq

from .. import _checks
from ..results import Result
from .._options import renamed
from ..errors import ConvergenceError
from .eigen import eigen_from_blocks, split_blocks, stability
from .linearize import linearize
from .static import static_equilibrium


@dataclass(frozen=True)
class CriticalFlow(Result):
    """Result of :func:`critical_mass_flow`.

    Attributes:
        mass_flow: mdot [kg/s] critical mass flow.
        kind: "divergence" (static buckling) or "flutter" (Hopf bifurcation).
        frequency: omega [rad/s] angular frequency of the mode at the critical flow (0 for divergence).
        eigenvalue: lambda [1/s] the critical eigenvalue (Re ~ 0).
        mode: (n_dofs,) critical mode shape [-] (complex, reduced coordinates, largest entry 1).
        evaluations: number of eigen-analyses used.
    """

    mass_flow: float
    kind: str
    frequency: float
    eigenvalue: complex
    mode: np.ndarray
    evaluations: int


class _Evaluator:
    """Static solve + linearisation + eigen-analysis at a mass flow, warm-started."""

    def __init__(self, model, state):
        self.model = model
        self.state = state
        self.count = 0

    def blocks(self, mdot):
        try:
            st = static_equilibrium(self.model, state=self.state, mass_flow=mdot).state
        except ConvergenceError as e:
            raise type(e)(f"critical_mass_flow: the static solve failed at mdot = {mdot:.6g} kg/s: {e}",
                          load_factor=e.load_factor, iteration=e.iteration, residual=e.residual,
                          mass_flow=mdot) from e
        lin = linearize(self.model, st, mass_flow=mdot)
        return split_blocks(lin.K, lin.C, lin.M), st

    def __call__(self, mdot, vectors=False):
        self.count += 1
        blocks, st = self.blocks(mdot)
        return eigen_from_blocks(blocks, self.model.n_dofs, vectors=vectors), st


@renamed(rtol="tol")
def critical_mass_flow(model, *, tol: float = 1e-10, mass_flow_max: Optional[float] = None,
                       steps_per_unit: int = 4, state=None) -> CriticalFlow:
    """Lowest mass flow at which the static equilibrium becomes unstable.

    Args:
        model: the model (its loads and gravity are applied; the flow is varied).
        tol: relative tolerance on the critical mass flow [-] (``rtol=`` is its
            deprecated name; ``tol`` as in the static solvers, ``rtol`` is IDA's).
        mass_flow_max: mdot [kg/s] up to which to search (default 20 flow units).
        steps_per_unit: scan points per flow unit (:meth:`Model.flow_scale`).
        state: starting guess for the static solves.

    Raises:
        ValueError: bad options, or the model is unstable already without flow.
        ConvergenceError: no instability up to ``mass_flow_max`` (``mass_flow`` is that
            end of the bracket), or a static solve failed at a trial flow (``mass_flow``
            is that flow; the static solver's error is chained), or the crossing could
            not be located (``mass_flow``: the lowest unstable flow found).
    """
    rtol = _checks.positive("tol", tol)
    unit = model.flow_scale()
    mmax = 20 * unit if mass_flow_max is None else _checks.positive("mass_flow_max", mass_flow_max)
    steps = _checks.positive_int("steps_per_unit", steps_per_unit)
    ev = _Evaluator(model, model.initial_state() if state is None else state)

    eig, ev.state = ev(0.0)
    if _stiffness_conditioning(eig) < 1e-10:  # before the sign test: a neutral direction's sign is round-off
        raise ValueError("the model is a mechanism (its stiffness is singular without flow, e.g. a free hinge): "
                         "there is no static equilibrium to lose stability; support the free motion")
    if stability(eig) != "stable":
        raise ValueError(f"the model is already unstable ({stability(eig)}) without flow")
    h = unit / steps
    lo, hi = 0.0, None
    while hi is None:
        m = min(lo + h, mmax)
        eig, st = ev(m)
        if stability(eig) != "stable":
            hi = m
        else:
            lo, ev.state = m, st
            if m >= mmax:
                raise ConvergenceError(f"no instability found in the searched bracket of mass flows [0, {mmax:.6g}] "
                                       "kg/s (raise mass_flow_max)", mass_flow=mmax)
    eig_hi = eig
    xtol = 0.25 * rtol * hi
    if stability(eig_hi) == "flutter":
        # Track the crossing eigenvalue over the scan bracket; bisect only if that fails.
        try:
            mc = _track_root(ev, lo, hi, eig_hi, xtol)
            _check_not_at_zero(mc, unit, hi, eig_hi)
            return _result(ev, mc, "flutter")
        except (ValueError, ConvergenceError):
            pass  # tracking lost: fall back to bisection on full eigen-analyses
    while hi - lo > 1e-3 * hi:
        mid = 0.5 * (lo + hi)
        eig, st = ev(mid)
        if stability(eig) != "stable":
            hi, eig_hi = mid, eig
        else:
            lo, ev.state = mid, st
    kind = stability(eig_hi)

    if kind == "flutter":
        try:
            mc = _track_root(ev, lo, hi, eig_hi, xtol)  # narrow bracket: tracking is safe
        except ValueError:  # no sign change: Re(lambda) > 0 down to lo
            _check_not_at_zero(lo, unit, hi, eig_hi)
            worst = eig_hi.values[np.argmax(eig_hi.values.real)]
            raise ConvergenceError(f"flutter between {lo:.6g} and {hi:.6g} kg/s (lambda = {worst.real:.3g} "
                                   f"{worst.imag:+.6g}j 1/s), but the crossing eigenvalue could not be followed "
                                   "through zero: a weakly growing mode near the noise level (e.g. of a loaded "
                                   "floating-frame body, docs/theory.md)", mass_flow=hi) from None
        _check_not_at_zero(mc, unit, hi, eig_hi)
    else:
        def kmin(m):
            e, _ = ev(m)
            vals = np.concatenate([np.linalg.eigvals(b.K) for b in e.blocks])
            vals = vals[np.abs(vals.imag) <= 1e-9 * np.abs(vals)].real
            scale = np.max(np.abs(vals))
            return vals[np.argmin(np.abs(vals))] / scale

        try:
            mc = brentq(kmin, lo, hi, xtol=xtol, rtol=4 * np.finfo(float).eps)
        except ValueError:
            raise ConvergenceError(f"divergence between {lo:.6g} and {hi:.6g} kg/s, but no stiffness eigenvalue "
                                   "changes sign there (a neutral direction, or an unstable eigenvalue that the "
                                   "stiffness does not show): cannot locate the critical flow", mass_flow=hi) from None

    return _result(ev, mc, kind)


def _stiffness_conditioning(eig) -> float:
    """Smallest ratio of least to largest singular value of the blocks' stiffness."""
    worst = 1.0
    for b in eig.blocks:
        if b.K.size:
            sv = np.linalg.svd(b.K, compute_uv=False)
            worst = min(worst, sv[-1] / sv[0] if sv[0] > 0 else 0.0)
    return worst


def _check_not_at_zero(mc, unit, hi, eig_hi):
    """A flutter crossing at mdot -> 0 is no critical flow: the equilibrium is only
    marginally stable without flow and the first flow destabilises it (e.g. a weakly
    growing mode of a loaded floating-frame body, docs/theory.md). Say so instead of
    returning ~0 kg/s."""
    if mc <= 1e-6 * unit:
        lam = eig_hi.values
        worst = lam[np.argmax(lam.real)]
        raise ConvergenceError(
            f"the equilibrium loses stability as soon as the flow starts (crossing at mdot = {mc:.3g} kg/s; at "
            f"{hi:.6g} kg/s lambda = {worst.real:.3g} {worst.imag:+.6g}j 1/s): it is only marginally stable "
            "without flow, so there is no critical flow to report", mass_flow=mc)


def refine_eigenpair(block, lam, x=None, *, tol=1e-10, max_iterations=20):
    """Newton's method for (lam^2 M + lam C + K) x = 0 from a nearby lam (and x).

    Each step solves T(lam) u = T'(lam) x and sets lam <- lam - (c^H x)/(c^H u),
    x <- u / (c^H u): quadratic convergence to a simple eigenvalue. Once a step is below
    tol |lam|, one more step reaches the round-off level (~1e-14 |lam|).
    """
    n = len(block.dofs)
    if x is None:
        # A few inverse-iteration steps at the fixed shift lam give a starting vector.
        x = np.random.default_rng(0).standard_normal(n) + 0j
        lu = sla.lu_factor(lam * lam * block.M + lam * block.C + block.K)
        dT = 2 * lam * block.M + block.C
        for _ in range(4):
            x = sla.lu_solve(lu, dT @ x)
            x /= np.linalg.norm(x)
    c = x / np.vdot(x, x)
    x = x / np.vdot(c, x)
    polish = False
    for _ in range(max_iterations):
        T = lam * lam * block.M + lam * block.C + block.K
        dT = 2 * lam * block.M + block.C
        u = np.linalg.solve(T, dT @ x)
        cu = np.vdot(c, u)
        step = np.vdot(c, x) / cu
        lam = lam - step
        x = u / cu
        if polish:
            return lam, x
        polish = abs(step) <= tol * abs(lam)
    raise ConvergenceError(f"eigenvalue refinement did not converge near lambda = {lam:.6g}",
                           iteration=max_iterations)


def _track_root(ev, lo, hi, eig_hi, xtol):
    """Brent's method on Re(lambda) of the eigenvalue that crosses at the flutter point.

    The eigenvalue is followed by Newton refinement (:func:`refine_eigenpair`) from the
    value predicted linearly in mdot by the evaluations nearest to the new flow, in the
    decoupled block it belongs to. A full eigen-analysis at the end checks the result.
    """
    lam = eig_hi.values
    i = int(np.argmax(lam.real - 1e300 * (lam.imag < 0)))
    dofs = eig_hi.blocks[eig_hi.block_of[i]].dofs
    seen = {hi: (lam[i], None)}

    def f(m):
        keys = sorted(seen, key=lambda k: abs(k - m))[:2]
        lam0, x0 = seen[keys[0]]
        if len(keys) == 2:
            k0, k1 = keys
            lam0 = lam0 + (seen[k1][0] - lam0) * (m - k0) / (k1 - k0)
        blocks, _ = ev.blocks(m)
        block = next((b for b in blocks if np.array_equal(b.dofs, dofs)), None)
        if block is None:
            raise ValueError("the block structure changed")
        ev.count += 1
        near, x = refine_eigenpair(block, lam0, x0)
        seen[m] = (near, x)
        return near.real

    return brentq(f, lo, hi, xtol=xtol, rtol=4 * np.finfo(float).eps)


def _result(ev, mc, kind):
    """Final check with a full eigen-analysis at mc, and the critical mode."""
    eig_c, _ = ev(mc)
    lam = eig_c.values
    if kind == "flutter":
        if np.any(lam.real > np.maximum(1e-6 * np.abs(lam), 1e3 * eig_c.noise)):
            raise ConvergenceError(f"at the computed flutter point mdot = {mc:.10g} kg/s another eigenvalue "
                                   "is unstable: the tracked crossing was not the first one", mass_flow=mc)
        i = int(np.argmin(np.abs(lam.real) + 1e300 * (lam.imag < 0)))
        block = eig_c.blocks[eig_c.block_of[i]]
        lam_c, x = refine_eigenpair(block, lam[i])
        freq = abs(lam_c.imag)
    else:
        # null vector of the stiffness block through zero
        best = None
        for b in eig_c.blocks:
            u, sv, vt = np.linalg.svd(b.K)
            if best is None or sv[-1] / sv[0] < best[0]:
                best = (sv[-1] / sv[0], b, vt[-1])
        _, block, x = best
        lam_c, freq = 0j, 0.0
    mode = np.zeros(ev.model.n_dofs, complex)
    mode[block.dofs] = x / x[np.argmax(np.abs(x))]
    return CriticalFlow(float(mc), kind, float(freq), complex(lam_c), mode, ev.count)
