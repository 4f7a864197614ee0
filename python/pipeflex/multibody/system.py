"""Multibody systems of floating-frame bodies joined by Lagrange-multiplier joints.

Governing equations (van Voorthuizen et al., eq. 70, prescribed flow), per body j with coordinates
q_j = [r_j; pi_j; eta_j] and velocities v_j = [r_dot_j; omega_j; eta_dot_j] (global r,
omega; pi a rotation increment):

    M_j(q) v_dot_j + Q_v,j(q, v, sdot, sddot) + [0; 0; K_j (eta_j - eta0_j)]
        - Q_g,j - Q_ext,j + C_q^T lambda = 0,        c(q, t) = 0,

with the fluid speed sdot_j = f_j mdot / mu_f,j of body j (``flow_factor`` f_j, the
model's mass flow mdot [kg/s]). Coordinates are stacked body after body.
"""
from __future__ import annotations

import copy
from dataclasses import dataclass, field, replace
from typing import List, Optional, Sequence, Tuple, Union

import numpy as np

from .. import _checks, _core
from ..results import Result
from ..time_functions import Sine, time_function
from .body import FlexibleBody, flexible_body, node_index
from ..rotation import rotation_exp, rotation_log
from .joints import JOINT_KINDS, JOINT_ROWS, Joint
from .statics import static_failure, static_newton

#: A function of time: a number, a table (times [s], values) interpolated linearly, or a
#: :class:`~pipeflex.Sine` (envelope number or table times a sine carrier).
TimeFunction = Union[float, Tuple[Sequence[float], Sequence[float]], Sine]


@dataclass(frozen=True)
class MultibodyState(Result):
    """Configuration and motion of a multibody system at time ``t`` [s].

    Frozen: the fields cannot be re-bound, but the arrays can be edited in place (e.g.
    ``st.v[3:6] = omega`` for an initial spin); :func:`dataclasses.replace` gives a
    state with other arrays.

    Attributes:
        r: (n_bodies, 3) frame origins [m]; R: (n_bodies, 3, 3) frame rotations [-].
        eta: (N,) stacked coordinate vector of which only the elastic entries are used
            (the frame entries are kept at zero; positions live in ``r``, ``R``).
        v, a: (N,) velocities [m/s, rad/s, ...] and accelerations.
        lam: Lagrange multipliers [N, N m] (one per constraint equation).
        t: time [s].
    """

    r: np.ndarray
    R: np.ndarray
    eta: np.ndarray
    v: np.ndarray
    a: np.ndarray
    lam: np.ndarray
    t: float = 0.0

    def copy(self) -> "MultibodyState":
        """A deep copy."""
        return MultibodyState(self.r.copy(), self.R.copy(), self.eta.copy(), self.v.copy(), self.a.copy(),
                              self.lam.copy(), self.t)


@dataclass(frozen=True)
class _Load:
    body: int
    node: int
    force: Tuple  # three plain time functions [N]
    moment: Tuple  # three plain time functions [N m]


def _plain_time_function(name, f):
    """A checked copy of a time function as plain data: a float, a (times, values) pair
    of float arrays or a :class:`~pipeflex.Sine` of those (``time_function`` compiles it)."""
    if isinstance(f, Sine):
        f = replace(f, envelope=_plain_time_function(f"{name}.envelope", f.envelope))
    elif np.isscalar(f) and not isinstance(f, (str, bytes)):
        f = _checks.finite(name, f)
    else:
        try:
            f = tuple(np.array(a, dtype=float) for a in f)
        except (TypeError, ValueError):
            pass  # time_function names the problem
    time_function(name, f)
    return f


def _require_body(body) -> None:
    """A TypeError naming ``body``'s type unless it is a FlexibleBody (a section or a dict
    of section fields is the common slip: the body is made from the section)."""
    if not isinstance(body, FlexibleBody):
        raise TypeError(f"body must be a FlexibleBody, got {type(body).__name__}: make one with pipeflex.multibody."
                        "flexible_body(length=..., n_elements=..., section=pipeflex.PipeSection(...))")


