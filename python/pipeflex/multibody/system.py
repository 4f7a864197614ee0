"""Multibody systems of floating-frame bodies joined by Lagrange-multiplier joints.

Governing equations (seed 004, eq. 70, prescribed flow), per body j with coordinates
q_j = [r_j; pi_j; eta_j] and velocities v_j = [r_dot_j; omega_j; eta_dot_j] (global r,
omega; pi a rotation increment):

    M_j(q) v_dot_j + Q_v,j(q, v, sdot, sddot) + [0; 0; K_j (eta_j - eta0_j)]
        - Q_g,j - Q_ext,j + C_q^T lambda = 0,        c(q, t) = 0,

with the fluid speed sdot_j = f_j mdot / mu_f,j of body j (``flow_factor`` f_j, the
model's mass flow mdot [kg/s]). Coordinates are stacked body after body.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, List, Optional, Sequence, Tuple, Union

import numpy as np

from .. import _checks
from ..analysis.transient import Sine
from .body import FlexibleBody
from .joints import Joint, node_kinematics, rotation_exp

TimeFunction = Union[float, Sine, Callable[[float], float]]


def time_value(f: TimeFunction, t: float) -> float:
    """Value of a time function at t [s]: a number, a :class:`~pipeflex.Sine` (envelope
    number or table (times, values), interpolated linearly) or a callable f(t)."""
    if isinstance(f, Sine):
        env = f.envelope
        e = float(env) if np.isscalar(env) else float(np.interp(t, env[0], env[1]))
        return e * np.sin(f.omega * t + f.phase)
    if callable(f):
        return float(f(t))
    return float(f)


def _check_time_function(name: str, f):
    if isinstance(f, Sine) or callable(f):
        v = time_value(f, 0.0)
        if not np.isfinite(v):
            raise ValueError(f"{name} must be finite, got {v} at t = 0")
        return f
    return _checks.finite(name, f)


@dataclass
class MultibodyState:
    """Configuration and motion of a multibody system at time ``t`` [s].

    Attributes:
        r: (n_bodies, 3) frame origins [m]; R: (n_bodies, 3, 3) frame rotations.
        eta: (N,) stacked coordinate vector of which only the elastic entries are used
            (the frame entries are kept at zero; positions live in ``r``, ``R``).
        v, a: (N,) velocities [m/s, rad/s, ...] and accelerations.
        lam: Lagrange multipliers [N, N m] (one per constraint equation).
    """

    r: np.ndarray
    R: np.ndarray
    eta: np.ndarray
    v: np.ndarray
    a: np.ndarray
    lam: np.ndarray
    t: float = 0.0

    def copy(self) -> "MultibodyState":
        return MultibodyState(self.r.copy(), self.R.copy(), self.eta.copy(), self.v.copy(), self.a.copy(),
                              self.lam.copy(), self.t)


@dataclass(frozen=True)
class _Load:
    body: int
    node: int
    force: Tuple[TimeFunction, TimeFunction, TimeFunction]
    moment: Tuple[TimeFunction, TimeFunction, TimeFunction]


class MultibodyBuilder:
    """Collects bodies, joints and loads; :meth:`build` checks them and returns a
    :class:`MultibodySystem`.

    Example::

        body = flexible_body(length=0.5, n_elements=20, section=sec)
        b = MultibodyBuilder()
        j0 = b.add_body(body, position=(0.25, 0, 0))
        j1 = b.add_body(body, position=(0.75, 0, 0))
        b.fix(j0, "start"); b.rigid(j0, "end", j1, "start")
        system = b.build(mass_flow=20.0)
    """

    def __init__(self) -> None:
        self._bodies: List[FlexibleBody] = []
        self._r: List[np.ndarray] = []
        self._R: List[np.ndarray] = []
        self._flow: List[float] = []
        self._joints: List[tuple] = []
        self._loads: List[_Load] = []
        self._gravity = np.zeros(3)

    def add_body(self, body: FlexibleBody, *, position: Sequence[float],
                 rotation: Optional[np.ndarray] = None, flow_factor: float = 1.0) -> int:
        """Place ``body`` with its frame origin (centre node) at ``position`` [m] and its
        axes rotated by ``rotation`` (3 x 3, body -> global; default identity). The fluid
        runs along +s (local x) with sdot = flow_factor mdot / mu_f. Returns its index."""
        if not isinstance(body, FlexibleBody):
            raise ValueError("body must be a FlexibleBody (pipeflex.multibody.flexible_body)")
        R = np.eye(3) if rotation is None else np.asarray(rotation, float)
        if R.shape != (3, 3) or not np.all(np.isfinite(R)) or not np.allclose(R.T @ R, np.eye(3), atol=1e-9) \
                or np.linalg.det(R) <= 0:
            raise ValueError("rotation must be a proper orthogonal 3 x 3 matrix")
        self._bodies.append(body)
        self._r.append(_checks.vector3("position", position))
        self._R.append(R.copy())
        self._flow.append(_checks.finite("flow_factor", flow_factor))
        return len(self._bodies) - 1

    def _ref(self, name: str, body, node) -> Tuple[int, int]:
        if isinstance(body, bool) or not isinstance(body, (int, np.integer)) or not 0 <= body < len(self._bodies):
            raise ValueError(f"{name} refers to body {body!r}, but the system has bodies 0..{len(self._bodies) - 1}")
        return int(body), self._bodies[body].node_index(node)

    def _add(self, kind, a, b, **extra):
        self._joints.append((kind, a, b, extra))

    def fix(self, body: int, node="start") -> None:
        """Clamp a node to the ground (position and orientation)."""
        self._add("rigid", self._ref("body", body, node), None)

    def rigid(self, body_a: int, node_a, body_b: int, node_b) -> None:
        """Rigid connection: no jump in position or orientation between two nodes."""
        self._add("rigid", self._ref("body_a", body_a, node_a), self._ref("body_b", body_b, node_b))

    def hinge(self, body_a: int, node_a, axis: Sequence[float], body_b: Optional[int] = None, node_b=None) -> None:
        """Revolute joint about the global ``axis`` (in the assembly configuration) between
        two nodes, or to the ground when ``body_b`` is None."""
        b = None if body_b is None else self._ref("body_b", body_b, node_b)
        self._add("hinge", self._ref("body_a", body_a, node_a), b, axis=_checks.unit_vector("axis", axis))

    def spherical(self, body_a: int, node_a, body_b: Optional[int] = None, node_b=None) -> None:
        """Coincident points, orientations free (to the ground when ``body_b`` is None)."""
        b = None if body_b is None else self._ref("body_b", body_b, node_b)
        self._add("spherical", self._ref("body_a", body_a, node_a), b)

    def roller(self, body: int, node, direction: Sequence[float]) -> None:
        """The node cannot move along the global ``direction``."""
        self._add("roller", self._ref("body", body, node), None, direction=_checks.unit_vector("direction", direction))

    def add_load(self, body: int, node, *, force: Sequence[TimeFunction] = (0.0, 0.0, 0.0),
                 moment: Sequence[TimeFunction] = (0.0, 0.0, 0.0)) -> None:
        """Dead nodal force [N] and moment [N m] in global axes; each component a number,
        a :class:`~pipeflex.Sine` or a callable of time t [s]."""
        ref = self._ref("body", body, node)
        if len(force) != 3 or len(moment) != 3:
            raise ValueError("force and moment need 3 components")
        f = tuple(_check_time_function(f"force[{i}]", x) for i, x in enumerate(force))
        m = tuple(_check_time_function(f"moment[{i}]", x) for i, x in enumerate(moment))
        self._loads.append(_Load(ref[0], ref[1], f, m))

    def set_gravity(self, g: Sequence[float]) -> None:
        """Gravitational acceleration g [m/s^2], e.g. ``(0, 0, -9.81)``."""
        self._gravity = _checks.vector3("gravity", g)

    def build(self, *, mass_flow: float = 0.0) -> "MultibodySystem":
        """Check the description and return the system.

        Args:
            mass_flow: mdot [kg/s] of the flow-carrying bodies (analyses may override it).

        Raises:
            ValueError: no bodies or joints; joints whose nodes do not coincide in the
                assembly configuration (inconsistent); redundant joint equations.
        """
        mdot = _checks.finite("mass_flow", mass_flow)
        if not self._bodies:
            raise ValueError("the system has no bodies")
        if not self._joints:
            raise ValueError("the system has no joints: fix or hinge a body to the ground")
        for j, (body, f) in enumerate(zip(self._bodies, self._flow)):
            if f != 0.0 and mdot != 0.0 and body.section.fluid_mass <= 0.0:
                raise ValueError(f"body {j} carries a mass flow but its fluid_mass is 0 (set flow_factor=0)")
        offsets = np.cumsum([0] + [b.n_coordinates for b in self._bodies])
        eta = np.zeros(offsets[-1])
        for j, b in enumerate(self._bodies):
            eta[offsets[j] + 6:offsets[j + 1]] = b.eta0
        n_rows = sum({"rigid": 6, "hinge": 5, "spherical": 3, "roller": 1}[j[0]] for j in self._joints)
        state0 = MultibodyState(np.array(self._r), np.array(self._R), eta, np.zeros(offsets[-1]),
                                np.zeros(offsets[-1]), np.zeros(n_rows))

        def kin(body, node):
            o = offsets[body]
            return node_kinematics(self._bodies[body], state0.r[body], state0.R[body],
                                   eta[o + 6:offsets[body + 1]], node)

        joints = []
        for k, (kind, a, b, extra) in enumerate(self._joints):
            name = f"joint {k} ({kind}: body {a[0]} node {a[1]} - " + \
                   ("ground" if b is None else f"body {b[0]} node {b[1]}") + ")"
            pa, Aa, _, _ = kin(*a)
            pb, Ab = (pa, np.eye(3)) if b is None else kin(*b)[:2]
            if b is not None and np.linalg.norm(pa - pb) > 1e-9 * max(1.0, np.linalg.norm(pa)):
                raise ValueError(f"{name}: the nodes do not coincide in the assembly configuration "
                                 f"(gap {np.linalg.norm(pa - pb):.3g} m)")
            ref = {}
            if b is None:
                ref["p"], ref["A"] = pa.copy(), Aa.copy()
                Ab = Aa
            if kind == "rigid":
                ref["C0"] = Aa.T @ Ab
            elif kind == "hinge":
                ax = extra["axis"]
                perp = np.linalg.svd(ax.reshape(1, 3))[2][1:]
                ref["axis_b"] = Ab.T @ ax
                ref["perp_a"] = [Aa.T @ e for e in perp]
            elif kind == "roller":
                ref["direction"], ref["p0"] = extra["direction"], pa.copy()
            joints.append(Joint(kind, a, b, ref, name))
        system = MultibodySystem(tuple(self._bodies), offsets, tuple(joints), tuple(self._loads),
                                 self._gravity.copy(), mdot, np.array(self._flow), state0)
        system.check_constraints()
        return system


class MultibodySystem:
    """An immutable system of flexible bodies, joints and loads.

    Attributes:
        bodies: the :class:`FlexibleBody` of each body; offsets: first coordinate of each.
        joints, loads, gravity [m/s^2], mass_flow mdot [kg/s], flow_factors.
        n_coordinates: N = sum(6 + m_j); n_constraints; n_dofs = N - n_constraints
            (independent coordinates: the size of the linearised problem).
        info: free-form description a scene attaches.
    """

    def __init__(self, bodies, offsets, joints, loads, gravity, mass_flow, flow_factors, state0):
        self.bodies = bodies
        self.offsets = offsets
        self.joints = joints
        self.loads = loads
        self.gravity = gravity
        self.mass_flow = mass_flow
        self.flow_factors = flow_factors
        self._state0 = state0
        self.n_coordinates = int(offsets[-1])
        self.joint_rows = np.cumsum([0] + [j.rows for j in joints])
        self.n_constraints = int(self.joint_rows[-1])
        self.n_dofs = self.n_coordinates - self.n_constraints
        self.info: dict = {}

    # -- states --------------------------------------------------------------------
    def initial_state(self) -> MultibodyState:
        """The assembly configuration (eta = eta0) at rest."""
        s = self._state0.copy()
        N = self.n_coordinates
        s.v, s.a, s.lam = np.zeros(N), np.zeros(N), np.zeros(self.n_constraints)
        return s

    def body_slice(self, j: int) -> slice:
        return slice(int(self.offsets[j]), int(self.offsets[j + 1]))

    def eta(self, state: MultibodyState, j: int) -> np.ndarray:
        return state.eta[self.offsets[j] + 6:self.offsets[j + 1]]

    def node_kinematics(self, state: MultibodyState, body: int, node: int):
        """(position [m], orientation, Jp, Ja) of a node (see :mod:`.joints`)."""
        return node_kinematics(self.bodies[body], state.r[body], state.R[body], self.eta(state, body), node)

    def node_position(self, state: MultibodyState, body: int, node) -> np.ndarray:
        """Global position [m] of a node (index or "start"/"center"/"end")."""
        return self.node_kinematics(state, body, self.bodies[body].node_index(node))[0]

    def centre_line(self, state: MultibodyState) -> List[np.ndarray]:
        """Per body, the (n_nodes, 3) global node positions [m]."""
        out = []
        for j, b in enumerate(self.bodies):
            e = self.eta(state, j)
            U = (b.basis @ e).reshape(-1, 6)[:, :3]
            X = np.column_stack([b.nodes_s, np.zeros((b.n_nodes, 2))]) + U
            out.append(state.r[j] + X @ state.R[j].T)
        return out

    def increment(self, state: MultibodyState, dq: np.ndarray) -> None:
        """q <- q (+) dq in place: r += dr, R <- exp(dpi~) R, eta += deta."""
        for j in range(len(self.bodies)):
            o = self.offsets[j]
            state.r[j] += dq[o:o + 3]
            state.R[j] = rotation_exp(dq[o + 3:o + 6]) @ state.R[j]
            state.eta[o + 6:self.offsets[j + 1]] += dq[o + 6:self.offsets[j + 1]]

    # -- flow ----------------------------------------------------------------------
    def flow_speeds(self, mass_flow: float, mass_flow_rate: float = 0.0):
        """Per body (sdot [m/s], sddot [m/s^2]) for mdot [kg/s] and d(mdot)/dt [kg/s^2]."""
        out = []
        for b, f in zip(self.bodies, self.flow_factors):
            mu = b.section.fluid_mass
            out.append((0.0, 0.0) if mu <= 0.0 or f == 0.0 else (f * mass_flow / mu, f * mass_flow_rate / mu))
        return out

    def flow_scale(self) -> float:
        """mdot_ref = (pi / L) sqrt(mu_f EI / k_v) [kg/s] of the flow-carrying bodies (as
        :meth:`pipeflex.Model.flow_scale`)."""
        bs = [b for b, f in zip(self.bodies, self.flow_factors) if f != 0 and b.section.fluid_mass > 0]
        if not bs:
            raise ValueError("the system has no body that carries fluid")
        L = sum(b.length for b in bs)
        mf = sum(b.length * b.section.fluid_mass for b in bs) / L
        EI = sum(b.length * min(b.section.EI, b.section.EIz) for b in bs) / L
        return float(np.pi / L * np.sqrt(mf * EI))

    @property
    def total_mass(self) -> float:
        return float(sum(b.mass for b in self.bodies))

    @property
    def length_scale(self) -> float:
        return float(max(b.length for b in self.bodies))

    # -- equations -----------------------------------------------------------------
    def constraints(self, state: MultibodyState):
        """(c (n_constraints,), C_q (n_constraints x N)) at ``state``."""
        c = np.zeros(self.n_constraints)
        J = np.zeros((self.n_constraints, self.n_coordinates))
        kin = lambda body, node: self.node_kinematics(state, body, node)  # noqa: E731
        for k, jt in enumerate(self.joints):
            rows = slice(self.joint_rows[k], self.joint_rows[k + 1])
            ck, Ja, Jb = jt.evaluate(kin)
            c[rows] = ck
            J[rows, self.body_slice(jt.a[0])] += Ja
            if Jb is not None:
                J[rows, self.body_slice(jt.b[0])] += Jb
        return c, J

    def check_constraints(self) -> None:
        """Raise ValueError for redundant joint equations (rank-deficient C_q)."""
        _, J = self.constraints(self._state0)
        if self.n_constraints > self.n_coordinates:
            raise ValueError(f"{self.n_constraints} constraint equations for {self.n_coordinates} coordinates")
        scale = np.maximum(np.abs(J).max(axis=1, keepdims=True), 1e-300)
        Jn = J / scale
        rank = 0
        for k, jt in enumerate(self.joints):
            sub = Jn[:self.joint_rows[k + 1]]
            r = np.linalg.matrix_rank(sub, tol=1e-9 * np.sqrt(sub.shape[1]))
            if r < self.joint_rows[k + 1]:
                raise ValueError(f"{jt.name} is redundant: {self.joint_rows[k + 1] - r} of its equations repeat "
                                 "constraints already imposed by the joints before it")
            rank = r
        del rank

    def external_forces(self, state: MultibodyState, t: float, load_factor: float = 1.0) -> np.ndarray:
        """Generalised nodal loads Jp^T f + Ja^T m (N,) at time t [s]."""
        Q = np.zeros(self.n_coordinates)
        for ld in self.loads:
            f = np.array([time_value(x, t) for x in ld.force])
            m = np.array([time_value(x, t) for x in ld.moment])
            _, _, Jp, Ja = self.node_kinematics(state, ld.body, ld.node)
            Q[self.body_slice(ld.body)] += load_factor * (Jp.T @ f + Ja.T @ m)
        return Q

    def body_forces(self, state: MultibodyState, *, mass_flow: float, mass_flow_rate: float = 0.0,
                    gravity_factor: float = 1.0, wK: float = 1.0, wC: float = 0.0, wM: float = 0.0,
                    tangent: bool = True):
        """Stacked body residuals (inertia + elastic - gravity) and the block-diagonal
        tangent wK dF/dq + wC dF/dv + wM dF/da (or None)."""
        N = self.n_coordinates
        F = np.zeros(N)
        T = np.zeros((N, N)) if tangent else None
        g = gravity_factor * self.gravity
        for j, (b, (sd, sdd)) in enumerate(zip(self.bodies, self.flow_speeds(mass_flow, mass_flow_rate))):
            sl = self.body_slice(j)
            o = sl.start
            v = state.v[sl]
            res, tan = b.data.forces(state.R[j], v[3:6], state.a[sl], state.eta[o + 6:sl.stop], v[6:], sd, sdd, g,
                                     wK, wC, wM, tangent)
            F[sl] = res
            if tangent:
                T[sl, sl] = tan
        return F, T

    def constraint_stiffness(self, state: MultibodyState, lam: np.ndarray, h: float = 1e-7) -> np.ndarray:
        """d(C_q^T lambda)/dq at fixed lambda (central differences per joint): the
        geometric stiffness of the joint reactions."""
        N = self.n_coordinates
        Kc = np.zeros((N, N))
        for k, jt in enumerate(self.joints):
            lk = lam[self.joint_rows[k]:self.joint_rows[k + 1]]
            if not np.any(lk):
                continue
            bodies = sorted({jt.a[0]} | ({jt.b[0]} if jt.b is not None else set()))
            cols = np.concatenate([np.arange(*self.body_slice(j).indices(N)) for j in bodies])

            def force(st):
                kin = lambda body, node: self.node_kinematics(st, body, node)  # noqa: E731
                _, Ja, Jb = jt.evaluate(kin)
                out = np.zeros(N)
                out[self.body_slice(jt.a[0])] += Ja.T @ lk
                if Jb is not None:
                    out[self.body_slice(jt.b[0])] += Jb.T @ lk
                return out[cols]

            for c in cols:
                d = np.zeros(N)
                step = h * (self.length_scale if (c - self.offsets[np.searchsorted(self.offsets, c, 'right') - 1]) < 3
                            else 1.0)
                d[c] = step
                sp, sm = state.copy(), state.copy()
                self.increment(sp, d)
                self.increment(sm, -d)
                Kc[cols, c] += (force(sp) - force(sm)) / (2 * step)
        return Kc

    def energy(self, state: MultibodyState) -> float:
        """Kinetic + elastic + gravitational potential energy [J] (no flow)."""
        E = 0.0
        for j, b in enumerate(self.bodies):
            sl = self.body_slice(j)
            R = state.R[j]
            v = state.v[sl]
            vl = np.concatenate([R.T @ v[:3], R.T @ v[3:6], v[6:]])
            M = np.asarray(b.data.forces(np.eye(3), np.zeros(3), np.zeros(b.n_coordinates), np.zeros(b.n_modes),
                                         np.zeros(b.n_modes), 0.0, 0.0, np.zeros(3), 0.0, 0.0, 1.0, True)[1])
            e = self.eta(state, j) - b.eta0
            K = np.asarray(b.data.forces(np.eye(3), np.zeros(3), np.zeros(b.n_coordinates), np.zeros(b.n_modes),
                                         np.zeros(b.n_modes), 0.0, 0.0, np.zeros(3), 1.0, 0.0, 0.0, True)[1])[6:, 6:]
            E += 0.5 * vl @ M @ vl + 0.5 * e @ K @ e
            # gravity: V = -m g.r - (R^T g).(int mu N ds) eta; the straight reference is centred
            Ng = np.asarray(b.data.Ng)
            E -= b.mass * self.gravity @ state.r[j] + (R.T @ self.gravity) @ (Ng[6:].T @ self.eta(state, j))
        return float(E)
