"""Static, linearised and transient analyses of a :class:`MultibodySystem`.

Time integration: the index-3 equations (positions constrained exactly) with the Lie
group generalised-alpha method of Arnold & Bruls (2007) / Bruls, Cardona & Arnold (2012):
rotations are updated as R <- exp(h Dq~) R, so there is no rotation singularity and no
extra normalisation constraint. Index 3 rather than an index-1 form (the seed's eq. 70)
because the position constraints then hold to the Newton tolerance at every step with
no drift stabilisation; the velocity-level drift (C_q v, not enforced) is reported.
Constraint rows are scaled by beta' = (1 - alpha_m) / ((1 - alpha_f) beta h^2) so that
the iteration matrix is balanced.
"""
from __future__ import annotations

import time as _time
from dataclasses import dataclass, field
from typing import Callable, Optional, Sequence, Union

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from .. import _checks
from ..errors import ConvergenceError
from .system import MultibodyState, MultibodySystem, TimeFunction, time_value


@dataclass
class MultibodyStatic:
    """Converged static state: ``state`` (with the reactions in ``state.lam``),
    ``iterations``, ``residual`` [N], ``mass_flow`` [kg/s]."""

    state: MultibodyState
    iterations: int
    residual: float
    mass_flow: float


def _kkt_solve(S, J, rhs_f, rhs_c, scale):
    n = S.shape[0]
    A = np.block([[S, scale * J.T], [scale * J, np.zeros((J.shape[0], J.shape[0]))]])
    try:
        lu = sla.lu_factor(A, check_finite=True)
    except (np.linalg.LinAlgError, ValueError) as e:
        raise ConvergenceError(f"singular or non-finite iteration matrix ({e})") from None
    if np.min(np.abs(np.diag(lu[0]))) <= 1e-14 * np.abs(np.diag(lu[0])).max():
        raise ConvergenceError("singular iteration matrix: a coordinate is neither constrained nor stiff "
                               "(an unsupported mechanism?)")
    x = sla.lu_solve(lu, np.concatenate([rhs_f, scale * rhs_c]))
    return x[:n], x[n:] * scale, lu


def static_equilibrium(system: MultibodySystem, *, state: Optional[MultibodyState] = None,
                       mass_flow: Optional[float] = None, t: float = 0.0, load_steps: int = 1,
                       tol: float = 1e-10, max_iterations: int = 30) -> MultibodyStatic:
    """Static equilibrium (at rest) under the loads at time ``t``, gravity and the flow.

    Loads and gravity are applied in ``load_steps`` increments; Newton's method on the
    coordinates and the Lagrange multipliers.

    Raises:
        ConvergenceError: with the load factor, iteration and residual where it failed.
    """
    steps = _checks.positive_int("load_steps", load_steps)
    tol = _checks.positive("tol", tol)
    mdot = system.mass_flow if mass_flow is None else _checks.finite("mass_flow", mass_flow)
    st = system.initial_state() if state is None else state.copy()
    st.v[:] = 0.0
    st.a[:] = 0.0
    L = system.length_scale
    total = 0
    fscale = 1.0
    for k in range(1, steps + 1):
        lf = k / steps
        for it in range(max_iterations):
            F, T = system.body_forces(st, mass_flow=mdot, gravity_factor=lf)
            F -= system.external_forces(st, t, lf)
            c, J = system.constraints(st)
            F += J.T @ st.lam
            fscale = max(fscale, np.abs(F).max(), np.abs(J.T @ st.lam).max())
            S = T + system.constraint_stiffness(st, st.lam)
            dq, dlam, _ = _kkt_solve(S, J, -F, -c, np.abs(S).max())
            system.increment(st, dq)
            st.lam += dlam
            total += 1
            if not np.all(np.isfinite(dq)):
                raise ConvergenceError(f"static solve: non-finite increment at load factor {lf:.3g}, iteration {it}")
            if np.abs(dq).max() <= tol * L and np.abs(c).max() <= 1e-6 * L:
                break
        else:
            raise ConvergenceError(f"static solve did not converge at load factor {lf:.3g} after {max_iterations} "
                                   f"iterations (last increment {np.abs(dq).max():.3g}, constraint violation "
                                   f"{np.abs(c).max():.3g} m)")
    F, _ = system.body_forces(st, mass_flow=mdot, tangent=False)
    c, J = system.constraints(st)
    res = float(np.abs(F - system.external_forces(st, t) + J.T @ st.lam).max())
    st.t = t
    return MultibodyStatic(st, total, res, mdot)


