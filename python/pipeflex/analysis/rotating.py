"""Linear vibration about a steady rotation, in the co-rotating frame (Berzeri & Shabana, §5-7).

A model with a rotating hub (:meth:`ModelBuilder.rotating_hub`) turns rigidly at the rate
Omega about the hub axis a through its centre c. Seen from the frame turning with it, a
coordinate perturbation y(t) moves the nodes by P(t) y, P(0) = I, with P = R(Omega t) for
positions and ANCF slopes and P = T(Omega t a)^-1 R(Omega t) for rotation vectors. With the
library's linearisation (K, C, M) at t = 0 of the rotating state the equations ::

    M y_ddot + (C + 2 Omega M A) y_dot + (K + Omega C A + Omega^2 M B) y = 0

are autonomous, A = P'(0)/Omega, B = P''(0)/Omega^2: A = S, B = S^2 (S = skew(a)) for
positions and slopes, A = S/2, B = S^2/6 for rotation vectors. The term Omega^2 M B is
the centrifugal softening, 2 Omega M A the Coriolis (gyroscopic) matrix; K carries the
prestress. Two choices of the state about which K is taken:

* ``"steady_state"``: the nonlinear relative equilibrium R(q, v(q), a(q)) = 0 in the
  rotating frame (Newton with continuation in Omega^2); any element type.
* ``"small_deformation"``: Berzeri & Shabana's Section 5: geometry and strain gradients at the
  undeformed configuration, prestress from the first-order static strains under the
  centrifugal load of the undeformed beam, K = K_0 + Omega^2 G (ANCF Model A only).
  The matrices K_0, G, M are computed once; each Omega costs one eigen-solution.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Sequence

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .. import _checks, _core
from .._options import renamed
from ..errors import ConvergenceError
from ..results import Result
from ..state import State, as_core
from ._assembly import require_model, residual_and_tangent
from ._continuation import follow
from .eigen import GROWTH_TOL, SPARSE_MIN_DOFS, eigenvalues
from .linearize import Linearization
from .._blas import pinned as blas_pinned

LINEARIZATIONS = ("small_deformation", "steady_state")

#: Largest axial strain [-] :func:`rotating_frequencies` answers for (a first-order
#: strain of 1e11 at gamma = 1e8 is no answer). Berzeri & Shabana's Tables 3-5 reach a
#: first-order strain of ~1 at gamma = 50 (hub radius R = L); the bound leaves them a
#: decade. Checked on the first-order estimate before any solve (so a steady state far
#: outside is refused at once, not searched for minutes) and on the state linearised about.
MAX_STRAIN = 10.0


@dataclass(frozen=True)
class RotatingFrequencies(Result):
    """Dimensionless frequencies omega / omega0 in the rotating frame.

    Attributes:
        gamma: (k,) Omega / omega0 [-] (eq. 65).
        omega0: reference rate [rad/s] (eq. 64; ``model.info['omega0']``).
        transverse: (k, n_modes) in-plane bending frequencies / omega0 [-], ascending.
        longitudinal: (k, n_modes) axial (radial) ones / omega0 [-].
        out_of_plane: (k, n_modes) flapwise ones / omega0 [-] (NaN for planar models).
        growth: (k,) largest Re(lambda) / omega0 [-]; > 0 means the rotation is unstable.
        max_strain: (k,) largest axial strain of the state linearised about [-] (the
            first-order strain for "small_deformation").
        linearization: which linearisation was used.
        transverse_shapes: (k, n_modes, n_nodes, 2) real mode shapes of the transverse
            family: nodal displacements along the reference beam (radial) and normal to
            it (tangential) in the rotating frame, scaled to a largest tangential
            component of 1 (the phase of the complex gyroscopic mode that maximises it).
    """

    gamma: np.ndarray
    omega0: float
    transverse: np.ndarray
    longitudinal: np.ndarray
    out_of_plane: np.ndarray
    growth: np.ndarray
    max_strain: np.ndarray
    linearization: str
    transverse_shapes: np.ndarray = None


class _Frame:
    """The rotating-frame operators A, B (per unit Omega) of a model, on the coordinates of
    its unconstrained variant: the supports hold in the rotating frame, so the reduced
    matrices are T^T (K + Omega C A + Omega^2 M B) T with the full M, C, K. Sparse (A, B
    are nodal 3 x 3 blocks; the bases select coordinates): memory and work linear in the
    number of nodes; dense arrays below SPARSE_MIN_DOFS reduced coordinates (``dense``),
    where scipy.sparse's per-operation overhead made Berzeri & Shabana's 10-element Tables 2-5
    1.3-2.7 times slower."""

    def __init__(self, model):
        require_model(model, why="the rotating analyses follow a hub turning at a prescribed rate "
                                  "(ModelBuilder.rotating_hub), which only element models have")
        if model.hub is None:
            raise ValueError("the model has no rotating hub: add one with ModelBuilder.rotating_hub")
        self.model = model
        self.free = model.free_model()
        self.axis = model.hub.axis
        self.center = model.hub.center
        self.dense = model.n_dofs < SPARSE_MIN_DOFS
        self.T = self._form(sp.csr_matrix(model.basis))
        self.radial, self.tangential = self._directions()
        self.present = self.families()

    def _form(self, X):
        """X as the frame keeps its matrices: a dense array or CSR."""
        if self.dense:
            return X.toarray() if sp.issparse(X) else X
        return sp.csr_matrix(X)

    @functools.cached_property
    def _operators(self):
        """T_rel, A, B on the unconstrained model's coordinates (the core's
        ``rigid_rotation_operators``, the kinematics of its rotating state), made at their
        first use (the rotating state, solved in the core, needs none of them)."""
        # a ValueError "... planar ANCF nodes can only turn about the z axis" if the
        # rotation turns the supported increments out of the unconstrained model's
        parts = _core.rigid_rotation_operators(self.model.core, self.free.core, list(map(float, self.axis)))
        ops = tuple(sp.csc_matrix((data, indices, indptr), shape=shape) for data, indices, indptr, shape in parts)
        return tuple(X.toarray() for X in ops) if self.dense else ops

    @property
    def T_rel(self):
        """pinv(T_f) T: the model's coordinates in the unconstrained model's."""
        return self._operators[0]

    @property
    def A(self):
        """The rate operator per unit Omega on the unconstrained model's coordinates."""
        return self._operators[1]

    @property
    def B(self):
        """The rate operator per unit Omega^2 on the unconstrained model's coordinates."""
        return self._operators[2]

    def matrices(self, state, omega):
        """Reduced M, C, K of the rotating-frame equations at rate omega [rad/s] (sparse,
        or dense arrays if ``self.dense``)."""
        K, C, M = _matrices(self.free, state, self.dense)
        Tr = self.T_rel
        return (Tr.T @ M @ Tr, Tr.T @ (C + 2 * omega * M @ self.A) @ Tr,
                Tr.T @ (K + omega * C @ self.A + omega**2 * M @ self.B) @ Tr)

    def _directions(self):
        """Unit radial (along the reference beam, normal to the axis) and tangential
        directions of the structure, for classifying mode shapes."""
        x = self.model.positions - self.center
        x = x - np.outer(x @ self.axis, self.axis)
        far = x[np.argmax(np.linalg.norm(x, axis=1))]
        if np.linalg.norm(far) == 0:
            raise ValueError("the structure lies on the hub axis")
        er = far / np.linalg.norm(far)
        return er, np.cross(self.axis, er)

    def rigid_rotation(self, state, omega):
        """Sets the velocities and accelerations of ``state`` (a core state of the model) to
        those of the rigid rotation at rate omega [rad/s], phi = 0 (the core's
        ``rigid_rotation_rates``)."""
        _core.rigid_rotation_rates(self.model.core, state, list(map(float, self.center)),
                                   list(map(float, self.axis)), float(omega))

    def families(self):
        """Which of the directions radial, tangential, axial the structure can move in
        (a planar model has no axial, i.e. out-of-plane, family)."""
        T = sp.coo_matrix(self.T)
        pos = T.row % 6 < 3  # the nodes' position rows
        row, col, val = T.row[pos], T.col[pos], T.data[pos]
        _, entry = np.unique((row // 6) * T.shape[1] + col, return_inverse=True)  # (node, coordinate)
        tol = 1e-12 * (np.abs(val).max() if len(val) else 0.0)
        return np.array([np.any(np.abs(np.bincount(entry, weights=d[row % 6] * val)) > tol)
                         for d in (self.radial, self.tangential, self.axis)])

    def classify(self, vectors):
        """Share of each mode's nodal displacement along radial, tangential, axial."""
        full = self.T @ vectors
        n = self.model.n_nodes
        pos = np.concatenate([np.arange(6 * i, 6 * i + 3) for i in range(n)])
        u = full[pos].reshape(n, 3, -1)
        parts = np.array([np.sum(np.abs(np.einsum("k,nkm->nm", d, u)) ** 2, axis=0)
                          for d in (self.radial, self.tangential, self.axis)])
        return parts / np.maximum(parts.sum(axis=0), 1e-300)


def _matrices(model, state, dense=False):
    """K, C, M of ``model`` at ``state`` (its linearisation through the system object):
    sparse CSC, or dense arrays."""
    lin = model._linearization(model._system(state), model.mass_flow)  # the one system object
    K, C, M = lin["K"], lin["C"], lin["M"]
    if dense:
        return K.toarray(), C.toarray(), M.toarray()
    return sp.csc_matrix(K), sp.csc_matrix(C), sp.csc_matrix(M)


def _solve(A, b):
    """A^-1 b for a dense or sparse A; None if A is singular."""
    b = np.asarray(b, dtype=float)
    try:
        return spla.splu(sp.csc_matrix(A)).solve(b) if sp.issparse(A) else np.linalg.solve(A, b)
    except (RuntimeError, np.linalg.LinAlgError):
        return None


def _axial_strains(model, state) -> float:
    """Largest |eps| over the elements' end and mean strains (ANCF) or chord strains."""
    q = np.asarray(state.q)
    worst = 0.0
    for e in model.elements:
        p, r = e.nodes
        chord = np.linalg.norm(q[6 * r:6 * r + 3] - q[6 * p:6 * p + 3]) / e.length - 1.0
        worst = max(worst, abs(chord))
        if e.kind == "ancf":
            for n in (p, r):
                worst = max(worst, abs(np.linalg.norm(q[6 * n + 3:6 * n + 6]) - 1.0))
    return worst


#: Failed Newton steps a continuation of :func:`rotating_state` may halve before it gives up.
MAX_CONTINUATION_FAILURES = 60


@blas_pinned
@renamed(steps="continuation_steps")
def rotating_state(model, omega: float, *, state=None, state_omega: float = 0.0, continuation_steps: int = 1,
                   tol: float = 1e-10, max_iterations: int = 30):
    """The steady state of the model turning at rate ``omega`` [rad/s] with its hub.

    The core's static Newton on R(q, v(q), a(q)) = 0 with the rotating-frame Jacobian
    K + Omega C A + Omega^2 M B, continued in Omega^2 from ``state`` (default: the
    undeformed state) at rate ``state_omega`` over ``continuation_steps`` equal steps
    (``steps=`` is its deprecated name), a step being halved when Newton fails; ``tol``
    [-]: Newton tolerance on the increment relative to the model size; ``max_iterations``:
    Newton iterations per step (the names of :func:`pipeflex.steady_rotation`). Returns
    the state (positions at t = 0, with the velocities and accelerations of the rigid
    rotation).

    Raises:
        ConvergenceError: Newton failed (the message gives Omega; attributes
            ``iteration``, ``residual``), or more than ``MAX_CONTINUATION_FAILURES``
            steps failed (a fold: the continuation would creep towards it).
    """
    fr = _Frame(model)
    return _steady_state(fr, _checks.finite("omega", omega), as_core(model, state),
                         _checks.finite("state_omega", state_omega),
                         _checks.positive_int("continuation_steps", continuation_steps),
                         _checks.positive("tol", tol), _checks.positive_int("max_iterations", max_iterations))


def _steady_state(fr, omega, st, state_omega=0.0, n_steps=1, tol=1e-10, max_iterations=30):
    """:func:`rotating_state` with the model's :class:`_Frame` (built once per analysis,
    not per rate) and checked arguments; ``st`` a core state. One core Newton
    (``_core.rotating_state``: the tangent through the unconstrained model) per step of
    the continuation in Omega^2 (:func:`~pipeflex.analysis._continuation.follow`, a failed
    step's interval bisected)."""
    model = fr.model
    st.rebase(0.0)
    size = model.length_scale
    load = model.load_state()
    scale = model.force_scale()
    center, axis = list(map(float, fr.center)), list(map(float, fr.axis))
    # the sense of the rates on the way (down to omega = 0: that of the start)
    sense = np.sign(omega) if omega != 0.0 else np.sign(state_omega)

    def step(trial, w2):
        # the last step at omega itself: the state's rates are those of the rate asked for
        w = omega if w2 == omega**2 else sense * np.sqrt(w2)
        # a correction beyond half the model is Newton diverging: the step is halved
        out = _core.rotating_state(model.core, fr.free.core, trial, load, center, axis, w, size, tol,
                                   max_iterations, 0.5)
        return out["converged"], (w, out["iterations"], out["residual"])

    # near a fold Newton stalls on every step: the halving would creep towards it over
    # thousands of solves (30 s for one element; found by the fuzz run), hence the cap
    way = follow(step, st, start=state_omega**2, end=omega**2, steps=n_steps, halving="interval",
                 max_failures=MAX_CONTINUATION_FAILURES, min_step=1e-8 * max(omega**2, 1e-30))
    if way.done:
        return way.state
    w, it, rnorm = way.outcome
    if way.stop == "failures":
        raise ConvergenceError(f"rotating_state: Newton failed at Omega = {w:.6g} rad/s ({way.failures - 1} failed "
                               f"steps; the last steady state at Omega = {np.sqrt(way.t):.6g} rad/s): a fold "
                               f"or loss of the steady state near there (residual {rnorm:.3e} N, force scale "
                               f"{scale:.3e} N)", iteration=it, residual=rnorm)
    raise ConvergenceError(f"rotating_state: Newton failed at Omega = {w:.6g} rad/s after {it} iterations "
                           f"(residual {rnorm:.3e} N, force scale {scale:.3e} N)", iteration=it, residual=rnorm)


def _family_eigen(fr, lin, n_modes, k=None):
    """Eigenvalues with vectors holding the ``n_modes`` lowest modes (Im lambda > 0) of
    each family the structure has (:meth:`_Frame.families`), and (lambda, vectors,
    family index 0 radial, 1 tangential, 2 axial) of its modes with Im lambda > 0, and
    the k that sufficed (the start ``k`` of the next rate of a sweep).

    Below SPARSE_MIN_DOFS coordinates all eigenvalues (dense); above, the k nearest 0 by
    shift-invert Arnoldi, k doubled until every family has its n_modes (all of a
    family's modes below the k-th |lambda| are among them, so these are its lowest).
    """
    n = lin.K.shape[0]
    k = 2 * n_modes * int(np.count_nonzero(fr.present)) + 4 if k is None else k
    while True:
        dense = n < SPARSE_MIN_DOFS or 2 * k >= n
        eig = eigenvalues(lin, vectors=True) if dense else eigenvalues(lin, vectors=True, n_modes=k)
        up = eig.values.imag > 0
        lam, V = eig.values[up], eig.vectors[:, up]
        kind = np.argmax(fr.classify(V), axis=0)
        if dense or np.all(np.bincount(kind, minlength=3)[fr.present] >= n_modes):
            return eig, lam, V, kind, k
        k *= 2


def _modes(fr, M, C, K, state, n_modes, k=None):
    """Frequencies sorted into transverse, longitudinal and out-of-plane families, the
    growth rate, the transverse shapes and the k of :func:`_family_eigen`."""
    lin = Linearization(sp.csc_matrix(M), sp.csc_matrix(C), sp.csc_matrix(K), 0.0,
                        State.from_core(state, fr.model))
    eig, lam, V, kind, k = _family_eigen(fr, lin, n_modes, k)
    out = []
    for family in (1, 0, 2):  # tangential (transverse), radial (longitudinal), axial
        w = np.sort(lam[kind == family].imag)[:n_modes]
        out.append(np.concatenate([w, np.full(n_modes - len(w), np.nan)]))
    sel = np.flatnonzero(kind == 1)
    sel = sel[np.argsort(lam[sel].imag)][:n_modes]
    n = fr.model.n_nodes
    shapes = np.full((n_modes, n, 2), np.nan)
    for j, col in enumerate(sel):
        u = (fr.T @ V[:, col]).reshape(n, 6)[:, :3]
        ur, ut = u @ fr.radial, u @ fr.tangential
        big = np.argmax(np.abs(ut))
        ph = np.conj(ut[big]) / abs(ut[big])  # rotate the complex mode to a real tip/peak
        shapes[j, :, 0], shapes[j, :, 1] = (ph * ur).real / abs(ut[big]), (ph * ut).real / abs(ut[big])
    # growth above the round-off bound of each eigenvalue (0: stable); on the sparse path
    # of the eigenvalues computed (the lowest: where centrifugal softening acts)
    real = eig.values.real
    grows = real > np.maximum(GROWTH_TOL * np.abs(eig.values), eig.noise)
    growth = float(np.max(real[grows])) if np.any(grows) else 0.0
    return out, growth, shapes, k


@blas_pinned
def rotating_frequencies(model, *, gamma, linearization: str = "small_deformation",
                         n_modes: int = 3) -> RotatingFrequencies:
    """Natural frequencies of a rotating model, dimensionless as in Berzeri & Shabana (Tables 3-5).

    Args:
        model: a model with a rotating hub and ``model.info['omega0']`` (e.g.
            :func:`pipeflex.scenes.rotating_cantilever`).
        gamma: Omega / omega0 [-], a number or a sequence (computed in ascending order).
        linearization: ``"small_deformation"`` (Berzeri & Shabana's Section 5: undeformed geometry,
            first-order prestress; ANCF Model A) or ``"steady_state"`` (the full nonlinear
            steady state in the rotating frame; any element).
        n_modes: how many frequencies of each family to return.

    Returns:
        :class:`RotatingFrequencies`; ``transverse[i, j]`` is omega_j / omega0 of the
        (j+1)-th in-plane bending mode at ``gamma[i]``. Mode families are told apart by
        the direction of their nodal displacements (radial: longitudinal; tangential:
        transverse; along the axis: out-of-plane). A family with fewer than ``n_modes``
        modes in the model is padded with NaN.

    Raises:
        ValueError: bad options; or a gamma whose axial strain (first-order estimate,
            before any solve, and the steady state's) exceeds :data:`MAX_STRAIN`.
    """
    if linearization not in LINEARIZATIONS:
        raise ValueError(f"linearization must be one of {LINEARIZATIONS}, got {linearization!r}")
    fr = _Frame(model)
    if "omega0" not in model.info:
        raise ValueError("model.info has no 'omega0' (reference rate); build the model with "
                         "scenes.rotating_cantilever or set model.info['omega0'] [rad/s]")
    n_modes = _checks.positive_int("n_modes", n_modes)
    g = _gammas(gamma)
    w0 = float(model.info["omega0"])
    s0 = model.initial_state()
    # the first-order strain check, before any solve, for both linearisations
    parts, e1 = (_small_deformation_parts if linearization == "small_deformation" else _first_order)(
        model, fr, s0, g.max() * w0)
    order = np.argsort(g)
    res = np.full((len(g), 3, n_modes), np.nan)
    shapes = np.full((len(g), n_modes, model.n_nodes, 2), np.nan)
    growth = np.zeros(len(g))
    strain = np.zeros(len(g))
    if linearization == "small_deformation":
        k = None
        for i in order:
            w = g[i] * w0
            fam, growth[i], shapes[i], k = _modes(fr, *_small_deformation_matrices(parts, w), s0, n_modes, k)
            res[i] = fam
            strain[i] = w**2 * e1
    else:
        st, w_prev, k = None, 0.0, None
        for i in order:
            w = g[i] * w0
            st = _steady_state(fr, w, model.initial_state(), n_steps=4) if st is None else _continue(fr, st, w_prev, w)
            w_prev = w
            fam, growth[i], shapes[i], k = _modes(fr, *fr.matrices(st, w), st, n_modes, k)
            res[i] = fam
            strain[i] = _axial_strains(model, st)
            _check_strain(g[i], strain[i], "")
    return RotatingFrequencies(g, w0, res[:, 0] / w0, res[:, 1] / w0, res[:, 2] / w0, growth / w0, strain,
                               linearization, shapes)


def _first_order(model, fr, s0, w_max):
    """The undeformed state's reduced K0 and M with the full K0f, C0f, Mf, the axial
    displacement per unit Omega^2 u1 and its strain e1; the strain at ``w_max`` [rad/s]
    checked (before any solve)."""
    K0f, C0f, Mf = _matrices(fr.free, s0, fr.dense)
    Tr = fr.T_rel
    K0, M = Tr.T @ K0f @ Tr, Tr.T @ Mf @ Tr
    u1, e1 = _unit_strain(model, fr, s0, K0)
    _check_strain(w_max / float(model.info.get("omega0", 1.0)), w_max**2 * e1, "first-order ")
    return (K0f, C0f, Mf, K0, M, u1), e1


def _small_deformation_parts(model, fr, s0, w_max):
    """The Omega-independent matrices of Berzeri & Shabana's Section 5 linearisation
    (reduced: M, C0, K0, G, MA, MB, CA) and e1 (:func:`_first_order`)."""
    (_, C0f, Mf, K0, M, u1), e1 = _first_order(model, fr, s0, w_max)
    Tr = fr.T_rel
    G = _unit_prestress(model, fr, s0, u1)
    return (M, Tr.T @ C0f @ Tr, K0, G, Tr.T @ Mf @ fr.A @ Tr, Tr.T @ Mf @ fr.B @ Tr, Tr.T @ C0f @ fr.A @ Tr), e1


def _small_deformation_matrices(parts, w):
    """(M, C, K) at Omega = w [rad/s] from :func:`_small_deformation_parts`."""
    M, C0, K0, G, MA, MB, CA = parts
    return M, C0 + 2 * w * MA, K0 + w * CA + w**2 * (G + MB)


def _continue(fr, state, state_omega, omega):
    """Steady state at omega continued from a nearby one (at most 4 Omega^2 steps)."""
    try:
        return _steady_state(fr, omega, state.copy(), state_omega)
    except ConvergenceError:
        return _steady_state(fr, omega, fr.model.initial_state(), n_steps=8)


def _unit_strain(model, fr, s0, K0):
    """The static displacement u per unit Omega^2 under the centrifugal load of the
    undeformed state, K0 u = f_c, f_c = -M_full B (q - c) (from the residual of the rigid
    rotation at rate 1), and the largest first-order strain per unit Omega^2 [s^2]."""
    s = s0.copy()
    fr.rigid_rotation(s, 1.0)
    s.v = np.zeros_like(np.asarray(s.v))  # only the centripetal acceleration loads
    f, _ = residual_and_tangent(model, s, model.load_state(), load_factor=0.0, matrix=False)
    u = _solve(K0, -np.asarray(f))
    if u is None:
        raise np.linalg.LinAlgError("the stiffness of the undeformed model is singular (a mechanism)")
    probe = s0.copy()
    _core.add_increment(model.core, probe, u * 1e-6, "q")
    return u, _axial_strains(model, probe) * 1e6


def _unit_prestress(model, fr, s0, u):
    """Prestress stiffness per unit Omega^2 of the first-order displacement u
    (:func:`_unit_strain`)."""
    rows, cols, vals = _core.assemble_geometric(model.core, s0, fr.T @ u)
    G = sp.csc_matrix((vals, (rows, cols)), shape=(len(u), len(u)))
    return G.toarray() if fr.dense else G


def _gammas(gamma) -> np.ndarray:
    """``gamma`` [-] as a non-empty 1-D array of finite values >= 0, else a ValueError
    naming gamma, the rule and what was given (not numpy's message)."""
    rule = "gamma (Omega / omega0 [-]) must be a number >= 0 or a non-empty 1-D sequence of them"
    if isinstance(gamma, (str, bytes)):  # numpy would try to parse text as a number
        raise ValueError(f"{rule}, got {gamma!r}")
    try:
        g = np.atleast_1d(np.asarray(gamma, dtype=float))
    except (TypeError, ValueError):
        raise ValueError(f"{rule}, got {gamma!r}") from None
    if g.ndim != 1 or g.size == 0:
        raise ValueError(f"{rule}, got {gamma!r}" + (" (empty: give at least one gamma)" if g.size == 0 else ""))
    bad = np.flatnonzero(~(np.isfinite(g) & (g >= 0)))
    if bad.size:
        raise ValueError(f"{rule}, got gamma[{bad[0]}] = {g[bad[0]]}")
    return g


def _check_strain(gamma, strain, kind):
    if not strain <= MAX_STRAIN:
        raise ValueError(f"gamma = {gamma:g} gives a {kind}axial strain of {strain:.3g}, above MAX_STRAIN = "
                         f"{MAX_STRAIN:g}: outside the elements' validity; lower gamma")


@blas_pinned
def resonance_speed(model, *, mode: int = 1, gamma_range: Sequence[float] = (0.5, 20.0),
                    linearization: str = "small_deformation") -> float:
    """gamma at which the ``mode``-th transverse frequency equals the rotation rate
    (omega_mode = Omega, Berzeri & Shabana, Section 7: 3.88 for mode 1, N = 0, R = 0).

    Raises:
        ValueError: ``mode`` beyond the model's transverse modes, a bad ``gamma_range``
            (low < high, both >= 0), or no resonance of the mode within it.
    """
    from ._roots import brentq

    j = _checks.positive_int("mode", mode) - 1
    try:
        lo, hi = (_checks.non_negative(f"gamma_range[{k}]", x) for k, x in enumerate(gamma_range))
    except TypeError:
        raise TypeError(f"gamma_range must be a pair (low, high) of gamma values, got {gamma_range!r}") from None
    if not lo < hi:
        raise ValueError(f"gamma_range must be (low, high) with low < high, got {tuple(gamma_range)}")
    available = np.count_nonzero(np.isfinite(
        rotating_frequencies(model, gamma=lo, linearization=linearization, n_modes=j + 1).transverse[0]))
    if j >= available:
        raise ValueError(f"mode = {mode}: the model has {available} transverse modes (refine it for more)")

    def f(g):
        return rotating_frequencies(model, gamma=g, linearization=linearization, n_modes=j + 1).transverse[0, j] - g

    if f(lo) * f(hi) > 0:
        raise ValueError(f"no resonance of mode {mode} for gamma in {tuple(gamma_range)}")
    return float(brentq(f, lo, hi, xtol=1e-10))
