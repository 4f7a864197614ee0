"""Flexible bodies in the floating frame of reference (van Voorthuizen et al., sections 5 and 7).

A body is a straight beam or pipe of ``n_elements`` two-node 3-D beam elements along
its local x axis, from s = -L/2 to L/2; the floating frame sits at the centre node. The
elastic displacements are reduced, u = Phi eta, by Craig-Bampton (boundary nodes = the
two end nodes, the centre node fixed to remove rigid motion, plus internal
fixed-interface modes) or kept in full (every node but the centre). A curved pipe is
a straight body with a preimposed, stress-free elastic deformation eta0 (eq. 70).

The constant inertia shape integrals (eqs. 64-69) are assembled over the elements from
the C++ element kernel and projected on B = [Psi0 Phi]; the C++ body kernel then
evaluates the mass matrix, quadratic-velocity and fluid terms at run time.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

import numpy as np
import scipy.linalg as sla

from .. import _checks, _core
from ..rotation import skew
from ..sections import PipeSection, refuse_unsupported, require_section

REDUCTIONS = ("craig_bampton", "full")

#: Most elements of one floating-frame body: its reduction works on dense matrices of
#: 6 (n_elements + 1) rows (1000 elements: 6006, ~0.3 GB each).
MAX_BODY_ELEMENTS = 1000


@dataclass(frozen=True, eq=False)
class FlexibleBody:
    """An immutable reduced body: geometry, reduction basis and the compiled constants.

    Attributes:
        length: L [m] (arc length of the straight reference).
        n_elements: number of beam elements; ``nodes_s`` [m] their node coordinates s.
        section: the :class:`~pipeflex.PipeSection` (``pipe_mass`` mu_p and
            ``fluid_mass`` mu_f [kg/m], ``EA`` [N], ``GJ``, ``EI``, ``EIz`` [N m^2]).
        reduction: ``"craig_bampton"`` or ``"full"`` (or ``"custom"``).
        internal_modes: fixed-interface modes kept (Craig-Bampton).
        basis: Phi (6 n_nodes x m), nodal [u, theta] per node in the body frame.
        eta0: preimposed elastic coordinates (m) [m, rad mixed].
        data: the compiled constants (``_core.FfrfBodyData``).
        mass: total mass (pipe + fluid) [kg].
        foundation: the Winkler foundation's constants (section ``k_found`` > 0; None
            without): ``cpp/include/pipeflex/elements/ffrf_body.hpp``, FfrfFoundation.

    Pickling and :func:`copy.deepcopy` rebuild the body with :func:`flexible_body` from
    the arguments it was made with (the compiled constants are not picklable).
    """

    length: float
    n_elements: int
    section: PipeSection
    reduction: str
    internal_modes: int
    nodes_s: np.ndarray
    basis: np.ndarray
    eta0: np.ndarray
    data: object
    mass: float
    _arguments: Optional[dict] = field(default=None, repr=False)
    foundation: Optional[dict] = field(default=None, repr=False)

    def __reduce__(self):
        if self._arguments is None:
            raise TypeError("this FlexibleBody was not made by flexible_body(): it cannot be pickled")
        return _rebuild_body, (self._arguments,)

    def __post_init__(self):
        # the compiled body holds copies: editing these arrays would desynchronise it
        for a in (self.nodes_s, self.basis, self.eta0, *(self.foundation or {}).values()):
            if isinstance(a, np.ndarray):
                a.flags.writeable = False

    @property
    def n_nodes(self) -> int:
        return self.n_elements + 1

    @property
    def n_modes(self) -> int:
        """Number of elastic coordinates m."""
        return self.basis.shape[1]

    @property
    def n_coordinates(self) -> int:
        """6 frame coordinates + m elastic ones."""
        return 6 + self.n_modes

    def node_index(self, node) -> int:
        """Node index from an int or ``"start"``, ``"center"``, ``"end"``."""
        return node_index(self.n_elements, node)

    def node_rows(self, node: int):
        """(Phi_u (3 x m), Phi_theta (3 x m), x (3,)) of a node in the body frame."""
        i = self.node_index(node)
        return self.basis[6 * i:6 * i + 3], self.basis[6 * i + 3:6 * i + 6], np.array([self.nodes_s[i], 0.0, 0.0])


def node_index(n_elements: int, node) -> int:
    """Index of a node of a body of ``n_elements`` elements from an int or ``"start"``,
    ``"center"``, ``"end"``."""
    names = {"start": 0, "center": n_elements // 2, "end": n_elements}
    if isinstance(node, str):
        if node not in names:
            raise ValueError(f"node must be an index 0..{n_elements} or one of {tuple(names)}, got {node!r}")
        return names[node]
    if isinstance(node, bool) or not isinstance(node, (int, np.integer)) or not 0 <= node <= n_elements:
        raise ValueError(f"node must be an index 0..{n_elements} or one of {tuple(names)}, got {node!r}")
    return int(node)


def _rebuild_body(arguments: dict) -> "FlexibleBody":
    return flexible_body(**arguments)


def _modal_damping_matrix(zeta, K: np.ndarray, M: np.ndarray) -> Optional[np.ndarray]:
    """D = M Phi diag(2 zeta omega) Phi^T M of the modes K phi = omega^2 M phi (phi^T M phi
    = 1, ascending omega [rad/s]) for the ratios zeta [-] (a number or one per mode, >= 0);
    None when all are zero (the kernel then skips the term)."""
    m = K.shape[0]
    if np.ndim(zeta) == 0:
        z = np.full(m, _checks.non_negative("modal_damping", zeta))
    else:
        z = np.asarray([_checks.non_negative(f"modal_damping[{i}]", x) for i, x in enumerate(np.ravel(zeta))])
        if z.size != m:
            raise ValueError(f"modal_damping must be one ratio or one per elastic coordinate ({m}), got {z.size}")
    if not np.any(z):
        return None
    # M phi = mu K phi (K is positive definite, M may be singular: a rotation without rotary
    # inertia), phi^T K phi = 1, mu = 1/omega^2 descending; with M phi = mu K phi the
    # mass-normalised form is D = sum_i 2 zeta_i sqrt(mu_i) (K phi_i)(K phi_i)^T, and a
    # massless mode (mu = 0) takes no damping
    mu, Phi = sla.eigh(M, K)
    mu, Phi = mu[::-1], Phi[:, ::-1]
    KPhi = K @ Phi
    return (KPhi * (2.0 * z * np.sqrt(np.maximum(mu, 0.0)))) @ KPhi.T


def _assemble(length, n_el, sec: PipeSection):
    """Full body matrices (6 n_nodes square) from the element kernels, the weight
    integral Ng and int N^T ds (6 n_nodes x 3)."""
    n = 6 * (n_el + 1)
    le = length / n_el
    ints = _core.beam_integrals(le)
    ke = _core.beam_stiffness(le, sec.EA, sec.GJ, sec.EI, sec.EIz)
    mu_p, mu_f = sec.pipe_mass, sec.fluid_mass
    Z = lambda: np.zeros((n, n))  # noqa: E731
    M, C, H, K = Z(), Z(), Z(), Z()
    S, G = [Z() for _ in range(3)], [Z() for _ in range(3)]
    N_int = np.zeros((n, 3))  # int N^T ds
    for e in range(n_el):
        s = slice(6 * e, 6 * e + 12)
        M[s, s] += (mu_p + mu_f) * ints["NN"]
        C[s, s] += mu_f * ints["NdN"]
        H[s, s] += mu_f * ints["NddN"]
        K[s, s] += ke
        for k in range(3):
            S[k][s, s] += (mu_p + mu_f) * ints["NSN"][k]
            G[k][s, s] += mu_f * ints["NSdN"][k]
        N_int[s] += ints["N"]
    # section rotary inertia (rho I_p, rho I_y, rho I_z) lumped at the nodes
    J = np.asarray(sec.rotary_inertia, float)
    for i in range(n_el + 1):
        w = le * (0.5 if i in (0, n_el) else 1.0)
        M[6 * i + 3:6 * i + 6, 6 * i + 3:6 * i + 6] += np.diag(w * J)
    return M, C, H, K, S, G, (mu_p + mu_f) * N_int, N_int


#: The nodal coordinates of the element's translation rows N_j (j = x, y, z) among its
#: 12: axial [u_x1, u_x2], u_y [u_y1, theta_z1, u_y2, theta_z2], u_z [u_z1, theta_y1, ...].
_COMPONENT_DOFS = (np.array([0, 6]), np.array([1, 5, 7, 11]), np.array([2, 4, 8, 10]))


def _component_products(ints) -> list:
    """NN_jl = int N_j^T N_l ds (12 x 12) of one element for j, l = x, y, z, taken from its
    integrals: N_j touches only its own coordinates (_COMPONENT_DOFS), so NN_jj is the
    (j, j) block of int N^T N and NN_jl (j != l) the (j, l) block of
    int N^T n~_k N, k the third axis, whose entry there is -eps_jlk."""
    out = [[None] * 3 for _ in range(3)]
    for j in range(3):
        for l in range(3):
            B = np.zeros((12, 12))
            rows, cols = np.ix_(_COMPONENT_DOFS[j], _COMPONENT_DOFS[l])
            if j == l:
                B[rows, cols] = ints["NN"][rows, cols]
            else:
                k = 3 - j - l
                eps = 1.0 if (j, l, k) in ((0, 1, 2), (1, 2, 0), (2, 0, 1)) else -1.0
                B[rows, cols] = -eps * ints["NSN"][k][rows, cols]
            out[j][l] = B
    return out


def _foundation(k, length, n_el, Phi, xbar, eta0) -> dict:
    """The Winkler foundation's constants (ffrf_body.hpp, FfrfFoundation) for k [N/m^2] on
    a body of length [m] and n_el elements (basis Phi, reference node coordinates xbar,
    preimposed eta0), plus the energy's constants xx = k int xbar . xbar ds and
    x0x0 = k int X0 . X0 ds [N m]."""
    n = Phi.shape[0]
    ints = _core.beam_integrals(length / n_el)
    NNe = _component_products(ints)
    z0 = xbar + Phi @ eta0  # the reference centre line's nodal coordinates
    NN = np.zeros((n, n))
    v = np.zeros((3, 3, n))  # NN_jl z0
    N_int = np.zeros((n, 3))
    for e in range(n_el):
        s = slice(6 * e, 6 * e + 12)
        NN[s, s] += ints["NN"]
        N_int[s] += ints["N"]
        for j in range(3):
            for l in range(3):
                v[j, l, s] += NNe[j][l] @ z0[s]
    C = k * np.stack([Phi.T @ v[j, l] for j in range(3) for l in range(3)], axis=1)
    return dict(kL=k * length, X=k * (N_int.T @ xbar), X0=k * (N_int.T @ z0),
                W0=k * np.array([[xbar @ v[j, l] for l in range(3)] for j in range(3)]),
                XPhi=k * (N_int.T @ Phi), K=k * (Phi.T @ NN @ Phi), x=k * (Phi.T @ (NN @ xbar)), C=C,
                xx=k * float(xbar @ NN @ xbar), x0x0=k * float(z0 @ NN @ z0))


def _slope_integrals(length, n_el):
    """(G0, G1) (6 n_nodes square) over the body: int (u_y'^2 + u_z'^2) ds [1/m] and the same
    weighted by s [-] (s from the centre node), the geometric stiffness of an axial force
    N(s) = N0 + N1 s being N0 G0 + N1 G1 (the fluid acceleration's, ffrf_body.hpp)."""
    n = 6 * (n_el + 1)
    le = length / n_el
    g0, g1 = _core.beam_slope_integrals(le)
    G0, G1 = np.zeros((n, n)), np.zeros((n, n))
    for e in range(n_el):
        s = slice(6 * e, 6 * e + 12)
        G0[s, s] += g0
        G1[s, s] += g1 + (-0.5 * length + e * le) * g0  # g1's s starts at the element's start node
    return G0, G1


def _end_slopes(Phi, node):
    """The bending slopes (0, u_y', u_z') (3 x m) per elastic coordinate at the end node
    whose rows start at ``node``: its rotations (u_y' = theta_z, u_z' = -theta_y, the
    kernel's convention). No axial entry: the linear axial shape has no u'' in the flow
    integrals (int N^T N''), whose end terms these slopes give."""
    return np.vstack([np.zeros(Phi.shape[1]), Phi[node + 5], -Phi[node + 4]])


def _craig_bampton(K, M, n_el, internal_modes):
    n = K.shape[0]
    c = n_el // 2
    bdofs = np.r_[0:6, 6 * n_el:6 * n_el + 6]
    fixed = np.r_[6 * c:6 * c + 6]
    idofs = np.setdiff1d(np.arange(n), np.r_[bdofs, fixed])
    Phi = np.zeros((n, 12 + internal_modes))
    Phi[bdofs, np.arange(12)] = 1.0
    if len(idofs):
        Kii = K[np.ix_(idofs, idofs)]
        Phi[np.ix_(idofs, np.arange(12))] = -np.linalg.solve(Kii, K[np.ix_(idofs, bdofs)])
        if internal_modes:
            if internal_modes > len(idofs):
                raise ValueError(f"internal_modes must be <= {len(idofs)} (interior coordinates), got {internal_modes}")
            # eig(M, K): the largest 1/omega^2 first; works with massless (torsion) coordinates
            mu, V = sla.eigh(M[np.ix_(idofs, idofs)], Kii)
            order = np.argsort(mu)[::-1]
            V = canonical_modes(mu[order], V[:, order], internal_modes)
            Phi[np.ix_(idofs, 12 + np.arange(internal_modes))] = V / np.abs(V).max(axis=0)
    elif internal_modes:
        raise ValueError("internal_modes must be 0: the body has no interior nodes")
    return Phi


#: Eigenvalues mu_a, mu_b of the fixed-interface problem belong to one degenerate group
#: when |mu_a - mu_b| <= DEGENERATE_RTOL max(|mu_a|, |mu_b|) (+ 1e-12 max |mu|): equal
#: up to round-off, as the two bending planes of a section with EI = EIz.
DEGENERATE_RTOL = 1e-8


def canonical_modes(mu: np.ndarray, V: np.ndarray, count: int) -> np.ndarray:
    """The first ``count`` modes of V (columns, eigenvalues ``mu`` sorted), every group
    of equal eigenvalues among them (a group cut by ``count`` in full) replaced by a
    basis that depends on the group's subspace only.

    Within a degenerate group any orthogonal combination of the vectors is an
    eigenbasis, and which one LAPACK returns depends on round-off (e.g. the number of
    BLAS threads): a Craig-Bampton basis cut inside such a group, and the signs and
    mixtures of all of them, would change from run to run. The canonical basis is built
    greedily: the coordinate with the largest share in what is left of the group (ties
    within 1e-8 to the lowest index) gets the combination that maximises it, with a
    positive sign; that direction is removed and the next one chosen. Combinations of
    the (B-orthonormal) vectors stay B-orthonormal. A single mode gets a positive
    largest coordinate."""
    V = np.array(V, dtype=float, copy=True)
    scale = float(np.abs(mu).max(initial=0.0))
    start = 0
    while start < count:
        stop = start + 1
        while stop < len(mu) and abs(mu[stop] - mu[start]) <= (
                DEGENERATE_RTOL * max(abs(mu[stop]), abs(mu[start])) + 1e-12 * scale):
            stop += 1
        W = V[:, start:stop].copy()  # V is overwritten column by column below
        Q = np.eye(stop - start)  # projector onto the group's remaining coefficients
        for j in range(stop - start):
            R = W @ Q
            norms = np.linalg.norm(R, axis=1)
            i = int(np.flatnonzero(norms >= (1.0 - 1e-8) * norms.max())[0])
            c = R[i] / norms[i]
            V[:, start + j] = W @ c
            Q -= np.outer(c, c)
        start = stop
    return V[:, :count]


def check_no_rigid_motion(Psi0: np.ndarray, Phi: np.ndarray, K: np.ndarray) -> None:
    """Raise ValueError if span(Phi) contains rigid motion (a combination without strain
    energy) or if [Psi0 Phi] is rank deficient: the frame and the elastic coordinates
    would then describe the same motion."""
    Kr = Phi.T @ K @ Phi
    # strain energy per unit of a diagonal (always positive) norm of the displacement
    W = Phi.T @ (np.abs(np.diag(K))[:, None] * Phi)
    try:
        w = sla.eigvalsh(0.5 * (Kr + Kr.T), 0.5 * (W + W.T))
    except np.linalg.LinAlgError:
        raise ValueError("the reduction basis has linearly dependent columns") from None
    if w.min() <= 1e-11 * w.max():
        raise ValueError("the reduction basis contains rigid-body motion (a mode without strain energy): "
                         "fix a node (e.g. the centre) when computing the modes")
    B = np.hstack([Psi0 / np.abs(Psi0).max(axis=0), Phi / np.abs(Phi).max(axis=0)])
    sv = np.linalg.svd(B, compute_uv=False)
    if sv[-1] <= 1e-10 * sv[0]:
        raise ValueError("the reduction basis and the rigid-body modes are linearly dependent")


def flexible_body(*, length: float, n_elements: int, section: PipeSection, internal_modes: int = 0,
                  reduction: str = "craig_bampton", curvature: float = 0.0,
                  basis: Optional[np.ndarray] = None, modal_damping=0.0,
                  fluid_lever_arm: str = "deformed") -> FlexibleBody:
    """Build a reduced straight (or preimposed-curved) body.

    Args:
        length: L [m] > 0 (for a curved body the arc length).
        n_elements: number of elements, even (the frame sits at the centre node).
        section: :class:`~pipeflex.PipeSection`; ``fluid_mass`` > 0 for a pipe that carries flow.
            Not supported yet (refused by name): ``kv`` != 1, shear flexibility ``GAy``, ``GAz``.
            ``k_found`` [N/m^2] > 0 puts the body on a Winkler foundation: the force
            -k_found (r(s) - r_ref(s)) per length on its centre line, r_ref(s) the centre
            line where :class:`MultibodyBuilder` places the body (with the preimposed shape
            eta0), consistent through the element shape functions in every coordinate
            (frame and elastic), with an exact tangent; it holds a free body on its own.
        internal_modes: fixed-interface modes added to the 12 boundary modes (Craig-Bampton),
            lowest frequencies first; modes of equal frequency (the two bending planes
            of a round section) get a canonical basis (:func:`canonical_modes`), so the
            body is the same whatever the round-off of the eigensolver, e.g. its number of
            BLAS threads, also when the count cuts such a group.
        reduction: ``"craig_bampton"`` (default) or ``"full"`` (all nodal coordinates but the
            centre node's: the unreduced body, as a check).
        curvature: kappa [1/m] of a preimposed circular arc in the body's x-y plane (turning
            towards +y): the straight body is deformed onto the arc, and that shape is made
            stress-free by the stiffness compensation K (eta - eta0).
        basis: a custom Phi (6 (n_elements + 1) x m) in place of ``reduction``; it must not
            contain rigid-body motion.
        modal_damping: zeta [-] damping ratios of the body's elastic modes: one number for
            all, or one per elastic coordinate (m, lowest frequency first); each >= 0. The
            modes are those of the elastic coordinates with the floating frame held,
            K_eta phi = omega^2 M_eta phi (M_eta the elastic block of the body's mass
            matrix, phi mass-normalised), and the damping force on the elastic equations is
            D eta_dot, D = M_eta Phi diag(2 zeta omega) Phi^T M_eta (default 0: none). A
            massless mode (a rotation without rotary inertia) has no dynamics and takes no
            damping (its ratio is ignored). The section's own damping coefficients are
            refused: a body is damped by this argument.
        fluid_lever_arm: the lever arm of the flow's Coriolis and centrifugal forces about
            the body's frame: ``"deformed"`` (default: the deformed centre line, so that the
            flow does no work inside a bent chain of bodies, docs/theory.md) or
            ``"reference"`` (the undeformed s e_x, van Voorthuizen et al.'s form: their scenes use
            it to reproduce the published figures; a loaded chain can then report a
            spurious weakly growing mode).
    """
    L = _checks.magnitude("length", length, "m")
    n_el = _checks.positive_int("n_elements", n_elements)
    if fluid_lever_arm not in ("deformed", "reference"):
        raise ValueError(f"fluid_lever_arm must be 'deformed' or 'reference', got {fluid_lever_arm!r}")
    if n_el > MAX_BODY_ELEMENTS:
        raise ValueError(f"n_elements must be at most {MAX_BODY_ELEMENTS} per floating-frame body (its matrices "
                         f"are dense, 6 (n_elements + 1) square), got {n_el}")
    if n_el % 2:
        raise ValueError(f"n_elements must be even (the floating frame sits at the centre node), got {n_el}")
    section = require_section(section)
    refuse_unsupported(section, {
        "kv": "the FFRF body does not support a momentum-flux factor kv != 1 yet (its fluid forces are plug flow's)",
        "GAy": "the FFRF body does not support shear flexibility yet (Euler-Bernoulli elements)",
        "GAz": "the FFRF body does not support shear flexibility yet (Euler-Bernoulli elements)",
        **{name: "the FFRF body is damped by its modes' ratios (flexible_body(..., modal_damping=zeta)), not by "
                 "the section's coefficients" for name in ("eta_bending", "eta_torsion", "eta_axial", "c_ext")}},
        "flexible_body")
    internal_modes = _checks.non_negative_int("internal_modes", internal_modes)
    kappa = _checks.finite("curvature", curvature)
    if abs(kappa) * L >= np.pi:
        raise ValueError(f"curvature * length must be < pi (a body turns by less than 180 degrees), got {kappa * L}")
    s = np.linspace(-L / 2, L / 2, n_el + 1)
    M, C, H, K, S, G, Ng, N_int = _assemble(L, n_el, section)
    n = 6 * (n_el + 1)
    xbar = np.zeros(n)
    xbar[0::6] = s
    Psi0 = np.zeros((n, 6))
    for i in range(n_el + 1):
        Psi0[6 * i:6 * i + 3, 0:3] = np.eye(3)
        Psi0[6 * i:6 * i + 3, 3:6] = skew(np.array([s[i], 0.0, 0.0])).T
        Psi0[6 * i + 3:6 * i + 6, 3:6] = np.eye(3)
    if basis is not None:
        Phi = np.array(basis, dtype=float)  # a copy: the body freezes its arrays
        if Phi.ndim != 2 or Phi.shape[0] != n or Phi.shape[1] < 1 or not np.all(np.isfinite(Phi)):
            raise ValueError(f"basis must be a finite {n} x m array with m >= 1 (6 coordinates per node), "
                             f"got shape {Phi.shape}")
        reduction = "custom"
    elif reduction == "craig_bampton":
        Phi = _craig_bampton(K, M, n_el, internal_modes)
    elif reduction == "full":
        if internal_modes:
            raise ValueError("internal_modes applies to reduction='craig_bampton' only")
        c = n_el // 2
        keep = np.setdiff1d(np.arange(n), np.r_[6 * c:6 * c + 6])
        Phi = np.eye(n)[:, keep]
    else:
        raise ValueError(f"reduction must be one of {REDUCTIONS}, got {reduction!r}")
    check_no_rigid_motion(Psi0, Phi, K)

    # preimposed arc: exact nodal displacements and rotations, projected in the K-norm
    Kr = Phi.T @ K @ Phi
    if kappa != 0.0:
        phi = kappa * s
        u0 = np.zeros(n)
        u0[0::6] = np.sin(phi) / kappa - s
        u0[1::6] = (1.0 - np.cos(phi)) / kappa
        u0[5::6] = phi
        eta0 = np.linalg.solve(Kr, Phi.T @ K @ u0)
    else:
        eta0 = np.zeros(Phi.shape[1])

    B = np.hstack([Psi0, Phi])
    Psi_r0 = Psi0[:, 3:]
    G0, G1 = _slope_integrals(L, n_el)
    Mr = B.T @ M @ B
    data = _core.FfrfBodyData(
        M=Mr, K=Kr, eta0=eta0, D=_modal_damping_matrix(modal_damping, Kr, Mr[6:, 6:]),
        A=[B.T @ S[k] @ Psi_r0 for k in range(3)], Bk=[B.T @ S[k] @ Phi for k in range(3)],
        GPhi=[B.T @ G[k] @ Phi for k in range(3)], Gx=[B.T @ G[k] @ xbar for k in range(3)],
        CPhi=B.T @ C @ Phi, HPhi=B.T @ H @ Phi, Cx=B.T @ C @ xbar, Hx=B.T @ H @ xbar, Ng=B.T @ Ng,
        # the fluid acceleration's axial force's geometric stiffness (the rate's; docs/parametric.md)
        Gs0=Phi.T @ G0 @ Phi, Gs1=Phi.T @ G1 @ Phi, Ua=section.fluid_mass * (N_int.T @ Phi),
        mu_f=section.fluid_mass,
        # the Coriolis forces' moment on the deformed lever arm N Phi eta (cpp/include/pipeflex/elements/ffrf_body.hpp)
        **(dict(Ubar=section.fluid_mass * (N_int.T @ Phi), Us=Phi[0:3],
                Ue=Phi[6 * n_el:6 * n_el + 3], dUs=_end_slopes(Phi, 0), dUe=_end_slopes(Phi, 6 * n_el))
           if fluid_lever_arm == "deformed" else {}))
    foundation = None if section.k_found == 0.0 else _foundation(section.k_found, L, n_el, Phi, xbar, eta0)
    mass = L * (section.pipe_mass + section.fluid_mass)
    arguments = dict(length=L, n_elements=n_el, section=section, internal_modes=internal_modes,
                     reduction=reduction, curvature=kappa, basis=None if basis is None else Phi,
                     modal_damping=modal_damping, fluid_lever_arm=fluid_lever_arm)
    return FlexibleBody(L, n_el, section, reduction, internal_modes if reduction == "craig_bampton" else 0,
                        s, Phi, eta0, data, mass, arguments, foundation=foundation)