@dataclass(frozen=True)
class MultibodyLinearization:
    """M, C, K (CSC) in independent coordinates z (q = q0 (+) T z, C_q T = 0), the basis
    T (N x n_dofs) and the state. Same use as :class:`pipeflex.Linearization`."""

    M: sp.csc_matrix
    C: sp.csc_matrix
    K: sp.csc_matrix
    mass_flow: float
    state: MultibodyState
    basis: np.ndarray


def null_space_basis(J: np.ndarray) -> np.ndarray:
    """Orthonormal basis of the null space of the constraint Jacobian."""
    if J.shape[0] == 0:
        return np.eye(J.shape[1])
    return sla.null_space(J, rcond=1e-10)


def linearize(system: MultibodySystem, state: Optional[MultibodyState] = None, *,
              mass_flow: Optional[float] = None) -> MultibodyLinearization:
    """Linearise about ``state`` (default: the assembly configuration at rest), keeping its
    multipliers: K includes the joint reactions' geometric stiffness d(C_q^T lambda)/dq."""
    st = system.initial_state() if state is None else state
    mdot = system.mass_flow if mass_flow is None else _checks.finite("mass_flow", mass_flow)
    _, K = system.body_forces(st, mass_flow=mdot, wK=1.0)
    _, C = system.body_forces(st, mass_flow=mdot, wK=0.0, wC=1.0)
    _, M = system.body_forces(st, mass_flow=mdot, wK=0.0, wM=1.0)
    K = K + system.constraint_stiffness(st, st.lam)
    _, J = system.constraints(st)
    Tb = null_space_basis(J)
    red = lambda X: sp.csc_matrix(Tb.T @ X @ Tb)  # noqa: E731
    return MultibodyLinearization(red(M), red(C), red(K), mdot, st, Tb)


@dataclass
class MultibodyResult:
    """A multibody transient.

    Attributes:
        t: (n_out,) output times [s]; r: (n_out, n_bodies, 3), R: (n_out, n_bodies, 3, 3)
        frames; eta: (n_out, N) elastic coordinates (frame entries zero); v: (n_out, N)
        velocities; drift: (n_out,) max |C_q v| [m/s] (velocity-level constraint drift;
        positions are enforced); stats: steps, Newton iterations, matrix factorisations,
        wall time [s].
    """

    system: MultibodySystem
    t: np.ndarray
    r: np.ndarray
    R: np.ndarray
    eta: np.ndarray
    v: np.ndarray
    drift: np.ndarray
    stats: dict = field(default_factory=dict)

    def state(self, k: int) -> MultibodyState:
        z = np.zeros(0)
        return MultibodyState(self.r[k].copy(), self.R[k].copy(), self.eta[k].copy(), self.v[k].copy(),
                              np.zeros_like(self.v[k]), z, float(self.t[k]))

    def node_position(self, body: int, node) -> np.ndarray:
        """(n_out, 3) global position [m] of a node."""
        i = self.system.bodies[body].node_index(node)
        return np.array([self.system.node_kinematics(self.state(k), body, i)[0] for k in range(len(self.t))])

    def angular_velocity(self, body: int) -> np.ndarray:
        """(n_out, 3) global angular velocity [rad/s] of a body's frame."""
        o = self.system.offsets[body]
        return self.v[:, o + 3:o + 6]

    def node_angular_velocity(self, body: int, node) -> np.ndarray:
        """(n_out, 3) global angular velocity [rad/s] of a node: omega + R Phi_theta eta_dot
        (small nodal rotations)."""
        b = self.system.bodies[body]
        _, Pt, _ = b.node_rows(node)
        sl = self.system.body_slice(body)
        ed = self.v[:, sl][:, 6:]
        return self.angular_velocity(body) + np.einsum("kij,kj->ki", self.R[:, body], ed @ Pt.T)