class MultibodyBuilder:
    """Collects bodies, joints, springs and loads; :meth:`build` checks them and returns a
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
        self._springs: List[dict] = []
        self._distributed: List[dict] = []
        self._gravity = np.zeros(3)

    def add_body_between(self, body: FlexibleBody, start: Sequence[float], end: Sequence[float], *,
                         up: Optional[Sequence[float]] = None, flow_factor: float = 1.0) -> int:
        """Place a straight body from the point ``start`` to ``end`` [m] (its length must
        match), local z towards ``up`` (default global z, or y for a vertical body)."""
        from ..model import _triad

        _require_body(body)
        x0, x1 = _checks.vector3("start", start), _checks.vector3("end", end)
        d = float(np.linalg.norm(x1 - x0))
        if abs(d - body.length) > 1e-9 * body.length or not np.allclose(body.eta0, 0.0):
            raise ValueError(f"the body (length {body.length} m, straight) does not fit between start and end "
                             f"({d} m apart)")
        R = _triad(x1 - x0, None if up is None else _checks.unit_vector("up", up))
        return self.add_body(body, position=0.5 * (x0 + x1), rotation=R, flow_factor=flow_factor)

    def add_body(self, body: FlexibleBody, *, position: Sequence[float],
                 rotation: Optional[np.ndarray] = None, flow_factor: float = 1.0) -> int:
        """Place ``body`` with its frame origin (centre node) at ``position`` [m] and its
        axes rotated by ``rotation`` (3 x 3, body -> global; default identity). The fluid
        runs along +s (local x) with sdot = flow_factor mdot / mu_f. Returns its index."""
        _require_body(body)
        R = np.eye(3) if rotation is None else np.asarray(rotation, float)
        if R.shape != (3, 3) or not np.all(np.isfinite(R)) or not np.allclose(R.T @ R, np.eye(3), atol=1e-9) \
                or np.linalg.det(R) <= 0:
            raise ValueError("rotation must be a proper orthogonal 3 x 3 matrix")
        self._bodies.append(body)
        self._r.append(_checks.vector3("position", position))
        self._R.append(R.copy())
        self._flow.append(_checks.finite("flow_factor", flow_factor))
        return len(self._bodies) - 1

    def _other(self, body_b, node_b):
        """The second end of a joint: a body node, or None for the ground."""
        if body_b is None:
            if node_b is not None:
                raise ValueError(f"node_b = {node_b!r} given without body_b (None joins to the ground)")
            return None
        return self._ref("body_b", body_b, node_b)

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

    def hinge(self, body_a: int, node_a, axis: Sequence[float], body_b: Optional[int] = None, node_b=None, *,
              torque: Optional[TimeFunction] = None) -> None:
        """Revolute joint about the global ``axis`` (in the assembly configuration) between
        two nodes, or to the ground when ``body_b`` is None. ``torque`` [N m] (a time
        function) drives the joint: +torque about the current axis on body a, -torque on
        body b (a motor between them)."""
        b = self._other(body_b, node_b)
        # given_axis: the vector as passed, which a model file writes (normalising twice may change the last bit)
        self._add("hinge", self._ref("body_a", body_a, node_a), b, axis=_checks.unit_vector("axis", axis),
                  torque=None if torque is None else _plain_time_function("torque", torque),
                  given_axis=_checks.vector3("axis", axis))

    def spherical(self, body_a: int, node_a, body_b: Optional[int] = None, node_b=None) -> None:
        """Coincident points, orientations free (to the ground when ``body_b`` is None)."""
        b = self._other(body_b, node_b)
        self._add("spherical", self._ref("body_a", body_a, node_a), b)

    def roller(self, body: int, node, direction: Sequence[float]) -> None:
        """The node cannot move along the global ``direction``."""
        self._add("roller", self._ref("body", body, node), None, direction=_checks.unit_vector("direction", direction),
                  given_direction=_checks.vector3("direction", direction))

    def add_load(self, body: int, node, *, force: Sequence[TimeFunction] = (0.0, 0.0, 0.0),
                 moment: Sequence[TimeFunction] = (0.0, 0.0, 0.0)) -> None:
        """Dead nodal force [N] and moment [N m] in global axes; each component a number,
        a table (times [s], values) or a :class:`~pipeflex.Sine` (see :data:`TimeFunction`)."""
        ref = self._ref("body", body, node)
        if len(force) != 3 or len(moment) != 3:
            raise ValueError("force and moment need 3 components")
        f = tuple(_plain_time_function(f"force[{i}]", x) for i, x in enumerate(force))
        m = tuple(_plain_time_function(f"moment[{i}]", x) for i, x in enumerate(moment))
        self._loads.append(_Load(ref[0], ref[1], f, m))

    def add_distributed_load(self, body: int, *, force_per_length: Sequence[float],
                             time_function: Optional[TimeFunction] = None) -> None:
        """A distributed dead load q [N/m] in global axes along the whole body, per unit of
        its length: consistent through the body's shape functions like its weight, whose
        term carries it (g raised by q / mu, mu = mu_p + mu_f the mass per length), so it
        acts on the frame and the elastic coordinates, and its tangent (the turning of the
        frame) is exact; a clamped body under it bends like under its weight with q = mu g
        (the element models' :meth:`pipeflex.ModelBuilder.add_distributed_load`).

        Args:
            body: the body [-] (an index from :meth:`add_body`).
            force_per_length: q (3) [N/m].
            time_function: s(t) [-] of this load alone (a number, a table (times [s],
                values), a :class:`~pipeflex.Sine`); the load is ``s(t) lambda(t) q``,
                lambda the analysis' load factor; statics take the loads at their time.
                None: s = 1.
        """
        j = self._ref("body", body, 0)[0]
        q = _checks.vector3("force_per_length", force_per_length)
        tf = None if time_function is None else _plain_time_function("time_function", time_function)
        self._distributed.append(dict(body=j, q=q, tf=tf))

    def _spring_node(self, body_name: str, node_name: str, body, node) -> Tuple[int, int]:
        """(body, node) of a spring's end, the errors naming the arguments."""
        j = self._ref(body_name, body, 0)[0]
        try:
            return j, self._bodies[j].node_index(node)
        except ValueError as e:
            raise ValueError(f"{node_name}: {e}") from None

    def add_spring(self, body_a: int, node_a, body_b: int, node_b, *, stiffness: float,
                   damping: float = 0.0) -> int:
        """A linear axial spring-damper between two body nodes (the element models' axial
        spring, :meth:`pipeflex.ModelBuilder.add_spring`): massless, unstressed at the
        nodes' distance L0 in the assembly configuration, axial force
        T = k (l - L0) + c dl/dt along the line between them (tension positive; l the
        nodes' distance, dl/dt its rate). It holds no rotation. It acts through the bodies'
        node maps (position r + R (x + Phi_u eta)), so the frames and the elastic
        coordinates feel it; its tangents are exact. Returns its index among the springs.

        Args:
            body_a, node_a: the first body [-] and its node (index or "start", "center",
                "end").
            body_b, node_b: the second; the two nodes must not coincide in the assembly
                configuration (a zero length has no axis: use :meth:`add_ground_spring`).
            stiffness: k [N/m] >= 0.
            damping: c [N s/m] >= 0, a dashpot in parallel.
        """
        a = self._spring_node("body_a", "node_a", body_a, node_a)
        b = self._spring_node("body_b", "node_b", body_b, node_b)
        k = _checks.non_negative("stiffness", stiffness)
        c = _checks.non_negative("damping", damping)
        if a == b:
            raise ValueError(f"node_a and node_b are both node {a[1]} of body {a[0]}: a spring needs two nodes "
                             "(to hold a node at a point use add_ground_spring)")
        self._springs.append(dict(kind="axial", nodes=(a, b), k=k, c=c))
        return len(self._springs) - 1

    def add_ground_spring(self, body: int, node, *, stiffness: Sequence[float] = (0.0, 0.0, 0.0),
                          damping: Sequence[float] = (0.0, 0.0, 0.0), anchor: Optional[Sequence[float]] = None,
                          rotational_stiffness: Sequence[float] = (0.0, 0.0, 0.0),
                          rotational_damping: Sequence[float] = (0.0, 0.0, 0.0)) -> int:
        """A linear spring-damper from a body node to the ground (the element models' ground
        spring, :meth:`pipeflex.ModelBuilder.add_ground_spring`), massless: force
        -K (x - X) - C v on the node with K = diag(kx, ky, kz), C = diag(cx, cy, cz) along
        the global axes, and optionally moment -T(psi)^-T K_phi psi - C_phi w, psi the
        rotation vector of the node's rotation from its orientation in the assembly
        configuration (``|psi| < pi``), w its angular velocity. It acts through the body's
        node maps with exact tangents. Returns its index among the springs.

        Args:
            body: the body [-]; node: its node (index or "start", "center", "end").
            stiffness: (kx, ky, kz) [N/m] >= 0 each.
            damping: (cx, cy, cz) [N s/m] >= 0 each.
            anchor: X [m], where the spring is unstressed; default the node's position in
                the assembly configuration.
            rotational_stiffness: k_phi (3) [N m/rad] >= 0 each, about the global axes.
            rotational_damping: c_phi (3) [N m s/rad] >= 0 each, about the global axes.
        """
        from ..model import ModelBuilder

        ref = self._spring_node("body", "node", body, node)
        k, c, kr, cr = (ModelBuilder._non_negative3(name, v, unit) for name, v, unit in
                        (("stiffness", stiffness, "N/m"), ("damping", damping, "N s/m"),
                         ("rotational_stiffness", rotational_stiffness, "N m/rad"),
                         ("rotational_damping", rotational_damping, "N m s/rad")))
        x = None if anchor is None else _checks.vector3("anchor", anchor)
        if not (k.any() or c.any() or kr.any() or cr.any()):
            raise ValueError("a ground spring needs a stiffness or a damping > 0 in some direction, got all zero")
        self._springs.append(dict(kind="ground", nodes=(ref,), k=k, c=c, anchor=x, k_phi=kr, c_phi=cr))
        return len(self._springs) - 1

    def add_bushing(self, body_a: int, node_a, body_b: int, node_b, *,
                    stiffness: Sequence[float] = (0.0, 0.0, 0.0), damping: Sequence[float] = (0.0, 0.0, 0.0),
                    rotational_stiffness: Sequence[float] = (0.0, 0.0, 0.0),
                    rotational_damping: Sequence[float] = (0.0, 0.0, 0.0)) -> int:
        """A linear 6-DOF spring-damper (bushing) between two body nodes (the element
        models' bushing, :meth:`pipeflex.ModelBuilder.add_bushing`), massless; the nodes
        may coincide. Force on node b -K (p_b - p_a - d0) - C (v_b - v_a), its opposite on
        node a (d0 the nodes' offset in the assembly configuration; K = diag(kx, ky, kz),
        C = diag(cx, cy, cz) along the global axes), and moment on node b
        -T(psi)^-T K_phi psi - C_phi (w_b - w_a), its opposite on node a, psi the rotation
        vector of the nodes' relative rotation from the assembly configuration
        (``|psi| < pi``), w their angular velocities, K_phi and C_phi about the global axes.
        It acts through the bodies' node maps with exact tangents. Returns its index among
        the springs.

        Args:
            body_a, node_a: the first body [-] and its node (index or "start", "center",
                "end").
            body_b, node_b: the second (another node).
            stiffness: (kx, ky, kz) [N/m] >= 0 each.
            damping: (cx, cy, cz) [N s/m] >= 0 each.
            rotational_stiffness: k_phi (3) [N m/rad] >= 0 each, about the global axes.
            rotational_damping: c_phi (3) [N m s/rad] >= 0 each, about the global axes.
        """
        from ..model import ModelBuilder

        a = self._spring_node("body_a", "node_a", body_a, node_a)
        b = self._spring_node("body_b", "node_b", body_b, node_b)
        k, c, kr, cr = (ModelBuilder._non_negative3(name, v, unit) for name, v, unit in
                        (("stiffness", stiffness, "N/m"), ("damping", damping, "N s/m"),
                         ("rotational_stiffness", rotational_stiffness, "N m/rad"),
                         ("rotational_damping", rotational_damping, "N m s/rad")))
        if a == b:
            raise ValueError(f"node_a and node_b are both node {a[1]} of body {a[0]}: a bushing joins two nodes "
                             "(to hold a node to the ground use add_ground_spring)")
        if not (k.any() or c.any() or kr.any() or cr.any()):
            raise ValueError("a bushing needs a stiffness or a damping > 0 in some direction, got all zero")
        self._springs.append(dict(kind="bushing", nodes=(a, b), k=k, c=c, k_phi=kr, c_phi=cr))
        return len(self._springs) - 1

    def set_gravity(self, g: Sequence[float]) -> None:
        """Gravitational acceleration g [m/s^2], e.g. ``(0, 0, -9.81)``."""
        self._gravity = _checks.gravity("gravity", g)

    def _junction(self, a, b) -> float:
        """+1 if the flow passes from a's outlet into b's inlet, -1 the other way, else 0."""
        if b is None:
            return 0.0

        def end(ref):  # "out", "in" or None (not a flow end)
            body, node = ref
            f, bd = self._flow[body], self._bodies[body]
            if f == 0.0 or bd.section.fluid_mass <= 0.0 or node not in (0, bd.n_elements):
                return None
            return "out" if (node == bd.n_elements) == (f > 0.0) else "in"

        ea, eb = end(a), end(b)
        return {("out", "in"): 1.0, ("in", "out"): -1.0}.get((ea, eb), 0.0)

    def _rate_force_zeros(self) -> List[float]:
        """Per body s0 [m] (its own s): where the axial force of the fluid's acceleration,
        N' = mu_f sddot along s, vanishes (the kernel's rate geometric stiffness, ffrf_body.hpp).

        The bodies that pass the flow from an outlet to the next inlet through a joint make
        a flow path of arc length L_p; N vanishes where the path may slide axially, as in
        docs/theory.md's table: at its outlet unless that is held (fixed, hinged or
        spherical to the ground, or a roller along the pipe's axis); else at its inlet
        unless that is held; with both held where int (x - c) / EA dx = 0 (mid-path for
        one EA). Ground springs and anything the chain is joined to outside this builder
        (a coupled system's elements) count as free."""
        flowing = [f != 0.0 and b.section.fluid_mass > 0.0 for b, f in zip(self._bodies, self._flow)]

        def ends(j):  # (inlet node, outlet node) of body j
            last = self._bodies[j].n_elements
            return (0, last) if self._flow[j] > 0.0 else (last, 0)

        nxt, prev = {}, {}
        for kind, a, b, extra in self._joints:
            if b is None or a[0] == b[0] or not (flowing[a[0]] and flowing[b[0]]):
                continue
            for up, down in ((a, b), (b, a)):
                if up[1] == ends(up[0])[1] and down[1] == ends(down[0])[0]:
                    nxt[up[0]], prev[down[0]] = down[0], up[0]

        def held(j, node):
            t = self._R[j][:, 0]
            for kind, a, b, extra in self._joints:
                if b is None and a == (j, node) and (
                        kind in ("rigid", "hinge", "spherical") or
                        (kind == "roller" and abs(extra["direction"] @ t) > 1.0 - 1e-6)):
                    return True
            return False

        zeros = [0.0] * len(self._bodies)
        done = set()
        for start in range(len(self._bodies)):
            if not flowing[start] or start in done:
                continue
            first, seen = start, {start}  # walk up to the path's inlet (a closed loop: start anywhere)
            while first in prev and prev[first] not in seen:
                first = prev[first]
                seen.add(first)
            path = [first]
            while path[-1] in nxt and nxt[path[-1]] not in path:
                path.append(nxt[path[-1]])
            done.update(path)
            lengths = np.array([self._bodies[j].length for j in path])
            x_in = np.concatenate([[0.0], np.cumsum(lengths)[:-1]])
            if not held(path[-1], ends(path[-1])[1]):
                c = float(lengths.sum())
            elif not held(path[0], ends(path[0])[0]):
                c = 0.0
            else:
                compliance = lengths / np.array([self._bodies[j].section.EA for j in path])
                c = float((x_in + 0.5 * lengths) @ compliance / compliance.sum())
            for j, x0, length in zip(path, x_in, lengths):
                zeros[j] = (c - x0 - 0.5 * length) if self._flow[j] > 0.0 else (0.5 * length - (c - x0))
        return zeros

    def build(self, *, mass_flow: float = 0.0, junction_forces: bool = True) -> "MultibodySystem":
        """Check the description and return the system.

        Each flow-carrying body gets the point of its flow path where the axial force of
        the fluid's acceleration vanishes (the outlet, unless it is held axially:
        docs/parametric.md), which the body's geometric stiffness of that force needs.

        Args:
            mass_flow: mdot [kg/s] of the flow-carrying bodies (analyses may override it).
            junction_forces: where a rigid joint passes the flow from the outlet of one
                body to the inlet of the next, apply the force of the fluid's momentum
                flux turning there, P_up t_up - P_down t_down (t the node tangents along
                the flow, P = mu_f sdot^2 [N]): the kink force, which the bodies' own
                terms (int N^T N'' over each body) do not contain. It vanishes where
                bodies join smoothly. ``False`` is van Voorthuizen et al.'s formulation as printed.

        Raises:
            ValueError: no bodies, or neither joints nor ground springs nor a foundation; joints whose nodes
                do not coincide in the assembly configuration (inconsistent); redundant
                joint equations; an axial spring between coinciding nodes.
        """
        mdot = _checks.finite("mass_flow", mass_flow)
        if not self._bodies:
            raise ValueError("the system has no bodies")
        if not self._joints and not any(sp["kind"] == "ground" for sp in self._springs) and \
                not any(b.foundation is not None for b in self._bodies):
            raise ValueError("the system has no joints and no ground springs (and no body on a foundation): fix, "
                             "hinge or spring a body to the ground")
        for j, (body, f) in enumerate(zip(self._bodies, self._flow)):
            if f != 0.0 and mdot != 0.0 and body.section.fluid_mass <= 0.0:
                raise ValueError(f"body {j} carries a mass flow but its fluid_mass is 0 (set flow_factor=0)")
        core = _core.MultibodySystemCore()
        distributed = [[] for _ in self._bodies]
        for d in getattr(self, "_distributed", ()):  # (absent from descriptions pickled without it)
            distributed[d["body"]].append(
                (d["q"], time_function("time_function", 1.0 if d["tf"] is None else d["tf"])))
        for j, (body, f, s0) in enumerate(zip(self._bodies, self._flow, self._rate_force_zeros())):
            core.add_body(body.data, body.basis, list(body.nodes_s), body.section.fluid_mass, f,
                          foundation=body.foundation, r_ref=self._r[j], R_ref=self._R[j],
                          mass_per_length=body.section.pipe_mass + body.section.fluid_mass,
                          distributed=distributed[j], rate_force_zero=s0)
        offsets = np.cumsum([0] + [b.n_coordinates for b in self._bodies])
        eta = np.zeros(offsets[-1])
        for j, b in enumerate(self._bodies):
            eta[offsets[j] + 6:offsets[j + 1]] = b.eta0
        n_rows = sum(JOINT_ROWS[j[0]] for j in self._joints)
        state0 = MultibodyState(np.array(self._r), np.array(self._R), eta, np.zeros(offsets[-1]),
                                np.zeros(offsets[-1]), np.zeros(n_rows))

        def kin(body, node):
            return core.node(state0.r, state0.R, eta, body, node)[:2]

        joints = []
        for k, (kind, a, b, extra) in enumerate(self._joints):
            name = f"joint {k} ({kind}: body {a[0]} node {a[1]} - " + \
                   ("ground" if b is None else f"body {b[0]} node {b[1]}") + ")"
            pa, Aa = kin(*a)
            pb, Ab = (pa, Aa) if b is None else kin(*b)
            if np.linalg.norm(pa - pb) > 1e-9 * max(1.0, np.linalg.norm(pa)):
                raise ValueError(f"{name}: the nodes do not coincide in the assembly configuration "
                                 f"(gap {np.linalg.norm(pa - pb):.3g} m)")
            ref = dict(p_ground=pa, A_ground=Aa, C0=Aa.T @ Ab, axis_b=np.array([0.0, 0.0, 1.0]),
                       perp0=np.zeros(3), perp1=np.zeros(3), direction=np.array([0.0, 0.0, 1.0]), p0=pa)
            if kind == "hinge":
                ax = extra["axis"]
                perp = np.linalg.svd(ax.reshape(1, 3))[2][1:]
                torque = None if extra["torque"] is None else time_function("torque", extra["torque"])
                ref.update(axis_b=Ab.T @ ax, perp0=Aa.T @ perp[0], perp1=Aa.T @ perp[1], torque=torque)
            elif kind == "roller":
                ref["direction"] = extra["direction"]
            junction = self._junction(a, b) if (junction_forces and kind == "rigid") else 0.0
            core.add_joint(JOINT_KINDS.index(kind), a[0], a[1], -1 if b is None else b[0], 0 if b is None else b[1],
                           junction=junction, **ref)
            joints.append(Joint(kind, a, b, ref, name))
        for ld in self._loads:
            core.add_load(ld.body, ld.node, [time_function(f"force[{i}]", x) for i, x in enumerate(ld.force)],
                          [time_function(f"moment[{i}]", x) for i, x in enumerate(ld.moment)])
        for k, sp in enumerate(self._springs):
            ends = [(*ref, *kin(*ref)) for ref in sp["nodes"]]
            if sp["kind"] == "axial":
                (ba, na, pa, Aa), (bb, nb, pb, Ab) = ends
                if not np.linalg.norm(pb - pa) > 0.0:
                    raise ValueError(f"spring {k} (body {ba} node {na} - body {bb} node {nb}): the nodes coincide "
                                     "in the assembly configuration, so the axial spring has no axis; use "
                                     "add_ground_spring, or move them apart")
                core.add_spring(ba, na, pa, Aa, bb, nb, pb, Ab, sp["k"], sp["c"])
            elif sp["kind"] == "bushing":
                (ba, na, pa, Aa), (bb, nb, pb, Ab) = ends
                core.add_bushing(ba, na, pa, Aa, bb, nb, pb, Ab, sp["k"], sp["c"], sp["k_phi"], sp["c_phi"])
            else:
                (b, n, p, A), = ends
                core.add_ground_spring(b, n, p, A, sp["k"], sp["c"], sp["anchor"], sp["k_phi"], sp["c_phi"])
        core.set_gravity(self._gravity)
        # the model's size for the Newton tests: the assembly's extent (body ends), as an
        # element model's (a chain of many short bodies is as large as the chain)
        ends = [state0.r[j] + state0.R[j][:, 0] * s for j, b in enumerate(self._bodies)
                for s in (b.nodes_s[0], b.nodes_s[-1])]
        core.set_length_scale(float(np.ptp(np.array(ends), axis=0).max()))
        core.finalize()
        system = MultibodySystem(core, tuple(self._bodies), offsets, tuple(joints), tuple(self._loads),
                                 self._gravity.copy(), mdot, np.array(self._flow), state0,
                                 description=(self._description(), bool(junction_forces)))
        system.check_constraints()
        return system

    def _description(self) -> dict:
        """The builder's plain data (bodies rebuild from their own description)."""
        return {k: copy.copy(v) for k, v in vars(self).items()}


def _rebuild_system(description, mass_flow):
    """A system built again from :meth:`MultibodySystem.__reduce__`'s description."""
    data, junction_forces = description
    b = MultibodyBuilder()
    vars(b).update(data)
    return b.build(mass_flow=mass_flow, junction_forces=junction_forces)


class MultibodySystem:
    """An immutable system of flexible bodies, joints and loads (evaluated by the C++
    ``_core.MultibodySystemCore``).

    Pickling and :func:`copy.deepcopy` rebuild the system from the builder's
    description (the compiled core is not picklable); ``mass_flow`` and ``info`` are kept.

    Attributes:
        bodies: the :class:`FlexibleBody` of each body; offsets: first coordinate of each.
        joints, loads, gravity [m/s^2], mass_flow mdot [kg/s], flow_factors.
        n_coordinates: N = sum(6 + m_j); n_constraints; n_dofs = N - n_constraints
            (independent coordinates: the size of the linearised problem).
        info: free-form description a scene attaches.
    """

    def __init__(self, core, bodies, offsets, joints, loads, gravity, mass_flow, flow_factors, state0, *,
                 description=None):
        self._description = description
        self._core = core
        self.bodies = bodies
        self.offsets = offsets
        self.joints = joints
        self.loads = loads
        self.gravity = gravity
        # the compiled system holds copies: editing these arrays would desynchronise it
        for a in (gravity, offsets, flow_factors):
            a.flags.writeable = False
        self.mass_flow = mass_flow
        self.flow_factors = flow_factors
        self._state0 = state0
        self.n_coordinates = int(offsets[-1])
        self.joint_rows = np.cumsum([0] + [j.rows for j in joints])
        self.n_constraints = int(self.joint_rows[-1])
        self.n_dofs = self.n_coordinates - self.n_constraints
        self.info: dict = {}

    def __reduce__(self):
        if self._description is None:
            raise TypeError("this MultibodySystem was not built by MultibodyBuilder.build: it cannot be pickled")
        return _rebuild_system, (self._description, self.mass_flow), {"info": self.info}

    @property
    def core(self):
        """The compiled system (read-only use)."""
        return self._core

    @property
    def spring_kinds(self) -> Tuple[str, ...]:
        """Per spring (the index :meth:`MultibodyBuilder.add_spring` or
        :meth:`MultibodyBuilder.add_ground_spring` returned): ``"axial"`` or ``"ground"``."""
        if self._description is None:
            return ()
        return tuple(sp["kind"] for sp in self._description[0].get("_springs", ()))

    # -- states --------------------------------------------------------------------
    def initial_state(self) -> MultibodyState:
        """The assembly configuration (eta = eta0) at rest."""
        return self._state0.copy()

    def body_index(self, body) -> int:
        """``body`` checked: an integer in [0, n_bodies) (ValueError otherwise)."""
        j = _checks.non_negative_int("body", body)
        if j >= len(self.bodies):
            raise ValueError(f"body must be in [0, {len(self.bodies)}), got {body!r}")
        return j

    def check_state(self, state: MultibodyState, name: str = "state") -> None:
        """Raise ValueError unless ``state`` fits this system: sizes, finite entries and
        orthonormal frame rotations (within 1e-6)."""
        nb, n, nc = len(self.bodies), self.n_coordinates, self.n_constraints
        shapes = dict(r=(nb, 3), R=(nb, 3, 3), eta=(n,), v=(n,), a=(n,), lam=(nc,))
        for attr, shape in shapes.items():
            x = np.asarray(getattr(state, attr))
            if x.shape != shape:
                raise ValueError(f"{name}.{attr} must have shape {shape} for this system, got {x.shape}")
            if not np.all(np.isfinite(x)):
                raise ValueError(f"{name}.{attr} must be finite")
        _checks.finite(f"{name}.t", state.t)
        err = np.abs(np.einsum("kji,kjl->kil", state.R, state.R) - np.eye(3)).max(initial=0.0)
        if err > 1e-6:
            raise ValueError(f"{name}.R must hold rotation matrices (R^T R = I), off by {err:.3g}")

    def body_slice(self, j: int) -> slice:
        """The coordinates [r, pi, eta] of body j in the stacked vectors."""
        j = self.body_index(j)
        return slice(int(self.offsets[j]), int(self.offsets[j + 1]))

    def eta(self, state: MultibodyState, j: int) -> np.ndarray:
        """The elastic coordinates of body j (a view into ``state.eta``)."""
        sl = self.body_slice(j)
        return state.eta[sl.start + 6:sl.stop]

    def node_kinematics(self, state: MultibodyState, body: int, node: int):
        """(position p [m], orientation A, Jp, Ja) of a node: dp = Jp dq_j, d alpha = Ja dq_j."""
        j = self.body_index(body)
        return self._core.node(state.r, state.R, state.eta, j, self.bodies[j].node_index(node))

    def node_position(self, state: MultibodyState, body: int, node) -> np.ndarray:
        """Global position [m] of a node (index or "start"/"center"/"end")."""
        return self.node_kinematics(state, body, node)[0]

    def centre_line(self, state: MultibodyState) -> List[np.ndarray]:
        """Per body, the (n_nodes, 3) global node positions [m]."""
        out = []
        for j, b in enumerate(self.bodies):
            U = (b.basis @ self.eta(state, j)).reshape(-1, 6)[:, :3]
            X = np.column_stack([b.nodes_s, np.zeros((b.n_nodes, 2))]) + U
            out.append(state.r[j] + X @ state.R[j].T)
        return out

    def increment(self, state: MultibodyState, dq: np.ndarray) -> None:
        """q <- q (+) dq in place: r += dr, R <- exp(dpi~) R, eta += deta."""
        for j in range(len(self.bodies)):
            o = int(self.offsets[j])
            state.r[j] += dq[o:o + 3]
            state.R[j] = rotation_exp(dq[o + 3:o + 6]) @ state.R[j]
            state.eta[o + 6:self.offsets[j + 1]] += dq[o + 6:self.offsets[j + 1]]

    # -- flow ----------------------------------------------------------------------
    def flow_speeds(self, mass_flow: float):
        """Per body the fluid speed sdot [m/s] for the mass flow mdot [kg/s]."""
        return [0.0 if b.section.fluid_mass <= 0.0 else f * mass_flow / b.section.fluid_mass
                for b, f in zip(self.bodies, self.flow_factors)]

    def flow_scale(self) -> float:
        """mdot_ref = (pi / L) sqrt(mu_f EI) [kg/s] of the flow-carrying bodies (as
        :meth:`pipeflex.Model.flow_scale` with k_v = 1)."""
        bs = [b for b, f in zip(self.bodies, self.flow_factors) if f != 0 and b.section.fluid_mass > 0]
        if not bs:
            raise ValueError("the system has no body that carries fluid")
        L = sum(b.length for b in bs)
        mf = sum(b.length * b.section.fluid_mass for b in bs) / L
        EI = sum(b.length * min(b.section.EI, b.section.EIz) for b in bs) / L
        return float(np.pi / L * np.sqrt(mf * EI))

    @property
    def total_mass(self) -> float:
        """Pipe + fluid mass of all bodies [kg]."""
        return float(sum(b.mass for b in self.bodies))

    @property
    def length_scale(self) -> float:
        """The model's size [m] (the Newton tests' scale): the largest extent of the
        assembly configuration along x, y or z, at least the longest body."""
        return float(self._core.length_scale)

    # -- equations -----------------------------------------------------------------
    def system(self, state: Optional[MultibodyState] = None) -> "_core.System":
        """The bodies as the core's one system object (``pipeflex._core.System``) on a copy
        of ``state`` (default: the assembly configuration at rest); the analyses run on it
        leave their end state in its ``body_state``."""
        st = self.initial_state() if state is None else state
        return _core.body_system(self._core, st.r, st.R, st.eta, st.v, st.a, st.lam, st.t)

    # The protocol of the analyses (pipeflex.analysis: one driver for every formulation; the
    # same methods on pipeflex.Model and pipeflex.CoupledSystem).

    def _system(self, state: Optional[MultibodyState] = None, *, mass_flow: Optional[float] = None) -> "_core.System":
        """The core system on a copy of ``state`` (a :class:`MultibodyState`, or a result
        holding one in ``body_state``, e.g. a steady rotation, or in ``state``, a static
        result; checked; None: the assembly configuration at rest); ``mass_flow`` mdot
        [kg/s] is the analyses' argument (the bodies' system holds no flow)."""
        if state is not None and not isinstance(state, MultibodyState):
            for name in ("body_state", "state"):  # (a static result's body_state is None)
                held = getattr(state, name, None)
                if isinstance(held, MultibodyState):
                    state = held
                    break
        if state is not None:
            self.check_state(state)
        return self.system(state)

    def _state_of(self, system) -> MultibodyState:
        """The end state of an analysis run on ``system`` (from :meth:`_system`)."""
        r, R, eta, v, a, lam, t = system.body_state
        return MultibodyState(np.array(r), np.array(R), np.array(eta), np.array(v), np.array(a), np.array(lam),
                              float(t))

    #: :func:`~pipeflex.linearize` without a state: about the static equilibrium (its
    #: multipliers balance its forces; others give a wrong K).
    _linearize_at_equilibrium = True

    def _gravity_rebuild(self):
        """(gravity g [m/s^2] (3,), rebuild(g) -> a copy of the system with gravity g), for
        continuation in the gravity; None if not built by MultibodyBuilder.build."""
        if self._description is None:
            return None
        data, junction_forces = self._description

        def rebuild(g):
            out = _rebuild_system(({**data, "_gravity": np.array(g, float)}, junction_forces), self.mass_flow)
            out.info = self.info
            return out

        return np.array(data["_gravity"], float), rebuild

    def _nodal_loads(self):
        """The loads as (point, force [N] (3,)), point = the node among the bodies' stacked
        nodes (as :meth:`centre_line`); a component given as a table or Sine counts 1."""
        first = np.cumsum([0] + [b.n_nodes for b in self.bodies])
        return [(int(first[ld.body] + ld.node), np.array([abs(c) if np.isscalar(c) else 1.0 for c in ld.force]))
                for ld in self.loads]

    def _with_body_load(self, spec: dict):
        """(a copy with the load ``spec`` = dict(body, node, force, moment) as its only load,
        the loaded point among the stacked nodes, the force [N] (3,)); ValueError if the
        system has loads or was not built by MultibodyBuilder.build."""
        if self._description is None:
            raise ValueError("load= needs a MultibodySystem built by MultibodyBuilder.build (its description is "
                             "rebuilt)")
        if self.loads:
            raise ValueError(f"load= adds the forced load to a system without loads, but this one has "
                             f"{len(self.loads)}: give the forcing as load_factor= (it scales all the system's "
                             "loads) instead")
        data, junction_forces = self._description
        b = MultibodyBuilder()
        vars(b).update(copy.deepcopy(data))
        force = np.asarray(spec.get("force", (0.0, 0.0, 0.0)), float)
        b.add_load(spec["body"], spec["node"], force=tuple(force), moment=tuple(spec.get("moment", (0.0, 0.0, 0.0))))
        out = b.build(mass_flow=self.mass_flow, junction_forces=junction_forces)
        out.info.update(self.info)
        ld = out.loads[0]
        return out, int(sum(bd.n_nodes for bd in out.bodies[:ld.body]) + ld.node), force

    def _linearization(self, system, mass_flow: float, mass_flow_rate: float = 0.0) -> dict:
        """:func:`~pipeflex.linearize`'s fields for ``system`` at mdot [kg/s] ``mass_flow``
        changing at ``mass_flow_rate`` [kg/s^2]: the core's linear matrices reduced to the joints' null space."""
        from ..analysis.linearize import constrained_fields

        out = _core.linear_matrices(system, mass_flow, mass_flow_rate=mass_flow_rate)
        return constrained_fields(out, mass_flow, self._state_of(system))

    def _equilibrium_state(self, result):
        """The state a static result holds (what :meth:`_system` takes): its ``state``."""
        return result.state

    def _flow_residual(self, state: MultibodyState, mass_flow: float, mass_flow_rate: float) -> np.ndarray:
        """The residual F (N,) [N, N m, ...] at ``state`` under the full loads with mdot
        [kg/s] ``mass_flow`` changing at ``mass_flow_rate`` [kg/s^2] (:meth:`evaluate`; the
        parametric analysis differences it in the flow)."""
        return np.asarray(self.evaluate(state, mass_flow=mass_flow, mass_flow_rate=mass_flow_rate, tangent=False,
                                        jacobian=False)[0])

    def _zero_flow_growth_hint(self) -> str:
        """Why a mode may grow from the first flow on, for :func:`~pipeflex.critical_mass_flow`'s
        error: ''."""
        return ""

    def _rotation_hinge(self):
        """:func:`~pipeflex.steady_rotation`'s hinge: (name, point [m], axis, body, -1, -1) of
        the one body hinged to the ground."""
        from ..analysis.steady import hinge_of

        return hinge_of(type(self).__name__, bodies=self)

    def _steady_rotation_parts(self, state: MultibodyState) -> dict:
        """:class:`~pipeflex.SteadyRotation`'s fields of the end ``state`` (from
        :meth:`_state_of`): no element state, the bodies' state."""
        return dict(state=None, body_state=state)

    def _check_transient(self) -> None:
        """Nothing: :func:`~pipeflex.simulate` integrates every system of bodies."""

    def _transient_parts(self, out: dict, system, stats: dict, metadata: dict) -> dict:
        """:class:`~pipeflex.TransientResult`'s fields from the core's record ``out`` of a run
        on ``system``: the bodies' motion in ``bodies`` (its accessors also on the result)
        and the end state; ``stats`` get the step (the bodies' results have said it there)."""
        stats["step"] = metadata["step"]
        return dict(t=out["t"], final_state=self._state_of(system), bodies=body_motion(self, out, stats))

    @property
    def n_nodes(self) -> int:
        """Nodes of all bodies."""
        return sum(b.n_nodes for b in self.bodies)

    def _orbit_chart(self, base: Optional[MultibodyState]):
        """The periodic orbits' chart about ``base`` (None: the assembly at rest): per body
        r - r_base, log(R R_base^T), eta - eta_base."""
        from ..charts import BodyChart

        return BodyChart(self, self.initial_state() if base is None else base)

    def _static_start(self, state: Optional[MultibodyState]) -> MultibodyState:
        """The static driver's working state: a copy of ``state`` (checked; None: the
        assembly) at rest, the loads at its time ``t``."""
        if state is not None:
            self.check_state(state)
        st = self.initial_state() if state is None else state.copy()
        st.v[:] = 0.0
        st.a[:] = 0.0
        return st

    def _static_newton(self, state, solve, *, mass_flow, load_factor, max_iterations, start=None) -> dict:
        """One static Newton from ``state`` (updated in place): statics.static_newton."""
        return static_newton(self, state, solve, mass_flow=mass_flow, load_factor=load_factor,
                             max_iterations=max_iterations, start=start)

    def _static_increment(self, start: MultibodyState, end: MultibodyState) -> np.ndarray:
        """The increment from ``start`` to ``end`` in the core's chart (origins, spatial
        rotation vectors log(R R0^T), elastic coordinates): the continuation's secant."""
        dq = np.array(end.eta, float) - np.array(start.eta, float)
        for j in range(len(self.bodies)):
            o = int(self.offsets[j])
            dq[o:o + 3] = np.asarray(end.r[j]) - np.asarray(start.r[j])
            dq[o + 3:o + 6] = rotation_log(np.asarray(end.R[j]) @ np.asarray(start.R[j]).T)
        return dq

    def _static_failure(self, out, *, load_factor, mass_flow, reached, ramp, halvings, max_iterations,
                        earlier) -> Exception:
        """The error of a load stepping whose step failed with ``out``: statics.static_failure."""
        return static_failure(self, out, load_factor=load_factor, mass_flow=mass_flow, max_iterations=max_iterations,
                              earlier=earlier)

    def _static_result(self, state: MultibodyState, *, iterations, residual, mass_flow, limit_points=()):
        """The StaticResult of the equilibrium ``state`` (its residual: the largest entry [N])."""
        from ..analysis.static import StaticResult

        F = self.evaluate(state, mass_flow=mass_flow, tangent=False, jacobian=False)[0]
        return StaticResult(state, iterations, float(np.abs(F).max()), mass_flow, limit_points)

    def evaluate(self, state: MultibodyState, *, mass_flow: float, mass_flow_rate: float = 0.0,
                 load_factor: float = 1.0, gravity_factor: float = 1.0, wK: float = 1.0, wC: float = 0.0,
                 wM: float = 0.0, tangent: bool = True, jacobian: bool = True):
        """(F, c, C_q, S): residual F = body forces - loads + C_q^T lambda (N,) [N, N m, and
        N m per elastic coordinate unit], the constraint equations c (n_constraints,) [m,
        rad], their Jacobian and the tangent S = wK dF/dq + wC dF/dv + wM dF/da (dF/dq
        includes the joint reactions' and the loads' geometric stiffness; None unless
        ``tangent``), at ``state`` (time state.t [s]) with the mass flow ``mass_flow`` mdot
        [kg/s] changing at ``mass_flow_rate`` [kg/s^2]; loads and gravity scaled by
        ``load_factor`` and ``gravity_factor``. ``jacobian=False``: C_q is None (dense, it
        is quadratic in the number of bodies; :meth:`constraints` gives it sparse)."""
        return self._core.evaluate(state.r, state.R, state.eta, state.v, state.a, state.lam, state.t, mass_flow,
                                   mass_flow_rate, load_factor, gravity_factor, wK, wC, wM, tangent, jacobian)

    def constraints(self, state: MultibodyState, *, sparse: bool = False):
        """(c (n_constraints,), C_q (n_constraints x N)) at ``state``; ``sparse``: C_q as a
        scipy CSC matrix (its size is linear in the number of bodies, the dense one's
        quadratic)."""
        if sparse:
            c, J = self._core.constraints(state.r, state.R, state.eta, state.t)
            return c, J
        _, c, J, _ = self.evaluate(state, mass_flow=0.0, tangent=False)
        return c, J

    def check_constraints(self) -> None:
        """Raise ValueError for redundant joint equations (rank-deficient C_q)."""
        if self.n_constraints > self.n_coordinates:
            raise ValueError(f"{self.n_constraints} constraint equations for {self.n_coordinates} coordinates")
        _, Js = self.constraints(self._state0, sparse=True)
        scale = np.maximum(abs(Js).max(axis=1).toarray().ravel(), 1e-300)
        if _full_row_rank(_sparse_rows_scaled(Js, 1.0 / scale)):
            return
        J = Js.toarray() / scale[:, None]
        tol = 1e-9 * np.sqrt(J.shape[1])
        for k, jt in enumerate(self.joints):  # rank deficient: name the first redundant joint
            sub = J[:self.joint_rows[k + 1]]
            r = np.linalg.matrix_rank(sub, tol=tol)
            if r < self.joint_rows[k + 1]:
                raise ValueError(f"{jt.name} is redundant: {self.joint_rows[k + 1] - r} of its equations repeat "
                                 "constraints already imposed by the joints before it")

    def save(self, path):
        """Write the system as a model file (``kind: multibody``), YAML (``.yaml``,
        ``.yml``) or JSON (``.json``) by the suffix of ``path`` [-] (its folder must exist;
        schema in docs/model_files.md): the file :func:`pipeflex.save_model` writes, from
        the description the builder kept. Returns the path. ValueError for what a file
        cannot hold (a body with a custom basis, springs, a system not built by
        :meth:`MultibodyBuilder.build`)."""
        from ..model_writer import multibody_data, write

        return write(multibody_data(self, flexible_body), path)

    def energy(self, state: MultibodyState) -> float:
        """Kinetic + elastic (bodies, springs, foundations) + gravitational potential
        energy [J] (no flow; the loads' work is not in it)."""
        self.check_state(state)
        E = 0.0
        for j, b in enumerate(self.bodies):
            sl = self.body_slice(j)
            R = state.R[j]
            v = state.v[sl]
            vl = np.concatenate([R.T @ v[:3], R.T @ v[3:6], v[6:]])
            e = self.eta(state, j) - b.eta0
            E += 0.5 * vl @ b.data.M @ vl + 0.5 * e @ b.data.K @ e
            # gravity: V = -m g.r - (R^T g).(int mu N ds) eta; the straight reference is centred
            E -= b.mass * self.gravity @ state.r[j] + (R.T @ self.gravity) @ (b.data.Ng[6:].T @ self.eta(state, j))
            if b.foundation is not None:
                E += _foundation_energy(b.foundation, state.r[j], R, self._state0.r[j], self._state0.R[j],
                                        self.eta(state, j))
        return float(E + self.spring_energy(state)[0])

    def spring_energy(self, state: MultibodyState):
        """(U [J], P [W]): the springs' elastic energy at ``state`` (part of :meth:`energy`)
        and the power their dashpots dissipate, P = sum c l_dot^2 (axial) or
        sum c_i v_i^2 + c_phi,i w_i^2 (ground) >= 0."""
        self.check_state(state)
        U, P = self._core.spring_energy(state.r, state.R, state.eta, state.v)
        return float(U), float(P)


def _foundation_energy(f: dict, r, R, r_ref, R_ref, eta) -> float:
    """V = k/2 int (r(s) - r_ref(s))^2 ds [J] of a body's Winkler foundation (constants f,
    FlexibleBody.foundation) at frame r [m], R and elastic coordinates eta, the reference
    placement r_ref, R_ref (ffrf_body.hpp, FfrfFoundation)."""
    p, Q = R.T @ (r - r_ref), R.T @ R_ref
    Xi = f["X"] + f["XPhi"] @ eta
    W = f["W0"] + (f["C"].T @ eta).reshape(3, 3)
    return float(0.5 * f["kL"] * p @ p + p @ (Xi - Q @ f["X0"])
                 + 0.5 * (f["xx"] + 2.0 * f["x"] @ eta + eta @ f["K"] @ eta) - np.sum(Q * W) + 0.5 * f["x0x0"])


def _sparse_rows_scaled(J, factors):
    import scipy.sparse as sp

    return sp.diags(factors) @ J


def _full_row_rank(J) -> bool:
    """Whether the row-scaled constraint Jacobian has full row rank, from the pivots of the
    sparse LU of its Gram matrix J J^T (banded for a chain: linear in the number of
    bodies, where a dense rank is cubic: 0.7 s at 192 bodies). Redundant equations leave
    a pivot at round-off; the dense rank, which names the redundant joint, runs only then."""
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

    if J.shape[0] == 0:
        return True
    Js = sp.csr_matrix(J)
    try:
        pivots = np.abs(spla.splu((Js @ Js.T).tocsc()).U.diagonal())
    except RuntimeError:  # exactly singular
        return False
    return bool(pivots.min() > 1e-12 * pivots.max())


@dataclass(frozen=True)
class MultibodyResult(Result):
    """A multibody transient, with the layout of the system's coordinates that its
    methods need.

    Attributes:
        t: (n_out,) output times [s]; r: (n_out, n_bodies, 3) frame origins [m], R:
        (n_out, n_bodies, 3, 3) frame rotations [-]; eta: (n_out, N) elastic coordinates
        (frame entries zero); v: (n_out, N) velocities [m/s, rad/s, ...]; drift: (n_out,)
        ``max abs(C_q v)`` [m/s] (velocity-level constraint drift; positions are
        enforced); offsets: (n_bodies + 1,) first coordinate of each body (as
        :attr:`MultibodySystem.offsets`); n_constraints: number of constraint equations;
        nodes_s: per body, its node coordinates s [m]; bases: per body, its reduction
        basis Phi (6 n_nodes x m) [-]; stats: the integrator's counters
        (:data:`pipeflex.results.COUNTERS`: steps, newton_iterations, jacobians, ...),
        wall_time [s], step (the step used [s]: the interval divided into whole steps).
    """

    t: np.ndarray
    r: np.ndarray
    R: np.ndarray
    eta: np.ndarray
    v: np.ndarray
    drift: np.ndarray
    offsets: np.ndarray
    n_constraints: int
    nodes_s: Tuple[np.ndarray, ...]
    bases: Tuple[np.ndarray, ...]
    stats: dict = field(default_factory=dict)

    @property
    def n_coordinates(self) -> int:
        """N = sum(6 + m_j) stacked coordinates."""
        return int(self.offsets[-1])

    def _body(self, body) -> int:
        j = _checks.non_negative_int("body", body)
        if j >= len(self.nodes_s):
            raise ValueError(f"body must be in [0, {len(self.nodes_s)}), got {body!r}")
        return j

    def state(self, k: int) -> MultibodyState:
        """The k-th output as a state (accelerations and multipliers not kept: zero)."""
        return MultibodyState(self.r[k].copy(), self.R[k].copy(), self.eta[k].copy(), self.v[k].copy(),
                              np.zeros_like(self.v[k]), np.zeros(self.n_constraints), float(self.t[k]))

    def node_position(self, body: int, node) -> np.ndarray:
        """(n_out, 3) global position [m] of a node (index or "start"/"center"/"end"):
        r + R (x + Phi_u eta)."""
        j = self._body(body)
        i = node_index(len(self.nodes_s[j]) - 1, node)
        o, e = int(self.offsets[j]), int(self.offsets[j + 1])
        x = np.array([self.nodes_s[j][i], 0.0, 0.0]) + self.eta[:, o + 6:e] @ self.bases[j][6 * i:6 * i + 3].T
        return self.r[:, j] + np.einsum("kij,kj->ki", self.R[:, j], x)

    def angular_velocity(self, body: int) -> np.ndarray:
        """(n_out, 3) global angular velocity [rad/s] of a body's frame."""
        o = int(self.offsets[self._body(body)])
        return self.v[:, o + 3:o + 6]

    def node_angular_velocity(self, body: int, node) -> np.ndarray:
        """(n_out, 3) global angular velocity [rad/s] of a node: omega + R Phi_theta eta_dot
        (small nodal rotations)."""
        j = self._body(body)
        i = node_index(len(self.nodes_s[j]) - 1, node)
        Pt = self.bases[j][6 * i + 3:6 * i + 6]
        ed = self.v[:, int(self.offsets[j]) + 6:int(self.offsets[j + 1])]
        return self.angular_velocity(j) + np.einsum("kij,kj->ki", self.R[:, j], ed @ Pt.T)


def body_motion(system: MultibodySystem, out: dict, stats: dict, prefix: str = "") -> MultibodyResult:
    """The bodies' motion in the core's record ``out`` of a run (their entries named with
    ``prefix``: "body_" in a coupled run), with the layout of ``system``'s coordinates."""
    return MultibodyResult(out["t"].copy(), out[prefix + "r"], out[prefix + "R"], out[prefix + "eta"],
                           out[prefix + "v"], out[prefix + "drift"], np.array(system.offsets), system.n_constraints,
                           tuple(np.array(b.nodes_s) for b in system.bodies),
                           tuple(np.array(b.basis) for b in system.bodies), stats)
