"""Floquet stability of a pipe whose flow pulsates, and the instability chart.

A pump delivers mdot(t) = mdot0 (1 + mu sin(Omega t)). Linearised about the quasi-static
equilibrium that follows the flow, the equations of motion are time-periodic,

    M z'' + C(mdot(t)) z' + K(mdot(t), mdot'(t)) z = 0,

with C linear in mdot (the Coriolis terms), K quadratic in mdot (the momentum flux) and
linear in mdot' (the fluid's relative acceleration, and the geometric stiffness of the
axial force it produces). Their Floquet multipliers over one forcing period
T = 2 pi / Omega decide the stability (Paidoussis & Issid 1974; Paidoussis,
"Fluid-Structure Interactions", vol. 1, Sections 4.5-4.6): a multiplier of modulus > 1
grows (a parametric resonance, in the "tongues" of the (Omega, mu) plane that open at
Omega = 2 omega_k / n and omega_j +- omega_k).

The matrices come from :func:`~pipeflex.linearize` of the model (an element model,
floating-frame bodies or a coupled system): about the static equilibrium at each sampled
flow, displaced by the quasi-static response to the flow's rate (the axial motion under
the fluid's acceleration is much faster than the pulsation), at five flows and rates, from
which the polynomial coefficients follow; a sixth linearisation checks the polynomial
(``fit_error``). Bodies and coupled systems are reduced to their joints' null space with
the mean-flow equilibrium's basis for every sample (one set of coordinates). The
coordinates are the lowest ``modes`` modes of the mean-flow system (its right and left
eigenvectors: a Petrov-Galerkin projection, exact for the steady flow); the monodromy matrix is
integrated over one period by the fourth-order Magnus method (two Gauss points per step
and one matrix exponential of the 2 k x 2 k system: exact for a steady flow, so that
mu = 0 gives multipliers exp(lambda T) to round-off), with
steps_per_period from the highest retained frequency (h omega_max <= 0.5) and at least 32.
See docs/parametric.md.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass, replace
from typing import List, Optional, Sequence

import numpy as np

from .. import _checks
from .._progress import logger
from ..results import Result

#: Magnus steps: h omega_max at most this (omega_max the largest |eigenvalue| retained);
#: the largest modulus then changes by < 1e-7 when the steps are doubled (tests/test_parametric.py)
STEP_PRODUCT = 0.5
#: and at least this many steps per forcing period
MIN_STEPS = 32
#: the truncation check adds the modes up to this many times the highest retained |lambda|
CHECK_RANGE = 10.0


@dataclass(frozen=True)
class PeriodicMatrices:
    """The pulsating-flow equations in the coordinates of the retained modes:
    dx/dt = (A0 + s As + s^2 Ass + d Ad) x with s = mdot - mdot0 [kg/s] and
    d = d(mdot)/dt [kg/s^2]. Plain arrays (picklable: the chart's workers get this)."""

    mean_flow: float
    A0: np.ndarray
    As: np.ndarray
    Ass: np.ndarray
    Ad: np.ndarray
    #: relative misfit of the polynomial at a check point [-]
    fit_error: float = 0.0
    #: modes retained (a complex pair of eigenvalues counts once)
    modes: int = 0

    @property
    def n_modes(self) -> int:
        """Modes retained (a complex pair of eigenvalues counts once)."""
        return self.modes

    def first_order(self):
        """(A0, As, Ass, Ad)."""
        return self.A0, self.As, self.Ass, self.Ad

    def mean_eigenvalues(self) -> np.ndarray:
        """Eigenvalues [1/s] of the mean-flow system (steady flow mdot0) retained."""
        return np.linalg.eigvals(self.A0)


class _FlowModel:
    """The full (dense) coefficient matrices of a model at mean flow mdot0, and its modes."""

    def __init__(self, model, mean_flow: float):
        from .. import _core
        from ._protocol import require_system
        from .constrained import from_core, metric, reduce, stiffness_floor
        from .linearize import linearize
        from .static import static_equilibrium

        require_system(model)
        mdot0 = self.mean_flow = float(mean_flow)
        equilibrium = model._equilibrium_state(static_equilibrium(model, mass_flow=mdot0))
        mean = linearize(model, equilibrium, mass_flow=mdot0)
        # the chart about the linearisation's state (an element model's re-based: phi = 0,
        # rotation increments about the equilibrium's own orientation; bodies': their
        # multipliers, which the joints' geometric stiffness needs)
        chart = model._orbit_chart(mean.state)
        base = chart.state(np.zeros(chart.n), np.zeros(chart.n))
        T = mean.basis
        if T is None:  # an element model: its coordinates are independent
            def dense(lin):
                return lin.M.toarray(), lin.C.toarray(), lin.K.toarray()
            Cq = np.zeros((0, chart.n))
        else:
            # Bodies and coupled systems: q = q0 (+) T z, C_q T = 0. The basis follows the
            # state, and the polynomial in the flow needs one for all samples: each sample's
            # unreduced (M, C, K) is reduced with the mean-flow equilibrium's T. At a sample
            # moved quasi-statically by u, C_q(q0 + u) T differs from 0 by O(abs(u) / L), the
            # joints turning with the moves (a clamped chain of a soft tube, EA =
            # 2.5e4 N: u = 3.9e-3 L at the largest sampled rate, C_q T 6e-4 of its scale).
            # Bases of their own differ by as much and more: their metric follows diag K, so
            # that the coordinates themselves would pulsate (a polynomial misfit of ~1).
            d = metric(mean.unreduced[2], T.shape[0])

            def dense(lin):
                Mr, Cr, Kr = reduce(T, *lin.unreduced)
                return Mr.toarray(), Cr.toarray(), stiffness_floor(Kr, T, d).toarray()
            Cq = from_core(_core.linear_matrices(model._system(mean.state, mass_flow=mdot0), mdot0))[3].toarray()

        def residual(mdot, rate):
            return model._flow_residual(base, mdot, rate)

        charts = {0.0: chart}

        def chart_at(s):
            # The flow's quasi-static state: the static equilibrium at mdot0 + s itself (from
            # the mean one), not a linear extrapolation: the joints' multipliers carry the
            # momentum flux mdot^2 / M_f through a chain of bodies, quadratic in the flow.
            if s not in charts:
                moved = static_equilibrium(model, state=equilibrium, mass_flow=mdot0 + s)
                charts[s] = model._orbit_chart(linearize(model, model._equilibrium_state(moved),
                                                         mass_flow=mdot0 + s).state)
            return charts[s]

        self.M, C0, K0 = dense(mean)
        self._modes(K0, C0)
        # Sample spans of the model's own scales (not of a grid: a chart and a single point
        # get the same matrices): the mean flow (or the model's flow unit) and that flow
        # changing at 4 |lambda_1|. Large spans: the differences of the stiff axial entries
        # lose less to round-off; the polynomial is exact but for the quasi-static base.
        a = abs(mdot0) if mdot0 != 0.0 else _flow_unit(model)
        lam = np.abs(self.lam)
        b = 4.0 * a * (lam[lam > 1e-9 * lam.max()].min() if lam.max() > 0 else 1.0)
        # the quasi-static response of the equilibrium (and of the joints' multipliers) to
        # the flow's rate (linear: the residual is linear in it; the response is the
        # equilibrium's axial stretch, fast against the pulsation), added to each sample
        try:
            self.u_rate, l_rate = _quasi_static(mean, K0, Cq, residual(mdot0, 1.0) - residual(mdot0, 0.0))
        except np.linalg.LinAlgError:
            raise ValueError(f"model: its stiffness at mean_flow = {mdot0:g} kg/s is singular (a mechanism, or "
                             "the flow's buckling point): no quasi-static equilibrium to linearise about") from None

        def at(s, d):
            st = _with_multipliers(chart_at(s).state(d * self.u_rate, np.zeros(chart.n)), d * l_rate)
            return dense(linearize(model, st, mass_flow=mdot0 + s, mass_flow_rate=d))

        self.sample = at  # (M, C, K) at mdot0 + s changing at d, about the quasi-static state

        _, Cp, Kp = at(a, 0.0)
        _, Cm, Km = at(-a, 0.0)
        _, _, Kdp = at(0.0, b)
        _, _, Kdm = at(0.0, -b)
        self.C = (C0, (Cp - Cm) / (2 * a))
        self.K = (K0, (Kp - Km) / (2 * a), (Kp + Km - 2 * K0) / (2 * a * a), (Kdp - Kdm) / (2 * b))
        # the polynomial checked at a sixth point (the quasi-static base included), in modal
        # coordinates (project): the axial stiffness would hide a misfit of the flow's terms
        self._check = (0.5 * a, 0.5 * b, *at(0.5 * a, 0.5 * b)[1:])

    def _modes(self, K0, C0):
        """The eigen-analysis of the mean-flow system E x' = F0 x, x = [z; z'],
        E = diag(I, M), F0 = [[0, I], [-K0, -C0]]: finite eigenvalues (massless coordinates
        have none) by ascending modulus, right and left vectors."""
        import scipy.linalg as sla

        n = self.M.shape[0]
        self.E = np.block([[np.eye(n), np.zeros((n, n))], [np.zeros((n, n)), self.M]])
        lam, Y, X = sla.eig(self._first_order(K0, C0, 1.0), self.E, left=True, right=True)
        upper = np.isfinite(lam) & (lam.imag >= 0.0)  # one of each conjugate pair; real ones once
        order = np.flatnonzero(upper)[np.argsort(np.abs(lam[upper]), kind="stable")]
        self.lam, self.X, self.Y = lam[order], X[:, order], Y[:, order]
        self.dims = np.where(self.lam.imag > 0.0, 2, 1)

    @staticmethod
    def _first_order(K, C, identity):
        n = K.shape[0]
        return np.block([[np.zeros((n, n)), identity * np.eye(n)], [-K, -C]])

    @property
    def n_modes(self) -> int:
        return len(self.lam)

    def check_modes(self, k: int) -> Optional[int]:
        """The modes of the truncation check of k retained: up to 2 k, those with |lambda| up
        to CHECK_RANGE times the highest retained (stiffer ones, e.g. axial, would set the
        step); None if there is no such mode."""
        if k >= self.n_modes:
            return None
        top = CHECK_RANGE * abs(self.lam[k - 1])
        more = k + int(np.count_nonzero(np.abs(self.lam[k:2 * k]) <= top))
        return more if more > k else None

    def project(self, modes: Optional[int]) -> PeriodicMatrices:
        """The equations on the lowest ``modes`` modes of the mean-flow system (None: all):
        a Petrov-Galerkin projection on their right vectors (real and imaginary parts)
        with their left vectors, exact for the steady flow."""
        k = self.n_modes if modes is None else min(modes, self.n_modes)

        def real_span(V):
            cols = []
            for j in range(k):
                cols.append(V[:, j].real)
                if self.dims[j] == 2:
                    cols.append(V[:, j].imag)
            Q, _ = np.linalg.qr(np.array(cols).T)
            return Q

        Xr, Yr = real_span(self.X), real_span(self.Y)
        G = Yr.T @ self.E @ Xr

        def pr(F):
            return np.linalg.solve(G, Yr.T @ F @ Xr)

        zero = np.zeros_like(self.K[0])
        A0 = pr(self._first_order(self.K[0], self.C[0], 1.0))
        parts = [pr(self._first_order(self.K[1], self.C[1], 0.0)), pr(self._first_order(self.K[2], zero, 0.0)),
                 pr(self._first_order(self.K[3], zero, 0.0))]
        s, d, Ct, Kt = self._check
        true = pr(self._first_order(Kt, Ct, 1.0))
        fit = A0 + s * parts[0] + s * s * parts[1] + d * parts[2]
        change = np.linalg.norm(true - A0)  # the flow's part (0 without fluid: then no misfit either)
        misfit = np.linalg.norm(true - fit) / change if change > 0.0 else 0.0
        return PeriodicMatrices(self.mean_flow, A0, *parts, fit_error=float(misfit), modes=k)


def _quasi_static(mean, K0, Cq, force):
    """(dq, dlam): the static response of the linearisation ``mean`` to a change ``force``
    of its residual (the system's coordinates, N): K dq + force + C_q^T dlam = 0 with
    C_q dq = 0, dq = T dz (element models: no constraints, dlam empty)."""
    if mean.basis is None:
        return -np.linalg.solve(K0, force), np.zeros(0)
    T = mean.basis
    dq = T @ -np.linalg.solve(K0, T.T @ force)
    # T^T (K dq + force) = 0: the rest is in the range of C_q^T, the multipliers' change
    rest = mean.unreduced[2] @ dq + force
    return dq, np.linalg.lstsq(Cq.T, -rest, rcond=None)[0]


def _with_multipliers(state, dlam):
    """``state`` (a chart's) with its joint multipliers changed by ``dlam``: a
    MultibodyState's ``lam``; a coupled state's bodies' ``lam``, then its coupling forces."""
    if len(dlam) == 0:
        return state
    body = getattr(state, "body_state", None)
    if body is None:
        return replace(state, lam=state.lam + dlam)
    nb = len(body.lam)
    forces = np.zeros(len(dlam) - nb) if state.coupling_forces is None else np.asarray(state.coupling_forces)
    return replace(state, body_state=replace(body, lam=body.lam + dlam[:nb]), coupling_forces=forces + dlam[nb:])


def steps_per_period(matrices: PeriodicMatrices, frequency: float) -> int:
    """Magnus steps for one forcing period 2 pi / frequency [rad/s]: h omega_max <=
    STEP_PRODUCT, at least MIN_STEPS."""
    omega_max = float(np.abs(matrices.mean_eigenvalues()).max())
    return int(max(MIN_STEPS, np.ceil(2 * np.pi / frequency * omega_max / STEP_PRODUCT)))


def monodromy(matrices: PeriodicMatrices, frequency: float, amplitudes: Sequence[float], *,
              steps: Optional[int] = None) -> np.ndarray:
    """Monodromy matrices (n_amplitudes, 2k, 2k) over one period, one per amplitude mu [-],
    all at once (fourth-order Magnus, ``steps`` per period: default :func:`steps_per_period`)."""
    from scipy.linalg import expm  # (batched; faster here than a Taylor series of products)

    A0, As, Ass, Ad = matrices.first_order()
    mus = np.asarray(amplitudes, float)
    mdot0, W = matrices.mean_flow, float(frequency)
    n = steps_per_period(matrices, W) if steps is None else steps
    h = 2 * np.pi / W / n
    gauss = 0.5 - np.sqrt(3) / 6, 0.5 + np.sqrt(3) / 6

    def A(t):
        s = mdot0 * mus * np.sin(W * t)
        d = mdot0 * mus * W * np.cos(W * t)
        return (A0[None] + s[:, None, None] * As[None] + (s * s)[:, None, None] * Ass[None]
                + d[:, None, None] * Ad[None])

    X = np.broadcast_to(np.eye(A0.shape[0]), (len(mus),) + A0.shape).copy()
    for i in range(n):
        A1, A2 = A((i + gauss[0]) * h), A((i + gauss[1]) * h)
        Om = 0.5 * h * (A1 + A2) + (np.sqrt(3) / 12 * h * h) * (A2 @ A1 - A1 @ A2)
        X = expm(Om) @ X
    return X


def _largest(matrices, frequency, amplitudes, steps):
    return np.abs(np.linalg.eigvals(monodromy(matrices, frequency, amplitudes, steps=steps))).max(axis=-1)


def chart_column(frequency: float, *, matrices: PeriodicMatrices, amplitudes: tuple,
                 steps: Optional[int] = None) -> dict:
    """One column of :func:`instability_chart` (module level: the sweep's workers import it):
    ``largest`` (n_amplitudes,) largest multiplier modulus [-] at Omega = ``frequency`` [rad/s]."""
    return {"largest": _largest(matrices, frequency, amplitudes, steps)}


@dataclass(frozen=True)
class ParametricStability(Result):
    """Floquet multipliers of the pulsating-flow equations (:func:`parametric_stability`).

    Attributes:
        multipliers: (2 k,) complex Floquet multipliers [-] over one period, by descending modulus.
        largest: the largest modulus [-]; > 1 grows.
        stable: largest <= 1 + tol.
        mean_flow: mdot0 [kg/s]. amplitude: mu [-]. frequency: Omega [rad/s]. period: 2 pi / Omega [s].
        natural_frequencies: the mean-flow system's frequencies [rad/s] (ascending, one per
            oscillating mode pair: the imaginary parts of its eigenvalues).
        modes: k, the modes retained. steps: Magnus steps per period.
        truncation_change: abs(largest(k) - largest(k')) [-] with k' up to 2 k modes, those
            within 10 times the highest retained frequency (None: no such mode, or not checked).
        fit_error: relative misfit of the matrices' polynomial in (mdot, mdot') at a check point [-].
        tol: the verdict's tolerance on the modulus [-].
    """

    multipliers: np.ndarray
    largest: float
    stable: bool
    mean_flow: float
    amplitude: float
    frequency: float
    period: float
    natural_frequencies: np.ndarray
    modes: int
    steps: int
    truncation_change: Optional[float]
    fit_error: float
    tol: float


def _frequencies(matrices: PeriodicMatrices) -> np.ndarray:
    lam = matrices.mean_eigenvalues()
    w = np.sort(lam.imag[lam.imag > 1e-9 * max(1.0, np.abs(lam).max())])
    return w


def _check_common(mean_flow, modes, tol):
    mdot0 = _checks.finite("mean_flow", mean_flow)
    if modes is not None:
        modes = _checks.positive_int("modes", modes)
    _checks.positive("tol", tol)
    return mdot0, modes


def _flow_unit(model):
    try:
        return model.flow_scale()
    except ValueError:  # no fluid: the flow enters no term
        return 1.0


def parametric_stability(model, *, mean_flow: float, amplitude: float, frequency: float, modes: Optional[int] = 8,
                         steps: Optional[int] = None, check_modes: bool = True,
                         tol: float = 1e-4) -> ParametricStability:
    """Floquet stability of ``model`` under the pulsating flow mdot(t) = mdot0 (1 + mu sin(Omega t)).

    Args:
        model: an element :class:`~pipeflex.Model` (3D pipe or planar ANCF elements), a
            :class:`~pipeflex.multibody.MultibodySystem` or a :class:`~pipeflex.CoupledSystem`.
        mean_flow: mdot0 [kg/s].
        amplitude: mu [-] (>= 0), the pulsation relative to the mean flow.
        frequency: Omega [rad/s] (> 0) of the pulsation.
        modes: k, the lowest undamped modes of the mean-flow system retained (None: all;
            massless coordinates have none).
        steps: Magnus steps per period (default from the highest retained frequency:
            h omega_max <= 0.5, at least 32).
        check_modes: also compute with up to 2 k modes (those whose frequency is within
            10 times the highest retained one) and report the change of the largest
            modulus (``truncation_change``).
        tol: [-] a largest modulus up to 1 + tol counts as stable. An undamped system's
            multipliers sit on the unit circle, but the modal truncation (a projection that
            does not keep its Hamiltonian structure) moves them off by up to ~1e-5 at large
            mu with 8 modes (less with more); 1e-4 is growth by e in 10^4 periods. Near a
            tongue's edge the growth rises like the square root of the distance, so the
            edges move by ~tol^2 only.

    Returns:
        :class:`ParametricStability`.

    The linearisation is about the static equilibrium at mdot0 moved quasi-statically
    with the flow (the axial response to the fluid's acceleration included); the cost is
    four static solves, about ten linearisations and one dense eigen-analysis of the model,
    then ``steps`` exponentials of a 2k x 2k matrix. Raises TypeError for a model that is
    none of the three, ValueError for bad arguments (named).
    """
    mdot0, modes = _check_common(mean_flow, modes, tol)
    mu = _checks.non_negative("amplitude", amplitude)
    W = _checks.positive("frequency", frequency)
    flow = _FlowModel(model, mdot0)
    mats = flow.project(modes)
    n = steps_per_period(mats, W) if steps is None else _checks.positive_int("steps", steps)
    X = monodromy(mats, W, [mu], steps=n)[0]
    rho = np.linalg.eigvals(X)
    rho = rho[np.argsort(-np.abs(rho), kind="stable")]
    largest = float(np.abs(rho[0]))
    change = None
    more = flow.check_modes(mats.n_modes) if check_modes else None
    if more is not None:
        change = abs(float(_largest(flow.project(more), W, [mu], None)[0]) - largest)
    return ParametricStability(multipliers=rho, largest=largest, stable=bool(largest <= 1.0 + tol), mean_flow=mdot0,
                               amplitude=mu, frequency=W, period=2 * np.pi / W,
                               natural_frequencies=_frequencies(mats), modes=mats.n_modes, steps=int(n),
                               truncation_change=change, fit_error=mats.fit_error, tol=float(tol))


def _grid(name, values, *, positive):
    x = np.atleast_1d(np.asarray(values, dtype=float))
    if x.ndim != 1 or len(x) == 0 or not np.all(np.isfinite(x)):
        raise ValueError(f"{name} must be a non-empty 1D list of finite numbers")
    if np.any(x <= 0) if positive else np.any(x < 0):
        raise ValueError(f"{name} must be {'> 0' if positive else '>= 0'}")
    if len(np.unique(x)) != len(x):
        raise ValueError(f"{name} must not repeat a value")
    return x


@dataclass(frozen=True)
class InstabilityChart(Result):
    """The largest Floquet multiplier modulus on an (Omega, mu) grid (:func:`instability_chart`).

    Attributes:
        frequencies: (n_Omega,) Omega [rad/s]. amplitudes: (n_mu,) mu [-].
        largest: (n_Omega, n_mu) largest multiplier modulus [-]; > 1 + tol is unstable.
        mean_flow: mdot0 [kg/s].
        natural_frequencies: the mean-flow system's frequencies omega_k [rad/s], ascending.
        modes: modes retained. steps: Magnus steps per period at each Omega (n_Omega,).
        truncation_change: abs change of the largest modulus at the chart's largest point
            with up to 2 k modes [-] (as :class:`ParametricStability`'s; None: no such mode).
        fit_error: the matrices' polynomial misfit at a check point [-].
        tol: the stability tolerance on the modulus [-].
    """

    frequencies: np.ndarray
    amplitudes: np.ndarray
    largest: np.ndarray
    mean_flow: float
    natural_frequencies: np.ndarray
    modes: int
    steps: np.ndarray
    truncation_change: Optional[float]
    fit_error: float
    tol: float

    @property
    def unstable(self) -> np.ndarray:
        """(n_Omega, n_mu) True where a multiplier exceeds 1 + tol."""
        return self.largest > 1.0 + self.tol

    def tongues(self, *, max_order: int = 2, n_frequencies: int = 3) -> List[dict]:
        """Where the tongues open at mu -> 0: ``{"kind", "frequency" [rad/s]}`` for the
        principal and higher ones 2 omega_k / n (n <= ``max_order``) and the combination
        ones omega_j + omega_k, omega_k - omega_j (j < k), of the lowest ``n_frequencies``
        distinct frequencies; those inside the chart's frequency range."""
        w = _distinct(self.natural_frequencies)[:n_frequencies]
        lo, hi = self.frequencies.min(), self.frequencies.max()
        out = [{"kind": f"2 omega_{k + 1} / {n}", "frequency": 2 * wk / n}
               for k, wk in enumerate(w) for n in range(1, max_order + 1)]
        for j in range(len(w)):
            for k in range(j + 1, len(w)):
                out.append({"kind": f"omega_{j + 1} + omega_{k + 1}", "frequency": w[j] + w[k]})
                out.append({"kind": f"omega_{k + 1} - omega_{j + 1}", "frequency": w[k] - w[j]})
        return sorted((t for t in out if lo <= t["frequency"] <= hi), key=lambda t: t["frequency"])

    def plot(self, ax=None, *, tongues: bool = True):
        """The chart: the largest modulus in colour (log scale, stable in grey), the
        boundary largest = 1 + tol, and the tongues' openings marked on the Omega axis."""
        import matplotlib.pyplot as plt
        from matplotlib.colors import LogNorm

        if ax is None:
            _, ax = plt.subplots(figsize=(6.4, 4.2))
        growth = np.maximum(self.largest, 1.0 + self.tol).T
        mesh = ax.pcolormesh(self.frequencies, self.amplitudes, growth, shading="nearest", cmap="magma_r",
                             norm=LogNorm(vmin=1.0 + self.tol, vmax=max(growth.max(), 1.0 + 2 * self.tol)))
        ax.figure.colorbar(mesh, ax=ax, label="largest multiplier modulus")
        if len(self.frequencies) > 1 and len(self.amplitudes) > 1 and self.unstable.any() and not self.unstable.all():
            ax.contour(self.frequencies, self.amplitudes, self.largest.T, levels=[1.0 + self.tol], colors="k",
                       linewidths=0.8)
        if tongues:
            for t in self.tongues():
                ax.axvline(t["frequency"], color="tab:blue", lw=0.6, ls=":")
                ax.annotate(t["kind"], (t["frequency"], 0.0), xycoords=("data", "axes fraction"), rotation=90,
                            fontsize=7, va="bottom", ha="right", color="tab:blue")
        ax.set_xlabel("pulsation frequency Omega [rad/s]")
        ax.set_ylabel("pulsation amplitude mu [-]")
        ax.set_title(f"mean flow {self.mean_flow:.4g} kg/s, {self.modes} modes")
        return ax

    def to_xarray(self):
        """The chart as an ``xarray.Dataset`` (variable ``largest`` on (frequency, amplitude))."""
        import xarray as xr

        return xr.Dataset({"largest": (("frequency", "amplitude"), self.largest, {"units": "1"})},
                          coords={"frequency": ("frequency", self.frequencies, {"units": "rad/s"}),
                                  "amplitude": ("amplitude", self.amplitudes, {"units": "1"})},
                          attrs={"mean_flow": self.mean_flow, "modes": self.modes, "tol": self.tol})


def _distinct(w, rtol=1e-6):
    out = []
    for x in np.sort(w):
        if not out or x > out[-1] * (1 + rtol):
            out.append(float(x))
    return np.array(out)


def instability_chart(model, *, mean_flow: float, frequencies: Sequence[float], amplitudes: Sequence[float],
                      modes: Optional[int] = 8, steps: Optional[int] = None, tol: float = 1e-4,
                      executor=None, client=None, workers: Optional[int] = None,
                      progress: Optional[bool] = None) -> InstabilityChart:
    """The largest Floquet multiplier modulus of ``model`` on an (Omega, mu) grid of
    pulsating flows mdot(t) = mdot0 (1 + mu sin(Omega t)) (:func:`parametric_stability` at
    every point).

    Args:
        model: an element :class:`~pipeflex.Model`, a
            :class:`~pipeflex.multibody.MultibodySystem` or a :class:`~pipeflex.CoupledSystem`.
        mean_flow: mdot0 [kg/s].
        frequencies: Omega [rad/s], each > 0, no repeats.
        amplitudes: mu [-], each >= 0, no repeats.
        modes: modes retained (None: all); see :func:`parametric_stability`.
        steps: Magnus steps per period (default from each Omega and the highest retained frequency).
        tol: [-] stability tolerance on the modulus (see :func:`parametric_stability`).
        executor, client, workers, progress: where the columns (one per Omega, all mu at
            once) run, as in :func:`pipeflex.sweep` (default a local process pool;
            ``executor="serial"`` in this process).

    Returns:
        :class:`InstabilityChart` (``.plot()``, ``.tongues()``, ``.to_xarray()``).

    The model is linearised once (as for :func:`parametric_stability`); each column then costs ``steps``
    batched exponentials of n_mu 2k x 2k matrices. Raises ValueError for bad arguments
    (named) and RuntimeError if a column failed.
    """
    from ..sweeps import sweep

    mdot0, modes = _check_common(mean_flow, modes, tol)
    W = _grid("frequencies", frequencies, positive=True)
    mus = _grid("amplitudes", amplitudes, positive=False)
    if steps is not None:
        steps = _checks.positive_int("steps", steps)
    flow = _FlowModel(model, mdot0)
    mats = flow.project(modes)
    logger.info("instability_chart: %d frequencies x %d amplitudes, %d modes", len(W), len(mus), mats.n_modes)
    fn = functools.partial(chart_column, matrices=mats, amplitudes=tuple(float(m) for m in mus), steps=steps)
    ds = sweep(fn, frequency=[float(w) for w in W], executor=executor, client=client, workers=workers,
               progress=progress)
    errors = [e for e in np.asarray(ds["error"].values).ravel() if e]
    if errors:
        raise RuntimeError(f"instability_chart: {len(errors)} of {len(W)} columns failed; the first: {errors[0]}")
    largest = np.asarray(ds["largest"].values, float).reshape(len(W), len(mus))
    change = None
    more = flow.check_modes(mats.n_modes)
    if more is not None:  # the truncation checked where the growth is largest
        i, j = np.unravel_index(np.argmax(largest), largest.shape)
        change = abs(float(_largest(flow.project(more), W[i], [mus[j]], None)[0]) - float(largest[i, j]))
    n_steps = np.array([steps_per_period(mats, w) if steps is None else steps for w in W], dtype=int)
    return InstabilityChart(frequencies=W, amplitudes=mus, largest=largest, mean_flow=mdot0,
                            natural_frequencies=_frequencies(mats), modes=mats.n_modes, steps=n_steps,
                            truncation_change=change, fit_error=mats.fit_error, tol=float(tol))


def pulsating_flow(*, mean_flow: float, amplitude: float, frequency: float):
    """The pulsating flow mdot0 (1 + mu sin(Omega t)) for :func:`~pipeflex.simulate`: a
    :class:`~pipeflex.Sine` about the mean, exact in the flow and its rate (the fluid's
    acceleration term).

    Args:
        mean_flow: mdot0 [kg/s]. amplitude: mu [-] (>= 0). frequency: Omega [rad/s] (> 0).
    """
    from ..time_functions import Sine

    mdot0 = _checks.finite("mean_flow", mean_flow)
    mu = _checks.non_negative("amplitude", amplitude)
    W = _checks.positive("frequency", frequency)
    return Sine(omega=W, envelope=mu * mdot0, mean=mdot0)