def alpha_parameters(rho_inf: float):
    """(alpha_m, alpha_f, beta, gamma) of generalised-alpha (Chung & Hulbert) for the
    spectral radius at infinity rho_inf in [0, 1]."""
    am = (2 * rho_inf - 1) / (rho_inf + 1)
    af = rho_inf / (rho_inf + 1)
    gamma = 0.5 + af - am
    beta = 0.25 * (gamma + 0.5) ** 2
    return am, af, beta, gamma


def simulate(system: MultibodySystem, t_end: float, *, step: float, state: Optional[MultibodyState] = None,
             mass_flow: Optional[Union[float, Callable[[float], float]]] = None,
             mass_flow_rate: Optional[Callable[[float], float]] = None, n_outputs: int = 201,
             rho_inf: float = 0.9, tol: float = 1e-7, max_iterations: int = 12,
             refresh: int = 3) -> MultibodyResult:
    """Integrate the constrained equations of motion from ``state`` (default: the
    assembly configuration at rest) to ``t_end`` [s] with fixed ``step`` h [s].

    Args:
        mass_flow: mdot [kg/s], a number or a function of t (default the system's).
        mass_flow_rate: d(mdot)/dt [kg/s^2] as a function of t (default: 0, or a central
            difference of a mass_flow function).
        n_outputs: output times, evenly spaced over [t0, t_end] (rounded to steps).
        rho_inf: spectral radius at infinite frequency (numerical damping; 1 = none).
        tol: Newton tolerance on the increment, relative to the largest body length
            (an iteration that stalls within 100 tol at round-off level is accepted).
        refresh: re-evaluate the iteration matrix when a step needs more Newton
            iterations than this (modified Newton).

    Raises:
        ConvergenceError: with the time, iteration and residual where Newton failed.
    """
    t_end = _checks.finite("t_end", t_end)
    h = _checks.positive("step", step)
    n_out = _checks.positive_int("n_outputs", n_outputs)
    rho = _checks.non_negative("rho_inf", rho_inf)
    if rho > 1:
        raise ValueError(f"rho_inf must be in [0, 1], got {rho}")
    st = system.initial_state() if state is None else state.copy()
    if st.lam is None or len(st.lam) != system.n_constraints:
        st.lam = np.zeros(system.n_constraints)
    t0 = st.t
    if t_end <= t0:
        raise ValueError(f"t_end = {t_end} must be after the start time {t0}")
    mf = system.mass_flow if mass_flow is None else mass_flow
    if callable(mf):
        mdot = mf
        mrate = mass_flow_rate or (lambda t: (mf(t + 1e-6) - mf(t - 1e-6)) / 2e-6)
    else:
        c_ = _checks.finite("mass_flow", mf)
        mdot = lambda t: c_  # noqa: E731
        mrate = mass_flow_rate or (lambda t: 0.0)
    am, af, beta, gamma = alpha_parameters(rho)
    n_steps = max(1, int(np.ceil((t_end - t0) / h - 1e-9)))
    h = (t_end - t0) / n_steps
    out_steps = np.unique(np.round(np.linspace(0, n_steps, n_out)).astype(int))
    bp = (1 - am) / ((1 - af) * beta * h * h)
    gp = gamma / (beta * h)
    L = system.length_scale
    N = system.n_coordinates

    def residual(s, t, tangent):
        F, T = system.body_forces(s, mass_flow=mdot(t), mass_flow_rate=mrate(t), wK=1.0, wC=gp, wM=bp,
                                  tangent=tangent)
        F -= system.external_forces(s, t)
        c, J = system.constraints(s)
        return F + J.T @ s.lam, c, J, T

    # consistent initial acceleration (least squares: massless coordinates allowed)
    F, c, J, _ = residual(st, t0, False)
    _, M = system.body_forces(st, mass_flow=mdot(t0), wK=0.0, wM=1.0)
    A = np.block([[M, J.T], [J, np.zeros((J.shape[0], J.shape[0]))]])
    sol = np.linalg.lstsq(A, np.concatenate([-(F - J.T @ st.lam), np.zeros(J.shape[0])]), rcond=1e-12)[0]
    st.a = sol[:N].copy()
    st.lam = sol[N:].copy()
    acc = st.a.copy()  # algorithmic acceleration
    record = {"t": [], "r": [], "R": [], "eta": [], "v": [], "drift": []}

    def save(s, t):
        record["t"].append(t)
        record["r"].append(s.r.copy())
        record["R"].append(s.R.copy())
        record["eta"].append(s.eta.copy())
        record["v"].append(s.v.copy())
        record["drift"].append(float(np.abs(system.constraints(s)[1] @ s.v).max(initial=0.0)))

    save(st, t0)
    lu = None
    stats = dict(steps=0, iterations=0, factorizations=0)
    wall = _time.perf_counter()
    for n in range(1, n_steps + 1):
        t = t0 + n * h
        vd_n, acc_n, v_n = st.a.copy(), acc.copy(), st.v.copy()
        acc_new = (af * vd_n - am * acc_n) / (1 - am)
        dq = h * v_n + h * h * ((0.5 - beta) * acc_n + beta * acc_new)
        st.v = v_n + h * ((1 - gamma) * acc_n + gamma * acc_new)
        st.a = np.zeros(N)
        system.increment(st, dq)
        converged = False
        last = np.inf
        for it in range(max_iterations):
            need = lu is None or (it >= refresh)
            F, c, J, T = residual(st, t, need)
            if need:
                S = T + system.constraint_stiffness(st, st.lam)
                scale = np.abs(S).max()
                A = np.block([[S, scale * J.T], [scale * J, np.zeros((J.shape[0], J.shape[0]))]])
                lu = sla.lu_factor(A)
                stats["factorizations"] += 1
            x = sla.lu_solve(lu, np.concatenate([-F, -scale * c]))
            dx, dl = x[:N], x[N:] * scale
            if not np.all(np.isfinite(x)):
                raise ConvergenceError(f"non-finite Newton increment at t = {t:.6g} s, iteration {it}")
            system.increment(st, dx)
            st.v += gp * dx
            st.a += bp * dx
            st.lam += dl
            stats["iterations"] += 1
            size = np.abs(dx).max()
            # converged, or stalled at round-off close to the tolerance
            if size <= tol * L or (size >= 0.5 * last and size <= 100 * tol * L):
                converged = True
                break
            last = size
        if not converged:
            raise ConvergenceError(f"Newton did not converge at t = {t:.6g} s after {max_iterations} iterations "
                                   f"(last increment {np.abs(dx).max():.3g}, residual {np.abs(F).max():.3g} N, "
                                   f"constraint violation {np.abs(c).max():.3g} m)")
        acc = acc_new + (1 - af) / (1 - am) * st.a
        st.t = t
        stats["steps"] += 1
        if n in out_steps:
            save(st, t)
    stats["wall_time"] = _time.perf_counter() - wall
    return MultibodyResult(system, np.array(record["t"]), np.array(record["r"]), np.array(record["R"]),
                           np.array(record["eta"]), np.array(record["v"]), np.array(record["drift"]), stats)
