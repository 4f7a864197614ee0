"""Steady rotation about a hinge: the relative equilibrium of a spinning structure.

The motion sought is a rigid rotation at constant rate omega about the hinge axis a
through the hinge point x_h, carrying a fixed deformation: node i moves with
    x_dot = omega a x (x - x_h),  x_ddot = omega^2 a x (a x (x - x_h)),
and turns with spatial angular velocity omega a. Unknowns: the reduced coordinates,
except the hinge angle (arbitrary), and omega; equations: R(q, v, a) = 0, whose hinge
row is the balance of moments about the axis. Newton's method with the analytic
Jacobian K + C dv/dq + M da/dq (and the omega column C dv/domega + M da/domega), with
continuation in the mass flow from rest.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .. import _checks, _core
from ..errors import ConvergenceError, SingularMatrixError
from ..results import Result
from ..state import State, as_core
from ._newton import converged
from ._assembly import KCM, require_model, residual_and_tangent, tangents
from ..rotation import skew
from .._blas import small_problems_single_threaded


# below this many coordinates the Newton systems are solved densely (cheaper than sparse
# bookkeeping); above, sparsely (linear in the model size)
DENSE_BELOW = 300


@dataclass(frozen=True)
class SteadyRotation(Result):
    """Steady rotation found by :func:`steady_rotation`.

    Attributes:
        omega: angular velocity [rad/s] about the hinge axis (right-hand rule).
        state: the deformed, rotating state (:class:`~pipeflex.state.State`: positions,
            rotation vectors, velocities, accelerations of the rigid rotation).
        axis: (3,) unit hinge axis [-]; hinge_node: its node.
        iterations: Newton iterations; residual: final residual norm [N].
    """

    omega: float
    state: State
    axis: np.ndarray
    hinge_node: int
    iterations: int
    residual: float


def _hinge(model):
    """The node with one free rotation and fixed position (the hinge), and its axis."""
    found = []
    for n in range(model.n_nodes):
        dofs = model.node_dofs(n)
        T = model.basis[6 * n:6 * n + 6][:, dofs].toarray() if len(dofs) else np.zeros((6, 0))
        if T.shape[1] == 1 and np.allclose(T[:3, 0], 0.0):
            found.append((n, T[3:, 0] / np.linalg.norm(T[3:, 0]), dofs[0]))
    if len(found) != 1:
        raise ValueError(f"steady_rotation needs exactly one hinge (a node with fixed position and one "
                         f"free rotation); this model has {len(found)}")
    return found[0]


def _rigid_rotation(model, state, node, axis, omega):
    """Set the velocities and accelerations of a rigid rotation at rate omega (phi = 0)."""
    S = skew(axis)
    xh = state.q[6 * node:6 * node + 3].copy()
    v = np.zeros(6 * model.n_nodes)
    a = np.zeros(6 * model.n_nodes)
    for i in range(model.n_nodes):
        r = state.q[6 * i:6 * i + 3] - xh
        v[6 * i:6 * i + 3] = omega * S @ r
        v[6 * i + 3:6 * i + 6] = omega * axis
        a[6 * i:6 * i + 3] = omega**2 * S @ S @ r
    state.v = v
    state.a = a
    return xh


def _rate_operators(model, axis):
    """Full-coordinate dv/dq / omega and da/dq / omega^2 at phi = 0 (the same 6 x 6 block
    on every node, sparse: the Jacobian stays banded and linear in the model size)."""
    S = skew(axis)
    S2 = S @ S
    Bv = np.zeros((6, 6))
    Ba = np.zeros((6, 6))
    Bv[:3, :3] = S
    Bv[3:, 3:] = 0.5 * S            # phi_dot = T(phi)^-1 omega a, T^-1 = I - skew(phi)/2 + ...
    Ba[:3, :3] = S2
    Ba[3:, 3:] = S2 / 6.0           # phi_ddot = -T^-1 d/dt[T] phi_dot to first order in phi
    eye = sp.identity(model.n_nodes, format="csr")
    return sp.kron(eye, sp.csr_matrix(Bv), format="csr"), sp.kron(eye, sp.csr_matrix(Ba), format="csr")


def _rate_columns(model, state, axis, xh, omega):
    """dv/domega and da/domega (full coordinates) at phi = 0."""
    S = skew(axis)
    x = np.asarray(state.q).reshape(-1, 6)[:, :3] - xh
    dv = np.zeros((model.n_nodes, 6))
    da = np.zeros((model.n_nodes, 6))
    dv[:, :3] = x @ S.T
    dv[:, 3:] = axis
    da[:, :3] = 2 * omega * x @ (S @ S).T
    return dv.ravel(), da.ravel()


@small_problems_single_threaded
def steady_rotation(model, *, omega_guess: Optional[float] = None, mass_flow: Optional[float] = None,
                    state=None, continuation_steps: int = 4, tol: float = 1e-12,
                    max_iterations: int = 30) -> SteadyRotation:
    """Steady rotation of a model about its single hinge under the prescribed mass flow.

    Args:
        model: a model with exactly one hinge (e.g. :func:`pipeflex.scenes.sprinkler`).
        omega_guess: starting angular velocity [rad/s] (default: from a rigid-body balance
            of the undeformed structure at the first continuation step).
        mass_flow: mdot [kg/s] (default the model's).
        state: starting deformation (default the reference configuration).
        continuation_steps: the flow is raised from mdot/steps to mdot in this many steps.
        tol: relative tolerance on the Newton correction (to the model size and to omega);
            a correction within 1e3 tolerances that stops halving is taken as converged
            (round-off; ``pipeflex.analysis._newton.converged``).
        max_iterations: Newton iterations per continuation step.

    Raises:
        ValueError: no or several hinges; bad options.
        ConvergenceError: Newton failed (the message gives the step and the residual;
            attributes ``mass_flow`` of the continuation step, ``iteration``, ``residual``).
    """
    require_model(model)
    node, axis, hinge_dof = _hinge(model)
    steps = _checks.positive_int("continuation_steps", continuation_steps)
    tol = _checks.positive("tol", tol)
    max_iterations = _checks.positive_int("max_iterations", max_iterations)
    mdot = model.mass_flow if mass_flow is None else _checks.finite("mass_flow", mass_flow)
    st = as_core(model, state)
    size = max(float(np.ptp(model.positions, axis=0).max()), 1e-3)
    T = sp.csc_matrix(model.basis)
    Dv1, Da1 = _rate_operators(model, axis)
    Av, Aa = (T.T @ Dv1 @ T).tocsc(), (T.T @ Da1 @ T).tocsc()  # reduced dv/dq / omega, da/dq / omega^2
    dense = model.n_dofs < DENSE_BELOW
    if dense:
        Av, Aa = Av.toarray(), Aa.toarray()
    keep = np.arange(model.n_dofs) != hinge_dof
    omega = None if omega_guess is None else _checks.finite("omega_guess", omega_guess)
    total = 0
    rnorm = np.inf
    for k in range(1, steps + 1):
        m_k = mdot * k / steps
        load = model.load_state(mass_flow=m_k)
        if omega is None:
            omega = _rigid_guess(model, st, node, axis, hinge_dof, load)
        elif k > 1:
            omega *= k / (k - 1)  # omega scales with the flow speed
        ok = False
        last = np.inf
        for it in range(1, max_iterations + 1):
            total += 1
            st.rebase(0.0)
            xh = _rigid_rotation(model, st, node, axis, omega)
            r, (K, Cm, Mm) = tangents(model, st, load, KCM, residual=True)
            rnorm = float(np.linalg.norm(r))
            dv, da = _rate_columns(model, st, axis, xh, omega)
            # the hinge angle is arbitrary: its column carries omega's derivative instead
            column = Cm @ (T.T @ dv) + Mm @ (T.T @ da)
            try:
                if dense:
                    Cd, Md = Cm.toarray(), Mm.toarray()
                    J = K.toarray() + omega * (Cd @ Av) + omega**2 * (Md @ Aa)
                    J[:, hinge_dof] = column
                    dz = np.linalg.solve(J, -r)
                else:
                    J = (K + omega * (Cm @ Av) + omega**2 * (Mm @ Aa)).tocsc()[:, keep]
                    J = sp.hstack([J[:, :hinge_dof], sp.csc_matrix(column.reshape(-1, 1)), J[:, hinge_dof:]],
                                  format="csc")
                    dz = spla.splu(J).solve(-r)
            except (np.linalg.LinAlgError, RuntimeError):
                raise SingularMatrixError(f"steady_rotation: singular Jacobian at flow step {k}/{steps}, "
                                          f"iteration {it} (omega = {omega:.6g} rad/s)", iteration=it,
                                          residual=rnorm, mass_flow=m_k) from None
            domega = dz[hinge_dof]
            dz[hinge_dof] = 0.0
            # damp large steps (the first iterations from the undeformed shape)
            scale = min(1.0, 0.2 * size / max(np.abs(dz).max(), 1e-300), 0.5 * max(abs(omega), 1.0) / max(abs(domega), 1e-300))
            _core.add_increment(model.core, st, scale * dz, "q")
            omega += scale * domega
            error = max(np.abs(dz).max() / size, abs(domega) / max(abs(omega), 1.0))
            # converged, or stalled at round-off (fine meshes of stiff arms: omega's last
            # digits wander), the static solvers' rule
            if scale == 1.0 and converged(error, last, tol):
                ok = True
                break
            last = error if scale == 1.0 else np.inf
        if not ok:
            raise ConvergenceError(f"steady_rotation: no convergence at flow step {k}/{steps} "
                                   f"(mdot = {m_k:.6g} kg/s) after {max_iterations} iterations; "
                                   f"residual {rnorm:.3e} N, omega = {omega:.6g} rad/s", iteration=max_iterations,
                                   residual=rnorm, mass_flow=m_k)
    st.rebase(0.0)
    _rigid_rotation(model, st, node, axis, omega)
    r, _ = residual_and_tangent(model, st, model.load_state(mass_flow=mdot), matrix=False)
    return SteadyRotation(float(omega), State.from_core(st, model), axis, node, total, float(np.linalg.norm(r)))


def _rigid_guess(model, st, node, axis, hinge_dof, load):
    """omega balancing the hinge moment of the undeformed structure (secant iterations)."""
    def moment(w):
        s = st.copy()
        s.rebase(0.0)
        _rigid_rotation(model, s, node, axis, w)
        r, _ = residual_and_tangent(model, s, load, matrix=False)
        return r[hinge_dof]

    w0, w1 = 0.0, 1.0
    f0, f1 = moment(w0), moment(w1)
    for _ in range(50):
        if f1 == f0:
            break
        w0, w1, f0 = w1, w1 - f1 * (w1 - w0) / (f1 - f0), f1
        f1 = moment(w1)
        if abs(w1 - w0) <= 1e-10 * max(1.0, abs(w1)):
            break
    return w1
