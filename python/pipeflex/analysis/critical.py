"""Critical mass flow: where the static equilibrium loses stability.

Method: (1) scan mdot upward in steps of a quarter of the model's natural flow unit
(:meth:`Model.flow_scale`), each point a static solve, a linearisation and a dense
block eigen-analysis, up to the first unstable point; the static solve continues the
flow from the last equilibrium (:func:`static_equilibrium` with ``from_mass_flow``),
halving the step down to 1/64 of the scan step where Newton fails; if even that cannot
pass a flow and the stiffness vanishes there, the static path ends in a fold, reported
as a divergence at the fold flow (:func:`_path_end`); (2) flutter: Brent's method on
the real part of the crossing eigenvalue over the scan bracket, the eigenvalue followed
by Newton refinement in its block (bisection on full eigen-analyses only if the
tracking is lost); divergence: bisection to 1e-3 relative, then Brent's method on the
stiffness eigenvalue through zero (det K = 0); (3) a full eigen-analysis at the result
checks that no other eigenvalue is unstable, and a flutter's crossing eigenvalue, refined
there, that it is zero to its resolution (:func:`_result`).

Large models (at least :data:`~pipeflex.analysis.eigen.SPARSE_MIN_DOFS` coordinates):
the scan and the checks compute only the :data:`SCAN_MODES` eigenvalues nearest 0 in
each block (the lowest modes, by sparse shift-invert Arnoldi), and the tracking
refines the crossing eigenpair by Newton from its eigenvector at the nearest flow (one
sparse LU per step; Arnoldi near the predicted eigenvalue only if Newton lands elsewhere),
so that the cost grows about linearly with the number of elements. A pipe's flutter and
divergence are instabilities of its lowest modes; an instability of a mode above the
SCAN_MODES lowest of each block would be missed. Every scan point still gets its full
analysis (no block is only followed): a block whose K, C and M are those of the
previous analysis to the bit (e.g. a straight pipe's torsion, which the flow does not
change) takes that analysis' eigenvalues, which are its own; a block proved stable by its
energy (:func:`~pipeflex.analysis.eigen.proved_stable`: K and M positive definite, C
dissipative or gyroscopic, e.g. a straight pipe's axial block) contributes no eigenvalues,
since none of them can grow; the others are solved anew, only starting from the previous
scale (:class:`~pipeflex.analysis.eigen.BlockSolutions`). So the scan decides stability
as a scan of independent analyses would.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass, replace
from typing import Optional

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .. import _checks
from ..results import Result
from .._options import renamed
from ..errors import ConvergenceError
from .eigen import (GROWTH_TOL, SPARSE_MIN_DOFS, BlockSolutions, _growing, classify, eigen_from_blocks, mechanism,
                    sparse_block_eigenvalues, QuadraticPencil, eigen_noise, one_norms,
                    sparse_eigen_from_blocks, split_blocks, with_reduction_noise)
from ._protocol import require_system
from .linearize import linearize
from ._roots import brentq
from .static import static_equilibrium
from .._blas import pinned as blas_pinned
from .._progress import logger

#: Eigenvalues per block (nearest 0) in the scan of a large model (sparse path).
SCAN_MODES = 16

#: Halvings of a scan step allowed to the static flow continuation (down to 1/64 of it).
FLOW_BISECTIONS = 6

#: A crossing below this many flow units (:meth:`Model.flow_scale`) is at zero flow: the
#: equilibrium is only marginally stable without flow (:func:`_check_not_at_zero`). It is
#: also the absolute floor of the bisection's tolerance (1e-3 relative alone underflows
#: as the bracket shrinks towards 0).
AT_ZERO_FLOW = 1e-6

#: Halvings of the bisection at most: from a scan step (at most one flow unit) down to
#: AT_ZERO_FLOW take about 20.
MAX_BISECTIONS = 64

#: Scan points (eigen-analyses) at most (the default bracket takes 20 steps_per_unit).
MAX_SCAN_POINTS = 10_000

#: The stored matrices' own rounding moves an eigenvalue by up to this fraction of its
#: double round-off level eigen_noise (measured 2-9 % on copies of the cantilever's block
#: with each entry rounded once more, docs/performance.md, "Critical flow at 8192
#: elements"; ~20 % at 10 000 elements, whose flow is 0.57 % low).
ROUNDOFF_SHIFT = 0.2

#: A flutter flow whose round-off estimate (:attr:`CriticalFlow.roundoff`) exceeds this
#: fraction of it is returned with a warning: round-off, not the discretisation, limits
#: it (the cantilever: from about 6000 elements on; 2e-5 at 2048).
ROUNDOFF_LIMIT = 1e-3

#: Large models: the followed eigenvalue's Newton refinement is trusted within this
#: A flutter crossing whose growth over the flow's own scale, dRe(lambda)/dmdot * mdot_c,
#: stays below WEAK_CROSSING |lambda| is reported with a RuntimeWarning: any structural
#: damping ratio above about WEAK_CROSSING / 2 suppresses it. Pipe flutter gains ~0.1-1
#: |lambda| (the cantilever's: 0.9 at 25 kg/s); the spurious growth of 4 loaded floating-
#: frame bodies (the flow's stiffness at their joints, docs/theory.md) ~1e-7.
WEAK_CROSSING = 1e-4


def _check_weak_crossing(mc, lam, slope):
    gain = abs(slope) * mc / max(abs(lam), 1e-300)
    if gain < WEAK_CROSSING:
        warnings.warn(f"critical_mass_flow: the flutter at {mc:.6g} kg/s ({abs(lam.imag):.6g} rad/s) is weak: its "
                      f"growth rate rises by {abs(slope) * mc:.3g} 1/s over the flow's scale, {gain:.2g} of |lambda| "
                      f"(below WEAK_CROSSING = {WEAK_CROSSING:g}), which a damping ratio of {gain / 2:.2g} would "
                      "remove: check it against a finer or an element model (loaded floating-frame bodies show such "
                      "spurious crossings: docs/theory.md), or add structural damping", RuntimeWarning, stacklevel=4)


#: fraction of |lambda| of its prediction (the eigenvalues of a pipe's lowest modes lie
#: tens of percent apart); farther, it is restarted from shift-invert Arnoldi.
TRACK_TRUST = 0.05


@dataclass(frozen=True)
class CriticalFlow(Result):
    """Result of :func:`critical_mass_flow`.

    Attributes:
        mass_flow: mdot [kg/s] critical mass flow.
        kind: "divergence" (static buckling, or the fold where the static equilibrium
            path ends) or "flutter" (Hopf bifurcation).
        frequency: omega [rad/s] angular frequency of the mode at the critical flow (0 for divergence).
        eigenvalue: lambda [1/s] the critical eigenvalue (Re ~ 0).
        mode: (n_dofs,) critical mode shape [-] (complex, reduced coordinates, largest entry 1).
        evaluations: number of eigen-analyses used.
        roundoff: [kg/s] estimated error of ``mass_flow`` from the round-off of the stored
            matrices (flutter: :func:`_roundoff_estimate`; 0 for divergence); above
            ROUNDOFF_LIMIT relative, critical_mass_flow warns (a RuntimeWarning).
    """

    mass_flow: float
    kind: str
    frequency: float
    eigenvalue: complex
    mode: np.ndarray
    evaluations: int
    roundoff: float = 0.0


class _Evaluator:
    """Static solve + linearisation + eigen-analysis at a mass flow, warm-started."""

    def __init__(self, model, state):
        require_system(model)
        if state is not None:
            model._system(state)  # a state foreign to the system: its TypeError now, not at the first solve
        self.model = model
        self.state = state  # None: the static solves start from the model's default start
        self.flow = None  # mdot of self.state once it is an equilibrium
        self.count = 0
        self.sparse = model.n_dofs >= SPARSE_MIN_DOFS
        # the scan's analyses at neighbouring flows: unchanged blocks are not solved again
        self.previous = BlockSolutions() if self.sparse else None
        self._kept = {}  # mdot -> (blocks, equilibrium, linearisation), the last few
        self.continuation = True  # the static flow continuation from the last equilibrium

    def accept(self, mdot, state):
        """Warm-start the next static solves from this equilibrium at mdot."""
        self.state, self.flow = state, mdot

    def blocks(self, mdot):
        # The scan's bracket ends and the converged crossing are asked for again (by the
        # tracking and the final check): the same equilibrium, kept, not solved again.
        key = float(mdot)
        if key not in self._kept:
            if len(self._kept) >= 8:
                self._kept.pop(next(iter(self._kept)))
            self._kept[key] = self._solve(key)
        return self._kept[key]

    def _solve(self, mdot):
        # From the last accepted equilibrium the flow is continued to mdot, the step
        # halved (at most FLOW_BISECTIONS times) where Newton fails; the first try is the
        # full step, as a plain warm-started solve.
        ramp = (dict(from_mass_flow=self.flow, max_bisections=FLOW_BISECTIONS)
                if self.continuation and self.flow is not None else {})
        try:
            try:
                solved = static_equilibrium(self.model, state=self.state, mass_flow=mdot, **ramp)
            except ValueError:
                if not ramp:
                    raise
                # a static solver that refuses the flow ramp on this system (before any solve):
                # plain solves warm-started from the last equilibrium
                self.continuation = False
                solved = static_equilibrium(self.model, state=self.state, mass_flow=mdot)
            st = self.model._equilibrium_state(solved)
        except ConvergenceError as e:
            err = type(e)(f"critical_mass_flow: the static solve failed at mdot = {mdot:.6g} kg/s: {e}",
                          load_factor=e.load_factor, iteration=e.iteration, residual=e.residual,
                          mass_flow=mdot, reached_mass_flow=e.reached_mass_flow, reached_state=e.reached_state)
            raise err from e
        lin = linearize(self.model, st, mass_flow=mdot)
        return split_blocks(lin.K, lin.C, lin.M, sparse=self.sparse), st, lin

    def __call__(self, mdot, vectors=False):
        self.count += 1
        blocks, st, lin = self.blocks(mdot)

        def solve(want_vectors):
            if self.sparse:
                return sparse_eigen_from_blocks(blocks, self.model.n_dofs, SCAN_MODES, vectors=want_vectors,
                                                previous=self.previous, unstable_only=True)
            return eigen_from_blocks(blocks, self.model.n_dofs, vectors=want_vectors)

        eig = with_reduction_noise(solve(vectors), lin, lambda: solve(True))
        return (eig if vectors else replace(eig, vectors=None)), st


@blas_pinned
@renamed(rtol="tol")
def critical_mass_flow(model, *, tol: float = 1e-10, mass_flow_max: Optional[float] = None,
                       steps_per_unit: int = 4, state=None) -> CriticalFlow:
    """Lowest mass flow at which the static equilibrium becomes unstable.

    Args:
        model: the model (its loads and gravity are applied; the flow is varied): an
            element :class:`~pipeflex.Model`, a :class:`~pipeflex.multibody.MultibodySystem`
            or a :class:`~pipeflex.CoupledSystem` (their linearisations in independent
            coordinates, :mod:`pipeflex.analysis.constrained`): the same driver.
        tol: relative tolerance on the critical mass flow [-] (``rtol=`` is its
            deprecated name; ``tol`` as in the static solvers, ``rtol`` is IDA's).
        mass_flow_max: mdot [kg/s] up to which to search (default 20 flow units).
        steps_per_unit: scan points per flow unit (:meth:`Model.flow_scale`); the scan
            stops after :data:`MAX_SCAN_POINTS` points.
        state: starting guess for the static solves (of a CoupledSystem: a
            :class:`~pipeflex.coupled.CoupledStatic`).

    A static equilibrium path that ends in a fold (a limit point: the stable equilibrium
    meets an unstable one and there is none beyond, e.g. a stiff U-tube whose free end
    swings round as the flow rises) before any dynamic instability is returned as
    kind="divergence" at the fold flow (det K = 0, a real eigenvalue through 0), located
    to about the static solver's tolerance (~1e-9 relative); ``eigenvalue`` is 0 and
    ``mode`` the stiffness null vector at the last equilibrium before the fold.

    Round-off: a flutter flow carries the estimate ``roundoff`` [kg/s] of its error from
    the stored matrices' rounding (it grows like N^3.5 with a beam's N elements: 2e-5
    relative at 2048 elements of the cantilever, 3e-3 at 8192, 6e-3 at 10 000, where the
    flow is 0.57 % low); above ROUNDOFF_LIMIT relative a RuntimeWarning gives it, the same
    rule at every size.

    Raises:
        ValueError: bad options, or the model is unstable already without flow.
        ConvergenceError: no instability up to ``mass_flow_max`` (``mass_flow`` is that
            end of the bracket) or within MAX_SCAN_POINTS scan points (``mass_flow``: the
            last stable flow), or an instability from the first flow on (a crossing below
            AT_ZERO_FLOW flow units: the equilibrium is only marginally stable), or a
            static solve failed at a trial flow even with the flow continuation, and not at a fold (``mass_flow`` is that flow; the static
            solver's error is chained), or the crossing could
            not be located (``mass_flow``: the lowest unstable flow found).
    """
    rtol = _checks.positive("tol", tol)
    ev = _Evaluator(model, state)  # checks the model first
    if model.n_dofs == 0:
        raise ValueError("the model has no free coordinates (every node is fixed): nothing can lose stability")
    unit = model.flow_scale()
    mmax = 20 * unit if mass_flow_max is None else _checks.positive("mass_flow_max", mass_flow_max)
    steps = _checks.positive_int("steps_per_unit", steps_per_unit)

    eig, st0 = ev(0.0)
    ev.accept(0.0, st0)
    # before the sign test: a neutral direction's sign is round-off. stability()'s rule
    # (eigen.mechanism), applied to the equilibrium without flow that the scan starts from
    named = mechanism(replace(eig, dof_labels=ev.blocks(0.0)[2].dof_labels))
    if named is not None:
        raise ValueError(f"the model is a mechanism (its stiffness at the static equilibrium without flow is "
                         f"singular, e.g. a free hinge; {named}): there is no static equilibrium to lose "
                         f"stability; support the free motion")
    if classify(eig) != "stable":
        raise ValueError(f"the model is already unstable ({classify(eig)}) without flow")
    eig0 = eig_lo = eig
    h = unit / steps
    lo, hi = 0.0, None
    points = 0
    while hi is None:
        points += 1
        if points > MAX_SCAN_POINTS:  # each point is an eigen-analysis
            raise ConvergenceError(
                f"no instability found up to {lo:.6g} kg/s in MAX_SCAN_POINTS = {MAX_SCAN_POINTS} scan points of "
                f"{h:.3g} kg/s (the flow unit {unit:.6g} kg/s / steps_per_unit = {steps}); mass_flow_max = "
                f"{mmax:.6g} kg/s would take {mmax / h:.3g}: lower mass_flow_max or steps_per_unit",
                mass_flow=lo)
        m = min(lo + h, mmax)
        try:
            eig, st = ev(m)
        except ConvergenceError as e:
            if e.reached_state is None:
                raise
            # (the stiffness without flow only where a path ends: a sparse model's is an Arnoldi run)
            fold = _path_end(ev, lo, eig_lo, e, abs(_kmin(eig0, ev.sparse)), rtol)
            if isinstance(fold, CriticalFlow):
                return fold
            if fold[0] != lo:
                eig_lo = None  # the bracket starts at a flow the scan did not analyse
            lo, m, eig = fold  # an instability before the path ends: bracket [lo, m]
        if classify(eig) != "stable":
            hi = m
        else:
            lo, eig_lo = m, eig
            ev.accept(m, st)
            logger.debug("critical_mass_flow: stable at %.6g kg/s", m)
            if m >= mmax:
                raise ConvergenceError(f"no instability found in the searched bracket of mass flows [0, {mmax:.6g}] "
                                       "kg/s (raise mass_flow_max)", mass_flow=mmax)
    eig_hi = eig
    xtol = 0.25 * rtol * hi
    logger.info("critical_mass_flow: %s bracketed in [%.6g, %.6g] kg/s (%d eigen-analyses)", classify(eig_hi), lo, hi,
                ev.count)
    if classify(eig_hi) == "flutter":
        # Track the crossing eigenvalue over the scan bracket; bisect only if that fails.
        try:
            mc, crossing = _track_root(ev, lo, hi, eig_hi, xtol, eig_lo)
            _check_not_at_zero(mc, unit, hi, eig_hi, ev.model)
            return _result(ev, mc, "flutter", crossing=crossing)
        except (ValueError, ConvergenceError):
            pass  # tracking lost: fall back to bisection on full eigen-analyses
    # to 1e-3 relative, but not below AT_ZERO_FLOW: towards a crossing at zero flow the
    # relative width alone never shrinks (1e-3 hi underflows with hi; the midpoint rounds to 0)
    floor = AT_ZERO_FLOW * unit
    for _ in range(MAX_BISECTIONS):
        if hi - lo <= max(1e-3 * hi, floor):
            break
        mid = 0.5 * (lo + hi)
        eig, st = ev(mid)
        if classify(eig) != "stable":
            hi, eig_hi = mid, eig
        else:
            lo, eig_lo = mid, eig
            ev.accept(mid, st)
        logger.debug("critical_mass_flow: bisection bracket [%.8g, %.8g] kg/s", lo, hi)
    else:
        raise ConvergenceError(f"critical_mass_flow: the bisection did not narrow the bracket [{lo:.6g}, {hi:.6g}] "
                               f"kg/s to 1e-3 relative (or {floor:.3g} kg/s) in MAX_BISECTIONS = {MAX_BISECTIONS} "
                               "halvings", mass_flow=hi)
    if hi <= floor:  # unstable down to zero flow, to the floor: no critical flow (raises)
        _check_not_at_zero(hi, unit, hi, eig_hi, ev.model)
    kind, crossing = classify(eig_hi), None

    if kind == "flutter":
        try:
            mc, crossing = _track_root(ev, lo, hi, eig_hi, xtol, eig_lo)  # narrow bracket: tracking is safe
        except (ValueError, ConvergenceError):  # no sign change (Re(lambda) > 0 down to lo) or lost
            _check_not_at_zero(lo, unit, hi, eig_hi, ev.model)
            iw = int(np.argmax(eig_hi.values.real))
            worst = eig_hi.values[iw]
            why = "a weakly growing mode near the noise level"
            if ev.sparse:
                why += (f"; or round-off: at {ev.model.n_dofs} coordinates the scan's eigenvalues (shift-invert "
                        f"Arnoldi in double) are only good to about {eig_hi.noise[iw]:.2g} 1/s (it grows like N^4 "
                        "with the number of elements N: the stiffness of short elements; the followed eigenvalue "
                        "itself is refined with a compensated residual, to ~1e-14 1/s up to 8192 elements of "
                        "the cantilever, docs/performance.md); use fewer elements")
            raise ConvergenceError(f"flutter between {lo:.6g} and {hi:.6g} kg/s (lambda = {worst.real:.3g} "
                                   f"{worst.imag:+.6g}j 1/s), but the crossing eigenvalue could not be followed "
                                   f"through zero: {why}{ev.model._zero_flow_growth_hint()}", mass_flow=hi) from None
        _check_not_at_zero(mc, unit, hi, eig_hi, ev.model)
    else:
        def kmin(m):
            e, _ = ev(m)
            k = _kmin(e, ev.sparse)
            logger.debug("critical_mass_flow: Brent at %.12g kg/s: relative k_min = %.3g", m, k)
            return k

        try:
            try:
                mc = brentq(kmin, lo, hi, xtol=xtol, rtol=4 * np.finfo(float).eps)
            except ValueError:
                if not ev.sparse:
                    raise
                # Large models: near the crossing the real eigenvalue lambda ~ sqrt(-k_min / m)
                # is within its round-off bound, so a flow just past the crossing may have been
                # called stable: widen the bracket downward until the stiffness changes sign.
                k_hi, a = kmin(hi), lo
                for _ in range(MAX_BISECTIONS):  # the width doubles: 0 is reached long before
                    if np.sign(kmin(a)) != np.sign(k_hi):
                        break
                    if a <= 0.0:
                        raise
                    a = max(0.0, hi - 2.0 * max(hi - a, floor))
                else:
                    raise
                mc = brentq(kmin, a, hi, xtol=xtol, rtol=4 * np.finfo(float).eps)
        except ValueError:
            raise ConvergenceError(f"divergence between {lo:.6g} and {hi:.6g} kg/s, but no stiffness eigenvalue "
                                   "changes sign there (a neutral direction, or an unstable eigenvalue that the "
                                   "stiffness does not show): cannot locate the critical flow", mass_flow=hi) from None

    return _result(ev, mc, kind, crossing=crossing)


def _kmin(eig, sparse):
    """The real stiffness eigenvalue nearest 0 of the blocks, relative to the stiffness scale."""
    vals = np.concatenate([_stiffness_eigenvalues_near_zero(b.K) if sp.issparse(b.K)
                           else np.linalg.eigvals(b.K) for b in eig.blocks])
    vals = vals[np.abs(vals.imag) <= 1e-9 * np.abs(vals)].real
    scale = (max(spla.norm(b.K, 1) for b in eig.blocks) if sparse else np.max(np.abs(vals)))
    return vals[np.argmin(np.abs(vals))] / scale


def _path_end(ev, lo, eig_lo, err, k0, rtol):
    """The flow continuation from the stable equilibrium at ``lo`` failed (``err``).

    If the last flow it reached is unstable, or a flow on the way to the fold is, the
    last stable flow, that flow and its eigen-analysis are returned: the scan brackets
    that instability as usual. Otherwise the static path ends in a fold (a saddle-node,
    a limit point in mdot): the smallest stiffness eigenvalue k_min -> 0 like sqrt(mdot_f - mdot) along
    the stable branch, and a real eigenvalue lambda ~ -k_min/c goes through 0 with it
    (det K = 0); beyond mdot_f there is no nearby equilibrium and the pipe jumps away.
    That is a static loss of stability, returned as kind="divergence" at mdot_f: the
    fold is located by secant steps on k_min^2 (linear in mdot near a fold) over
    static solves continued ever closer to it. A failure that is no fold raises.
    """
    m_fail = err.__cause__.mass_flow  # the flow of the failed ramp step (err names the target)
    m_r, st_r = err.reached_mass_flow, err.reached_state
    pts = [(0.0, k0)] + ([(lo, abs(_kmin(eig_lo, ev.sparse)))] if lo > 0.0 else [])
    eig_last = None
    if m_r is not None and m_r > lo:
        start = ev.flow, ev.state
        ev.accept(m_r, st_r)
        eig_last, _ = ev(m_r)
        if classify(eig_last) != "stable":
            ev.accept(*start)
            return lo, m_r, eig_last
        pts.append((m_r, abs(_kmin(eig_last, ev.sparse))))
    best = (np.inf, m_fail)  # (gap to the estimated fold, estimate)
    for _ in range(60):
        m2, k2 = pts[-1]
        m_f = m_fail
        if len(pts) > 1:
            m1, k1 = pts[-2]
            slope = (k2 * k2 - k1 * k1) / (m2 - m1)
            if slope < 0:
                m_f = min(m2 - k2 * k2 / slope, m_fail)
        gap = m_f - m2
        if gap >= best[0] and best[0] <= 1e-6 * best[1]:
            break  # no more progress: the flow is resolved to the Newton tolerance
        if gap < best[0]:
            best = (gap, m_f)
        if gap <= 0.25 * rtol * m_f:
            break
        trial, done = m2 + 0.9 * gap, False
        for _ in range(8):
            try:
                eig_t, st_t = ev(trial)
            except ConvergenceError:
                trial = m2 + 0.5 * (trial - m2)
                continue
            k_t = _kmin(eig_t, ev.sparse)
            if k_t <= 0.0:  # the other branch of the fold (or beyond it): not ours
                trial = m2 + 0.5 * (trial - m2)
                continue
            if classify(eig_t) != "stable":
                return ev.flow, trial, eig_t
            ev.accept(trial, st_t)
            pts.append((trial, k_t))
            eig_last, done = eig_t, True
            break
        if not done:
            break
    gap, m_f = best
    if eig_last is None or not (gap <= 1e-6 * m_f and pts[-1][1] <= 1e-2 * k0):
        raise ConvergenceError(
            f"{err} (the flow continuation from {lo:.6g} kg/s reached {pts[-1][0]:.6g} kg/s; the stiffness does "
            "not vanish there, so this is no fold of the static path)", load_factor=err.load_factor,
            iteration=err.iteration, residual=err.residual, mass_flow=m_fail) from err
    return _result(ev, m_f, "divergence", eig_last)


def _stiffness_eigenvalues_near_zero(K, k=3):
    """The k eigenvalues of a sparse stiffness block nearest 0 (real ones only)."""
    n = K.shape[0]
    if n <= 64:
        vals = np.linalg.eigvals(K.toarray())
    else:
        try:
            vals = spla.eigs(sp.csc_matrix(K), k=min(k, n - 2), sigma=0.0, which="LM", tol=0.0,
                             v0=np.random.default_rng(0).standard_normal(n), return_eigenvectors=False)
        except RuntimeError:  # exactly singular
            return np.zeros(1)
    return vals


def _check_not_at_zero(mc, unit, hi, eig_hi, model):
    """A flutter crossing at mdot -> 0 is no critical flow: the equilibrium is only
    marginally stable without flow and the first flow destabilises it (a weakly growing
    mode at the noise level). Say so instead of
    returning ~0 kg/s."""
    if mc <= AT_ZERO_FLOW * unit:
        lam = eig_hi.values
        worst = lam[np.argmax(lam.real)]
        raise ConvergenceError(
            f"the equilibrium loses stability as soon as the flow starts (crossing at mdot = {mc:.3g} kg/s; at "
            f"{hi:.6g} kg/s lambda = {worst.real:.3g} {worst.imag:+.6g}j 1/s): it is only marginally stable "
            f"without flow, so there is no critical flow to report{model._zero_flow_growth_hint()}", mass_flow=mc)


def refine_eigenpair(block, lam, x=None, *, tol=1e-10, max_iterations=20):
    """Newton's method for (lam^2 M + lam C + K) x = 0 from a nearby lam (and x).

    Each step solves T(lam) u = T'(lam) x and sets lam <- lam - (c^H x)/(c^H u),
    x <- u / (c^H u): quadratic convergence to a simple eigenvalue. Once a step is below
    tol |lam|, one more step reaches the round-off level. That level grows with the
    model: the step is computed from T(lam) = lam^2 M + lam C + K, whose largest terms
    (the stiffness of the shortest elements, ~ N^3) cancel to the small T(lam) x, so
    lam is only determined to about eps kappa |lam| / sqrt(n)
    (:func:`~pipeflex.analysis.eigen.eigen_noise`, kappa ~ (omega_max / omega)^2 ~ N^4):
    ~1e-12 relative at 32 elements, ~1e-9 at 128. The test is therefore
    |step| <= max(tol |lam|, that round-off level); with a fixed 1e-10 the iteration
    wandered in the round-off and never stopped from about 96 elements on.

    Sparse blocks (large models): Newton on [T(lam) x; c^H x - 1] = 0, the step from
    the sparse LU of its bordered Jacobian [[T(lam), T'(lam) x], [c^H, 0]] and the
    residual T(lam) x with K x summed in twice the working precision
    (:meth:`~pipeflex.analysis.eigen.QuadraticPencil.residual`). The double LU only
    corrects, so the eigenvalue is that of the stored K, C, M to a few units of the last
    place of lam (:func:`_refined_noise`): measured 1e-14 to 2e-13 1/s from 128 to 8192
    elements on the cantilever's crossing eigenvalue, where double's level is 1e-7 to
    0.3 1/s. (The bordered LU, not T(lam)'s alone: near the eigenvalue T(lam) is
    singular to working precision, and corrections through it converged only linearly,
    about tenfold a step at 8192 elements.) Small dense blocks keep the double
    iteration; their level is below tol.
    """
    n = len(block.dofs)
    sparse = sp.issparse(block.K)
    norms = one_norms(block.K, block.C, block.M)
    if sparse:
        T = QuadraticPencil(block.K, block.C, block.M)
        K, C, M = T.K, T.C, T.M

        def factor(lam_):
            return spla.splu(T(complex(lam_)))
    else:
        K, C, M = block.K, block.C, block.M
    if x is None:
        x = _start_vector(K, C, M, lam, factor if sparse else None)
    c = x / np.vdot(x, x)
    x = x / np.vdot(c, x)
    polish = False
    for _ in range(max_iterations):
        noise = _refined_noise(block, lam, x, norms)  # of the current pair
        if sparse:
            # Newton on [T(lam) x; c^H x - 1] = 0 by the LU of its (bordered) Jacobian
            dTx = 2 * lam * (M @ x) + C @ x
            try:
                d = spla.splu(T.bordered(complex(lam), dTx, c.conj())).solve(np.append(-T.residual(lam, x), 0.0))
            except RuntimeError:  # singular: lam is an eigenvalue to working precision
                return lam, x / np.linalg.norm(x)
            x, step = x + d[:n], -d[n]
        else:  # the arithmetic of the original dense iteration (small models: same numbers)
            T = lam * lam * M + lam * C + K
            dTx = (2 * lam * M + C) @ x
            try:
                u = np.linalg.solve(T, dTx)
            except np.linalg.LinAlgError:  # T(lam) singular: lam is an eigenvalue to working precision
                return lam, x / np.linalg.norm(x)
            cu = np.vdot(c, u)
            step = np.vdot(c, x) / cu
            x = u / cu
        lam = lam - step
        if polish:
            return lam, x
        # (4 eps |lam|: the resolution of lam itself, which the compensated level is near)
        polish = abs(step) <= max(tol * abs(lam), noise, 4 * np.finfo(float).eps * abs(lam))
    raise ConvergenceError(f"eigenvalue refinement did not converge near lambda = {lam:.6g}",
                           iteration=max_iterations)


def _start_vector(K, C, M, lam, factor=None):
    """A starting vector for :func:`refine_eigenpair`: a few inverse-iteration steps at
    the fixed shift lam (the sparse LU ``factor(s)``, else dense).

    Where T(lam) is singular to the last bit (lam an eigenvalue already: a small dense
    block's own value, as the scan hands the tracking at the bracket's lower end) its
    solve would divide by zero; the shift is then moved by 1e-10 |lam|, then 1e-7 |lam|."""
    n = K.shape[0]
    dT = 2 * lam * M + C
    for nudge in (0.0, 1e-10, 1e-7):
        s = lam + nudge * max(abs(lam), 1.0)
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore", sla.LinAlgWarning)
            try:
                if factor is not None:
                    fsolve = factor(s).solve
                else:
                    lu = sla.lu_factor(s * s * M + s * C + K)
                    fsolve = lambda r: sla.lu_solve(lu, r)  # noqa: E731
            except RuntimeError:  # the sparse LU refuses an exactly singular matrix
                continue
            x = np.random.default_rng(0).standard_normal(n) + 0j
            for _ in range(4):
                x = fsolve(np.asarray(dT @ x, complex))
                x /= np.linalg.norm(x)
        if np.all(np.isfinite(x)):
            return x
    raise ConvergenceError(f"eigenvalue refinement: T(lambda) is singular near lambda = {lam:.6g} and no "
                           "starting vector was found")


def _refined_noise(block, lam, x, norms=None) -> float:
    """Round-off level [1/s] of an eigenpair from :func:`refine_eigenpair` in ``block``
    (:func:`~pipeflex.analysis.eigen.eigen_noise`, ``norms`` its :func:`one_norms` if known;
    compensated on a sparse block)."""
    return float(eigen_noise(block.K, block.C, block.M, lam, x, compensated=sp.issparse(block.K), norms=norms)[0])


def _track_root(ev, lo, hi, eig_hi, xtol, eig_lo=None):
    """Brent's method on Re(lambda) of the eigenvalue that crosses at the flutter point.

    The eigenvalue is followed by Newton refinement (:func:`refine_eigenpair`) from the
    value predicted linearly in mdot by the evaluations nearest to the new flow and the
    eigenvector of the nearest one, in the decoupled block it belongs to; at the start
    the values at the bracket's ends (large models: at ``lo``, ``eig_lo``'s value of the
    block nearest the crossing eigenvalue at ``hi``; small ones predict ``lo`` from ``hi``
    alone, as before, which keeps their flows bit for bit). Large models:
    should Newton land farther than TRACK_TRUST |lambda| from the prediction (on another
    eigenvalue), it starts again from the eigenpair nearest the prediction by sparse
    shift-invert Arnoldi. A full eigen-analysis at the end checks the result.

    Large models also check the bracket's lower end with the refined eigenvalue and move
    it down while that grows (the scan judged it by Arnoldi's eigenvalues in double).

    Why the value at ``lo``: predicted from ``hi`` alone (as before), the first step's
    Newton lands on the crossing eigenvalue at ``lo`` more than TRACK_TRUST away, and the
    Arnoldi restart returned spurious eigenvalues at 8192 elements (|lambda| ~ 460 for 14).

    Returns the crossing flow mc and the :class:`_Crossing` there (for :func:`_result`).
    """
    lam = eig_hi.values
    i = int(np.argmax(lam.real - 1e300 * (lam.imag < 0)))
    dofs = eig_hi.blocks[eig_hi.block_of[i]].dofs
    seen = {hi: (lam[i], None)}
    if eig_lo is not None and ev.sparse:
        mine = np.array([np.array_equal(eig_lo.blocks[b].dofs, dofs) for b in eig_lo.block_of], bool)
        if mine.any():
            j = int(np.argmin(np.abs(eig_lo.values - lam[i]) + 1e300 * ~mine))
            seen[lo] = (eig_lo.values[j], None)

    values = {}  # mdot -> Re(lambda): the lower end is asked for twice

    def f(m):
        if m not in values:
            values[m] = re_lambda(m)
            logger.debug("critical_mass_flow: Brent at %.12g kg/s: Re(lambda) = %.3g 1/s", m, values[m])
        return values[m]

    def re_lambda(m):
        keys = sorted(seen, key=lambda k: abs(k - m))[:2]
        lam0, x0 = seen[keys[0]]
        if len(keys) == 2:
            k0, k1 = keys
            lam0 = lam0 + (seen[k1][0] - lam0) * (m - k0) / (k1 - k0)
        blocks, _, _ = ev.blocks(m)
        block = next((b for b in blocks if np.array_equal(b.dofs, dofs)), None)
        if block is None:
            raise ValueError("the block structure changed")
        ev.count += 1
        sparse = sp.issparse(block.K)
        try:
            near, x = refine_eigenpair(block, lam0, x0)
        except ConvergenceError:
            if not sparse:
                raise
            near = None
        if sparse and (near is None or abs(near - lam0) > TRACK_TRUST * abs(lam0)):
            # The shift is kept TRACK_TRUST |lambda| off the prediction: at a shift within
            # the round-off of an eigenvalue (~1e-4 |lambda| at 2048 elements) T(sigma) is
            # singular to working precision and Arnoldi returns spurious values.
            cand, _, X, _ = sparse_block_eigenvalues(block, 3, lam0 - TRACK_TRUST * abs(lam0), vectors=True,
                                                     guess=None if x0 is None else (lam0, x0))
            j = int(np.argmin(np.abs(cand - lam0)))
            near, x = refine_eigenpair(block, cand[j], X[:, j])
        seen[m] = (near, x)
        if lo < m < hi and abs(near.real) <= _refined_noise(block, near, x):
            # Re(lambda) is zero to round-off inside the bracket: m is the crossing as far
            # as it is determined (the level is ~1e-14 1/s since the sparse refinement is
            # compensated, so Brent now goes on to xtol; in double it stopped Brent from
            # ~256 elements on). Not at the ends: their signs must show the crossing.
            return 0.0
        return near.real

    if ev.sparse:
        # The scan called lo stable by Arnoldi's eigenvalues in double, whose level grows
        # like N^4 (0.2-0.3 1/s at 8192 elements, ~0.5 kg/s of flow here): refined, the
        # crossing eigenvalue may already grow there. Step lo down by the bracket's width.
        # (after 4 steps the step doubles: a bounded count whatever the width)
        width = hi - lo
        for k in range(MAX_BISECTIONS):
            if not f(lo) > 0.0:
                break
            if lo <= 0.0:
                raise ValueError("the crossing eigenvalue grows down to zero flow")
            lo = max(0.0, lo - width * 2.0 ** max(0, k - 3))
        else:
            raise ValueError(f"the crossing eigenvalue still grows at {lo:.6g} kg/s after {MAX_BISECTIONS} steps down")
    rtol = 4 * np.finfo(float).eps
    mc = brentq(f, lo, hi, xtol=xtol, rtol=rtol)
    f(mc)  # (Brent returns a flow it evaluated: nothing is computed again)
    lam_c, x_c = seen[mc]
    resolution = xtol + rtol * abs(mc)
    slope = (seen[hi][0].real - seen[lo][0].real) / (hi - lo)
    scatter = max((abs(seen[k][0].real - lam_c.real - slope * (k - mc)) for k in seen
                   if 0.0 < abs(k - mc) <= 100.0 * resolution), default=0.0)
    return mc, _Crossing(dofs, lam_c, x_c, slope, resolution, scatter)


@dataclass(frozen=True)
class _Crossing:
    """The tracked crossing at the flow mc Brent's method returned: its block's coordinates,
    lambda [1/s] and vector there (refined, :func:`refine_eigenpair`), dRe(lambda)/dmdot
    [1/kg] (the secant over the tracked bracket), the flow's resolution [kg/s] (Brent's
    bound |mc - root| <= xtol + rtol |mc|) and the scatter [1/s] of the tracked Re(lambda)
    about that secant at the flows within 100 resolutions of mc (Brent's last iterates).

    Why the scatter: refined to ~1e-13 1/s, Re(lambda) still scatters from flow to flow
    by the round-off of the static solve and the linearisation, which the refinement takes
    as exact: measured ~1e-9 1/s at 1024 elements, ~1e-8 at 4096, ~6e-8 at 8192 (a few
    1e-9 of the flow there, above tol)."""

    dofs: np.ndarray
    value: complex
    vector: np.ndarray
    slope: float
    resolution: float
    scatter: float


def _result(ev, mc, kind, eig_c=None, crossing=None):
    """Final check with a full eigen-analysis at mc (or ``eig_c``, that of a flow next to
    it, e.g. of the last equilibrium before a fold), and the critical mode.

    Flutter (``crossing``: the tracking's :class:`_Crossing` at mc): no eigenvalue but the
    crossing one (and its conjugate and copies in equal blocks) may grow by the scan's own
    rule (:func:`~pipeflex.analysis.eigen.classify`) by more than the tracked one changes
    over the flow's tolerance (|dRe/dmdot| 4 (xtol + rtol mc), ~tol mc), else the tracked
    crossing was not the first (a nearly equal mode of a nearly symmetric pipe's other
    bending plane may cross within the tolerance); and the crossing eigenvalue, refined at
    mc, must be on the axis to its resolution: |Re lambda| <= 4 noise + 2 |dRe/dmdot|
    (xtol + rtol mc) + 2 scatter (:class:`_Crossing`), noise its round-off level
    (:func:`_refined_noise`, compensated on a sparse block: ~1e-13 1/s). On the
    cantilever (dRe/dmdot ~0.5 1/s per kg/s) that is ~1e-9 1/s at 1024 elements, 1e-7 at
    8192; a flow 1e-6 relative off the crossing has Re lambda ~1e-5 1/s."""
    if eig_c is None:
        eig_c, _ = ev(mc)
    lam = eig_c.values
    if kind == "flutter":
        ref = crossing.value
        mine = np.array([np.array_equal(eig_c.blocks[b].dofs, crossing.dofs) for b in eig_c.block_of], bool)
        i = int(np.argmin(np.abs(lam - ref) + 1e300 * ((lam.imag < 0) | ~mine)))
        copies = np.minimum(np.abs(lam - lam[i]), np.abs(lam - np.conj(lam[i]))) <= 1e-12 * np.abs(lam[i])
        within = lam.real <= (np.maximum(GROWTH_TOL * np.abs(lam), eig_c.noise)
                              + 4.0 * abs(crossing.slope) * crossing.resolution)
        if np.any(_growing(eig_c) & ~copies & ~within):
            raise ConvergenceError(f"at the computed flutter point mdot = {mc:.10g} kg/s another eigenvalue "
                                   "is unstable: the tracked crossing was not the first one", mass_flow=mc)
        block = eig_c.blocks[eig_c.block_of[i]]
        if ev.sparse and np.array_equal(block.dofs, crossing.dofs):
            lam_c, x = refine_eigenpair(block, ref, crossing.vector)  # converged: one or two Newton steps
        else:  # (small models: as before, from the analysis' value, bit for bit)
            lam_c, x = refine_eigenpair(block, lam[i])
        bound = (4.0 * _refined_noise(block, lam_c, x) + 2.0 * abs(crossing.slope) * crossing.resolution
                 + 2.0 * crossing.scatter)
        if not abs(lam_c.real) <= bound:
            raise ConvergenceError(f"at the computed flutter point mdot = {mc:.10g} kg/s the crossing eigenvalue "
                                   f"lambda = {lam_c.real:.3g} {lam_c.imag:+.10g}j 1/s is not on the imaginary axis "
                                   f"to its resolution {bound:.2g} 1/s: the flow is not the crossing",
                                   mass_flow=mc)
        freq = abs(lam_c.imag)
        roundoff = _roundoff_estimate(block, lam_c, x, crossing.slope)
        _check_roundoff(mc, roundoff, ev.model.n_dofs)
        _check_weak_crossing(mc, lam_c, crossing.slope)
    else:
        # null vector of the stiffness block through zero
        best = None
        for b in eig_c.blocks:
            if sp.issparse(b.K) and b.K.shape[0] > 64:
                nk = b.K.shape[0]
                w, V = spla.eigs(sp.csc_matrix(b.K), k=1, sigma=0.0, which="LM", tol=0.0,
                                 v0=np.random.default_rng(0).standard_normal(nk))
                ratio, vec = abs(w[0]) / spla.norm(b.K, 1), V[:, 0]
            else:
                u, sv, vt = np.linalg.svd(b.K.toarray() if sp.issparse(b.K) else b.K)
                ratio, vec = sv[-1] / sv[0], vt[-1]
            if best is None or ratio < best[0]:
                best = (ratio, b, vec)
        _, block, x = best
        lam_c, freq, roundoff = 0j, 0.0, 0.0
    mode = np.zeros(ev.model.n_dofs, complex)
    mode[block.dofs] = x / x[np.argmax(np.abs(x))]
    logger.info("critical_mass_flow: %s at %.10g kg/s, omega = %.6g rad/s (%d eigen-analyses)", kind, mc, freq,
                ev.count)
    return CriticalFlow(float(mc), kind, float(freq), complex(lam_c), mode, ev.count, float(roundoff))


def _roundoff_estimate(block, lam, x, slope) -> float:
    """Error [kg/s] of a flutter flow from the stored matrices' rounding: it moves the
    crossing eigenvalue by about ROUNDOFF_SHIFT * eigen_noise (eps kappa |lambda| / sqrt(n),
    kappa ~ N^4 for a beam of N elements; the refinement's compensated residual does not
    remove it: it is the eigenvalue of the rounded matrices), and Re(lambda) moves with the
    flow at ``slope`` = dRe(lambda)/dmdot [1/kg]. The same estimate at every size."""
    noise = float(eigen_noise(block.K, block.C, block.M, lam, x)[0])
    return ROUNDOFF_SHIFT * noise / max(abs(slope), 1e-300)


def _check_roundoff(mc, roundoff, n_dofs):
    """The one rule for a flow limited by round-off: above ROUNDOFF_LIMIT relative, warn
    with the estimate (the same whatever the model's size)."""
    if roundoff > ROUNDOFF_LIMIT * abs(mc):
        warnings.warn(f"critical_mass_flow: the flutter flow {mc:.10g} kg/s is limited by round-off: at {n_dofs} "
                      f"coordinates the stored matrices' rounding alone can move it by about {roundoff:.2g} kg/s "
                      f"({roundoff / abs(mc):.1g} relative, above ROUNDOFF_LIMIT = {ROUNDOFF_LIMIT:g}; a beam's "
                      "eigenvalue conditioning grows like N^4 with its N elements); use fewer elements "
                      "(the discretisation error falls like N^-4)", RuntimeWarning,
                      stacklevel=_checks._stacklevel_outside_package())
