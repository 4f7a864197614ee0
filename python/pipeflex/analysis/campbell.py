"""Campbell diagrams: natural frequencies of a rotating model against its rotation rate,
branches followed by their mode shapes.

The rotating-frame eigen-problem is that of :mod:`pipeflex.analysis.rotating` (Berzeri &
Shabana, Sections 5-7): at each rate Omega the linear equations about the steady rotation,
seen from the turning frame,

    M y_ddot + (C + 2 Omega M A) y_dot + (K + Omega C A + Omega^2 M B) y = 0,

are solved for their frequencies omega and complex mode shapes. Sorting the frequencies
at each speed mixes branches where two of them cross (or veer); here each branch is
followed from speed to speed by the modal assurance criterion of the nodal translations
u (complex, in the rotating frame)::

    MAC(u_a, u_b) = |u_a^H u_b|^2 / ((u_a^H u_a) (u_b^H u_b)),

pairing the branches of one speed with the modes of the next by the assignment of largest
total MAC (Hungarian method). A branch is labelled by its family at the first speed: its
nodal displacements mostly tangential ("in-plane" bending), along the hub axis
("flapwise") or radial ("axial"). The speeds at which a branch crosses the excitation
lines omega = k Omega (k = 1, 2, 3: once-, twice-, three-per-revolution forcing) are
found by cubic-spline interpolation of the branch between the computed speeds.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Optional, Sequence, Tuple

import numpy as np
import scipy.sparse as sp

from .. import _checks
from .._blas import pinned as blas_pinned
from ..results import Result
from ..state import State
from .eigen import GROWTH_TOL, eigenvalues
from .linearize import Linearization
from .rotating import (LINEARIZATIONS, _axial_strains, _check_strain, _continue, _Frame, _small_deformation_matrices,
                       _small_deformation_parts, _steady_state)

#: Reduced coordinates from which each speed's modes come from shift-invert Arnoldi
#: (:func:`_candidates`): the break-even of the ANCF cantilever, 9 speeds, 4 branches
#: (one BLAS thread, load ~6): 30 elements (121 coordinates) 0.33 s dense against
#: 0.18 s sparse, 20 elements 0.14 s against 0.14 s, 40 elements 0.76 s against 0.25 s.
SPARSE_MIN_DOFS = 100

#: Family labels, by the main direction of a mode's nodal displacements: radial,
#: tangential (in the plane of rotation), along the hub axis.
FAMILIES = ("axial", "in-plane", "flapwise")


@dataclass(frozen=True)
class Campbell(Result):
    """A Campbell diagram: frequencies in the rotating frame against the rotation rate,
    one column per branch followed by its mode shape.

    Attributes:
        speeds: (n_speeds,) Omega [rad/s] rotation rates, ascending.
        gamma: (n_speeds,) Omega / omega0 [-] if the rates were given as ``gamma``, else None.
        omega0: omega0 [rad/s] reference rate (NaN if the model has none).
        frequencies: (n_speeds, n_branches) omega [rad/s] of each branch; a branch starts
            at the first speed among the ``n_modes`` lowest frequencies.
        mac: (n_speeds - 1, n_branches) MAC [-] of each branch's mode between the speeds
            i and i + 1 (1: the same shape).
        family: (n_branches,) "in-plane", "flapwise" or "axial": the branch's family at
            the first speed.
        share: (n_speeds, n_branches, 3) fraction [-] of the branch's squared nodal
            translations that is radial, tangential, along the axis (a branch through a
            veering changes family on its way).
        modes: (n_speeds, n_branches, n_dofs) complex mode shapes [-] in the model's
            reduced coordinates (largest entry 1), for :func:`pipeflex.plot.mode_shape`.
        growth: (n_speeds,) largest Re(lambda) [1/s] over all modes (0: stable).
        harmonics: (k,) the multiples k of the excitation lines omega = k Omega.
        crossing_k, crossing_branch: (m,) of each crossing: k and the branch (column).
        crossing_speed: (m,) Omega [rad/s] at which omega_branch = k Omega.
        crossing_frequency: (m,) omega = k Omega [rad/s] there.
        linearization: ``"small_deformation"`` or ``"steady_state"`` (as
            :func:`pipeflex.rotating_frequencies`).
    """

    speeds: np.ndarray
    gamma: Optional[np.ndarray]
    omega0: float
    frequencies: np.ndarray
    mac: np.ndarray
    family: np.ndarray
    share: np.ndarray
    modes: np.ndarray
    growth: np.ndarray
    harmonics: np.ndarray
    crossing_k: np.ndarray
    crossing_branch: np.ndarray
    crossing_speed: np.ndarray
    crossing_frequency: np.ndarray
    linearization: str

    @property
    def crossings(self) -> list:
        """The crossings as tuples (k, branch, Omega [rad/s], omega [rad/s]), by speed."""
        return [(int(k), int(b), float(s), float(w)) for k, b, s, w in
                zip(self.crossing_k, self.crossing_branch, self.crossing_speed, self.crossing_frequency)]

    def crossing(self, k: int, branch: int) -> float:
        """Omega [rad/s] of the (first) crossing of ``branch`` with omega = k Omega; NaN if none."""
        hit = np.flatnonzero((self.crossing_k == k) & (self.crossing_branch == branch))
        return float(self.crossing_speed[hit[0]]) if len(hit) else float("nan")

    def to_xarray(self):
        """The diagram as an ``xarray.Dataset``: ``frequencies`` over (speed, branch) with
        the coordinates ``speed`` (= ``speeds`` [rad/s]), ``gamma`` (on ``speed``, if
        given), ``branch`` (indices) and ``family`` (on ``branch``); ``mac`` over
        (speed_interval, branch), ``share`` over (speed, branch, direction: radial,
        tangential, axial), the complex ``modes`` as ``modes_real`` and ``modes_imag``
        over (speed, branch, dof), ``growth`` over speed, the crossings over
        ``crossing``, ``harmonics`` over ``harmonic`` and ``omega0``; every variable with
        ``units`` (where it has one) and ``long_name``; ``attrs["linearization"]``.
        xarray loads here."""
        from ..results import field_info, to_dataset

        n_branches = self.frequencies.shape[1]
        coords = {"speed": ("speed", self.speeds, field_info("Campbell", "speeds")[0]),
                  "branch": ("branch", np.arange(n_branches), {"long_name": "branch index"}),
                  "family": ("branch", np.asarray(self.family, dtype=object), field_info("Campbell", "family")[0]),
                  "direction": ("direction", np.array(["radial", "tangential", "axial"], dtype=object),
                                {"long_name": "direction of the nodal translations"})}
        if self.gamma is not None:
            coords["gamma"] = ("speed", self.gamma, field_info("Campbell", "gamma")[0])
        names = ("omega0", "frequencies", "mac", "share", "modes", "growth", "harmonics", "crossing_k",
                 "crossing_branch", "crossing_speed", "crossing_frequency")
        return to_dataset("Campbell", {n: getattr(self, n) for n in names}, coords,
                          {"linearization": self.linearization})


@blas_pinned
def campbell(model, *, gamma: Optional[Sequence[float]] = None, omega: Optional[Sequence[float]] = None,
             n_modes: int = 6, linearization: Optional[str] = None, harmonics: Sequence[int] = (1, 2, 3),
             executor="serial", client=None, workers: Optional[int] = None) -> Campbell:
    """Campbell diagram of a model with a rotating hub: branches followed by MAC.

    Args:
        model: a model with a rotating hub (:meth:`~pipeflex.ModelBuilder.rotating_hub`),
            e.g. :func:`pipeflex.scenes.rotating_cantilever` (ANCF or ``formulation="pipe"``).
        gamma: Omega / omega0 [-] rates, ascending (needs ``model.info['omega0']``); or
        omega: Omega [rad/s] rates, ascending. Exactly one of the two. The steps must be
            small enough for the mode shapes to change little between neighbours
            (see :attr:`Campbell.mac`).
        n_modes: number of branches: the lowest frequencies at the first speed.
        linearization: ``"small_deformation"`` (ANCF Model A beams only) or
            ``"steady_state"`` (any element), as :func:`pipeflex.rotating_frequencies`;
            default: the first for a model of ANCF Model A elements, else the second.
        harmonics: the k of the excitation lines omega = k Omega whose crossings are found.
        executor: ``"serial"`` (default): the speeds one after another in this process (the
            steady states continued from speed to speed). Anything else runs the speeds
            as the points of :func:`pipeflex.sweep` (each steady state from rest):
            None, a process pool of ``workers`` processes; or a
            ``concurrent.futures.Executor``.
        client: a ``dask.distributed.Client``: the speeds run on its cluster (via
            :func:`pipeflex.sweep`).
        workers: processes of the default pool (``executor=None``).

    Returns:
        :class:`Campbell`.

    Raises:
        ValueError: no hub, bad rates, no ``omega0`` for ``gamma``, or an axial strain
            above :data:`~pipeflex.analysis.rotating.MAX_STRAIN` (as
            :func:`pipeflex.rotating_frequencies`).
        ConvergenceError: a steady state was not found (``"steady_state"``, serial).
        RuntimeError: a speed failed in the sweep (its error in the message).
    """
    fr = _Frame(model)
    if (gamma is None) == (omega is None):
        raise ValueError("give exactly one of gamma (Omega / omega0) and omega [rad/s]")
    w0 = float(model.info.get("omega0", np.nan))
    if gamma is not None:
        if not np.isfinite(w0):
            raise ValueError("gamma needs model.info['omega0'] [rad/s]; give omega [rad/s] instead")
        speeds = _rates("gamma", gamma) * w0
    else:
        speeds = _rates("omega", omega)
    n_modes = _checks.positive_int("n_modes", n_modes)
    ks = np.array([_checks.positive_int("harmonics", k) for k in harmonics], dtype=int)
    linearization = _default_linearization(model) if linearization is None else linearization
    if linearization not in LINEARIZATIONS:
        raise ValueError(f"linearization must be one of {LINEARIZATIONS}, got {linearization!r}")
    if linearization == "small_deformation" and not _model_a(model):
        raise ValueError('linearization="small_deformation" needs ANCF Model A elements; use "steady_state"')
    count = _candidates(fr, n_modes)
    if isinstance(executor, str) and executor == "serial" and client is None:
        solutions = list(_serial(model, fr, speeds, linearization, count))
    else:
        solutions = _swept(model, speeds, linearization, executor, client, workers, count)
    freqs, mac, share, modes, growth = _track(fr, solutions, n_modes)
    family = np.array([FAMILIES[i] for i in np.argmax(share[0], axis=1)])
    ck, cb, cs, cw = _crossings(speeds, freqs, ks)
    return Campbell(speeds, speeds / w0 if gamma is not None else None, w0, freqs, mac, family, share, modes,
                    growth, ks, ck, cb, cs, cw, linearization)


def _rates(name, values) -> np.ndarray:
    s = np.atleast_1d(np.asarray(values, dtype=float))
    if s.ndim != 1 or len(s) < 2 or not np.all(np.isfinite(s)) or np.any(s < 0):
        raise ValueError(f"{name} must be a finite non-negative 1-D sequence of at least 2 rates")
    if np.any(np.diff(s) <= 0):
        raise ValueError(f"{name} must be strictly ascending")
    return s


def _model_a(model) -> bool:
    return all(e.kind == "ancf" and e.elastic == "A" for e in model.elements)


def _default_linearization(model) -> str:
    return "small_deformation" if _model_a(model) else "steady_state"


def _candidates(fr, n_modes):
    """How many of the lowest modes each speed offers the tracking of ``n_modes``
    branches: all (None, the dense path) below :data:`SPARSE_MIN_DOFS` coordinates;
    above, 2 n_modes + 4 (a branch would have to be overtaken by n_modes + 4 others
    between two speeds to leave them) by shift-invert Arnoldi, linear in the model size."""
    return None if fr.T.shape[1] < SPARSE_MIN_DOFS else 2 * n_modes + 4


def _eigen(fr, M, C, K, state, count=None):
    """The ``count`` lowest modes with Im(lambda) > 0 (all if None), ascending frequency:
    lambda [1/s], reduced shapes, the largest Re(lambda) [1/s] (of those computed);
    sparse from :data:`SPARSE_MIN_DOFS` coordinates on."""
    lin = Linearization(sp.csc_matrix(M), sp.csc_matrix(C), sp.csc_matrix(K), 0.0, State.from_core(state, fr.model))
    if count is None or K.shape[0] < SPARSE_MIN_DOFS:
        eig = eigenvalues(lin, vectors=True)
    else:
        eig = eigenvalues(lin, vectors=True, n_modes=2 * count, method="sparse")
    up = eig.values.imag > 0
    lam, V = eig.values[up], eig.vectors[:, up]
    order = np.argsort(lam.imag)[:count]
    real = eig.values.real
    grows = real > np.maximum(GROWTH_TOL * np.abs(eig.values), eig.noise)  # above round-off
    growth = float(np.max(real[grows])) if np.any(grows) else 0.0
    return lam[order], V[:, order], growth


def _serial(model, fr, speeds, linearization, count=None):
    """(lambda, shapes, growth) at each speed, in this process (``count``: :func:`_eigen`)."""
    if linearization == "small_deformation":
        s0 = model.initial_state()
        parts = _small_deformation_parts(model, fr, s0, speeds.max())[0]
        for w in speeds:
            yield _eigen(fr, *_small_deformation_matrices(parts, w), s0, count)
    else:
        st, w_prev = None, 0.0
        for w in speeds:
            st = _steady_state(fr, w, model.initial_state(), n_steps=4) if st is None else _continue(fr, st, w_prev, w)
            w_prev = w
            _check(model, st, w)
            yield _eigen(fr, *fr.matrices(st, w), st, count)


def _check(model, state, w):
    w0 = float(model.info.get("omega0", 1.0))
    _check_strain(w / w0, _axial_strains(model, state), "")


def rotating_modes(model, *, omega: float, linearization: Optional[str] = None,
                   n_modes: Optional[int] = None) -> dict:
    """The rotating-frame modes at one rate ``omega`` [rad/s] (also a point of the sweep of
    :func:`campbell`), the steady state found from rest: all of them (dense), or with
    ``n_modes`` the n_modes lowest (sparse shift-invert from :data:`SPARSE_MIN_DOFS`
    coordinates on).

    Returns:
        dict: ``eigenvalue`` (k,) lambda [1/s] with Im > 0, ascending frequency;
        ``shapes`` (n_dofs, k) complex mode shapes in reduced coordinates; ``share``
        (k, 3) fraction [-] of each mode's squared nodal translations that is radial,
        tangential, along the hub axis; ``growth`` largest Re(lambda) [1/s] (0: stable).
    """
    fr = _Frame(model)
    omega = _checks.finite("omega", omega)
    count = None if n_modes is None else _checks.positive_int("n_modes", n_modes)
    linearization = _default_linearization(model) if linearization is None else linearization
    if linearization not in LINEARIZATIONS:
        raise ValueError(f"linearization must be one of {LINEARIZATIONS}, got {linearization!r}")
    if linearization == "small_deformation":
        s0 = model.initial_state()
        lam, V, g = _eigen(fr, *_small_deformation_matrices(_small_deformation_parts(model, fr, s0, abs(omega))[0], omega),
                           s0, count)
    else:
        st = _steady_state(fr, omega, model.initial_state(), n_steps=4)
        _check(model, st, omega)
        lam, V, g = _eigen(fr, *fr.matrices(st, omega), st, count)
    return {"eigenvalue": lam, "shapes": V, "share": fr.classify(V).T, "growth": g}


def _swept(model, speeds, linearization, executor, client, workers, count=None):
    from ..sweeps import sweep

    fn = functools.partial(rotating_modes, model=model, linearization=linearization, n_modes=count)
    if client is not None and isinstance(executor, str) and executor == "serial":
        executor = None
    ds = sweep(fn, executor=executor, client=client, workers=workers, progress=False, omega=list(speeds))
    if ds.attrs.get("n_failed", 0):
        bad = [str(e) for e in np.asarray(ds["error"].values).ravel() if str(e)]
        raise RuntimeError(f"campbell: {len(bad)} speed(s) failed: {bad[0]}")
    lam = ds["eigenvalue_real"].values + 1j * ds["eigenvalue_imag"].values
    V = ds["shapes_real"].values + 1j * ds["shapes_imag"].values
    return [(lam[i], V[i], float(ds["growth"].values[i])) for i in range(len(speeds))]


def mac(a, b) -> np.ndarray:
    """Modal assurance criterion [-] between the columns of ``a`` (n, p) and ``b`` (n, r):
    ``|a_i^H b_j|^2 / ((a_i^H a_i)(b_j^H b_j))``, a (p, r) array (1-D inputs: one column)."""
    a = np.asarray(a)
    b = np.asarray(b)
    a = a[:, None] if a.ndim == 1 else a
    b = b[:, None] if b.ndim == 1 else b
    num = np.abs(a.conj().T @ b) ** 2
    den = np.outer(np.sum(np.abs(a) ** 2, axis=0), np.sum(np.abs(b) ** 2, axis=0))
    return num / np.maximum(den, 1e-300)


def _translations(fr, V) -> np.ndarray:
    """Nodal translations (3 n_nodes, k) of reduced shapes V."""
    full = fr.T @ V
    n = fr.model.n_nodes
    pos = np.concatenate([np.arange(6 * i, 6 * i + 3) for i in range(n)])
    return full[pos]


def _track(fr, solutions, n_modes):
    """Follow the n_modes lowest modes of the first speed through the others by MAC."""
    from scipy.optimize import linear_sum_assignment

    n = len(solutions)
    lam0, V0, _ = solutions[0]
    if len(lam0) < n_modes:
        raise ValueError(f"the model has only {len(lam0)} oscillatory modes, n_modes = {n_modes}")
    n_dofs = V0.shape[0]
    freqs = np.full((n, n_modes), np.nan)
    macs = np.full((n - 1, n_modes), np.nan)
    share = np.full((n, n_modes, 3), np.nan)
    modes = np.zeros((n, n_modes, n_dofs), dtype=complex)
    growth = np.zeros(n)
    prev = None
    for i, (lam, V, g) in enumerate(solutions):
        ok = np.isfinite(lam)
        lam, V = lam[ok], V[:, ok]
        growth[i] = g
        U = _translations(fr, V)
        if U.shape[1] < n_modes:
            raise ValueError(f"only {U.shape[1]} oscillatory modes at speed {i}, n_modes = {n_modes}; lower n_modes")
        if prev is None:
            pick = np.arange(n_modes)
        else:
            m = mac(prev, U)
            # largest total MAC; a tiny frequency term only breaks exact ties
            rel = np.abs(lam.imag[None, :] - freqs[i - 1][:, None]) / np.maximum(np.abs(freqs[i - 1][:, None]), 1e-300)
            _, pick = linear_sum_assignment(-(m - 1e-9 * rel))
            macs[i - 1] = m[np.arange(n_modes), pick]
        freqs[i] = lam[pick].imag
        share[i] = fr.classify(V[:, pick]).T
        for b, j in enumerate(pick):
            v = V[:, j]
            modes[i, b] = v / v[np.argmax(np.abs(v))]
        prev = U[:, pick]
    return freqs, macs, share, modes, growth


def _crossings(speeds, freqs, ks) -> Tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Where each branch meets omega = k Omega: sign changes of omega_b - k Omega between
    neighbouring speeds, located on a cubic spline of the branch (linear with < 4 speeds)."""
    from scipy.interpolate import CubicSpline

    from ._roots import brentq

    out = []
    for b in range(freqs.shape[1]):
        w = freqs[:, b]
        spline = CubicSpline(speeds, w) if len(speeds) >= 4 else None
        for k in ks:
            d = w - k * speeds
            for i in np.flatnonzero(np.sign(d[:-1]) * np.sign(d[1:]) < 0):
                lo, hi = speeds[i], speeds[i + 1]
                if spline is not None and (spline(lo) - k * lo) * (spline(hi) - k * hi) < 0:
                    s = brentq(lambda x: float(spline(x)) - k * x, lo, hi, xtol=1e-14 * max(hi, 1.0))
                else:
                    s = lo - d[i] * (hi - lo) / (d[i + 1] - d[i])
                out.append((int(k), b, float(s), float(k * s)))
            exact = np.flatnonzero(d == 0)
            out.extend((int(k), b, float(speeds[i]), float(w[i])) for i in exact if speeds[i] > 0)
    out.sort(key=lambda c: (c[2], c[0], c[1]))
    if not out:
        return np.zeros(0, int), np.zeros(0, int), np.zeros(0), np.zeros(0)
    k, b, s, w = zip(*out)
    return np.array(k, int), np.array(b, int), np.array(s), np.array(w)
