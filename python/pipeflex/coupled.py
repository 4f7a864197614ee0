"""Element models and floating-frame bodies in one system.

A :class:`CoupledSystem` joins a :class:`~pipeflex.Model` (pipe elements) and a
:class:`~pipeflex.multibody.MultibodySystem` (floating-frame bodies and their joints) by
Lagrange-multiplier joints between element frame nodes and body nodes, the bodies' own
joint equations (rigid, hinge, spherical) with the element node as node a:

    R_el(q_el, v_el, a_el) + C_el^T lambda_c = 0
    F_b(q_b, v_b, a_b) + C_b^T lambda_b + C_cb^T lambda_c = 0
    c_b(q_b) = 0,  c_c(q_el, q_b) = 0.

It is integrated by the project's one generalised-alpha integrator (the index-3 form:
positions constrained exactly), the same that integrates element models and bodies
alone: :func:`pipeflex.simulate` (:func:`simulate` here is its alias with this module's
start states).

Coordinates: the element model's reduced coordinates, then the bodies' (body after body);
multipliers: the bodies' joints, then the couplings (:attr:`pipeflex.TransientResult.coupling_forces`).
A planar ANCF node is clamped to a body node in the x-y plane (3 rows: its position, and
its slope's direction; the slope's length, the root's axial strain, stays free), so a
rotating ANCF beam can hang on a hub body with inertia and a motor torque instead of a
prescribed hub angle.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import List, Optional, Sequence, Tuple

import numpy as np

from . import _checks, _core
from .analysis.linearize import Linearization, constrained_fields, linearize as _linearize
from .analysis.static import StaticResult
from .analysis.transient import TransientResult, simulate as _simulate
from ._options import MAX_NEWTON, MAX_STEPS, NEWTON_TOL, RHO_INF
from .model import Model, ModelBuilder
from .multibody.system import body_motion
from .multibody.system import MultibodyState, MultibodySystem
from .errors import ConvergenceError, SingularMatrixError
from .results import Result
from .state import State, as_core

KINDS = ("rigid", "hinge", "spherical")


@dataclass(frozen=True)
class CouplingJoint:
    """A joint between element node ``node`` and node ``body_node`` of body ``body``:
    ``kind`` "rigid" (no jump in position or orientation), "hinge" (free rotation about
    ``axis``, a global unit vector in the assembly configuration) or "spherical"."""

    kind: str
    node: int
    body: int
    body_node: int
    axis: Optional[Tuple[float, float, float]] = None
    # the axis as passed, which a model file writes (normalising twice may change the last bit)
    given_axis: Optional[Tuple[float, float, float]] = field(default=None, compare=False, repr=False)


class CoupledSystem:
    """An element model and a multibody system joined at nodes (see the module doc).

    Args:
        model: the element model (its supports stay; the coupled nodes are usually free).
        bodies: the floating-frame bodies with their own joints (at least one joint to the
            ground, or a coupling, must hold the whole at rest).

    Joints are added with :meth:`rigid`, :meth:`hinge` and :meth:`spherical`; the nodes
    joined must coincide in the assembly configuration.
    """

    def __init__(self, model: Model, bodies: MultibodySystem) -> None:
        if not isinstance(model, Model):
            raise ValueError("model must be a pipeflex.Model (elements)")
        if not isinstance(bodies, MultibodySystem):
            raise ValueError("bodies must be a pipeflex.multibody.MultibodySystem")
        self.model = model
        self.bodies = bodies
        self._joints: List[CouplingJoint] = []
        # add_spring, add_bushing: dict(kind "axial" / "bushing", node, body, body_node, k, c
        # (, k_phi, c_phi))
        self._springs: List[dict] = []

    @property
    def mass_flow(self) -> float:
        """mdot [kg/s] of the analyses by default: the element model's."""
        return self.model.mass_flow

    @property
    def joints(self) -> Tuple[CouplingJoint, ...]:
        return tuple(self._joints)

    def rigid(self, node: int, body: int, body_node="start") -> None:
        """Rigid joint: element node ``node`` moves and turns with the body node. An ANCF
        node (planar beams) is clamped in the x-y plane: its position and its slope's
        direction move with the body node, the slope's length (the axial strain) stays
        free."""
        self._add("rigid", node, body, body_node)

    def hinge(self, node: int, body: int, body_node, axis: Sequence[float]) -> None:
        """Hinge about ``axis`` (global unit vector in the assembly configuration)."""
        self._add("hinge", node, body, body_node, tuple(_checks.unit_vector("axis", axis)),
                  tuple(float(x) for x in _checks.vector3("axis", axis)))

    def spherical(self, node: int, body: int, body_node="start") -> None:
        """Spherical joint: equal positions, free relative rotation."""
        self._add("spherical", node, body, body_node)

    def _ends(self, node, body, body_node):
        """(element node, body, body node) of a spring-damper, checked, as indices."""
        n = _checks.non_negative_int("node", node)
        if n >= self.model.n_nodes:
            raise ValueError(f"node must be a node of the element model, in [0, {self.model.n_nodes}), got {node}")
        j = self.bodies.body_index(body)
        try:
            i = self.bodies.bodies[j].node_index(body_node)
        except ValueError as e:
            raise ValueError(f"body_node: {e}") from None
        return n, j, i

    def add_spring(self, node: int, body: int, body_node, *, stiffness: float, damping: float = 0.0) -> int:
        """A linear axial spring-damper between element node ``node`` and node ``body_node``
        of body ``body`` (the element models' axial spring,
        :meth:`pipeflex.ModelBuilder.add_spring`): massless, unstressed at their distance
        L0 in the assembly configuration (they must not coincide), axial force
        T = k (l - L0) + c dl/dt along the line between them; no constraint. Exact
        tangents (through the body's node map). Ground springs belong to the parts
        (:meth:`pipeflex.ModelBuilder.add_ground_spring`,
        :meth:`pipeflex.multibody.MultibodyBuilder.add_ground_spring`). Returns its index
        among these springs.

        Args:
            node: the element node (frame or ANCF) [-].
            body: the body [-]; body_node: its node (index or "start", "center", "end").
            stiffness: k [N/m] >= 0.
            damping: c [N s/m] >= 0.
        """
        n, j, i = self._ends(node, body, body_node)
        k = _checks.non_negative("stiffness", stiffness)
        c = _checks.non_negative("damping", damping)
        p_el = np.asarray(self.model.positions[n], float)
        p_b = self.bodies.node_kinematics(self.bodies.initial_state(), j, i)[0]
        if not np.linalg.norm(p_b - p_el) > 0.0:
            raise ValueError(f"element node {n} and body {j} node {i} coincide in the assembly configuration: an axial "
                             "spring of zero length has no axis")
        self._springs.append(dict(kind="axial", node=n, body=j, body_node=i, k=k, c=c))
        return len(self._springs) - 1

    def add_bushing(self, node: int, body: int, body_node, *, stiffness: Sequence[float] = (0.0, 0.0, 0.0),
                    damping: Sequence[float] = (0.0, 0.0, 0.0),
                    rotational_stiffness: Sequence[float] = (0.0, 0.0, 0.0),
                    rotational_damping: Sequence[float] = (0.0, 0.0, 0.0)) -> int:
        """A linear 6-DOF spring-damper (bushing) between element node ``node`` (node a) and
        node ``body_node`` of body ``body`` (node b), the element models' bushing
        (:meth:`pipeflex.ModelBuilder.add_bushing`): massless, the nodes may coincide. Force
        on the body node -K (p_b - x_a - d0) - C (v_b - v_a), its opposite on the element
        node (d0 their offset in the assembly configuration; K = diag(kx, ky, kz),
        C = diag(cx, cy, cz) along the global axes), and moment on the body node
        -T(psi)^-T K_phi psi - C_phi (w_b - w_a), its opposite on the element node, psi the
        rotation vector of their relative rotation from the assembly configuration
        (``|psi| < pi``), w their angular velocities, K_phi and C_phi about the global
        axes. No constraint; exact tangents (through the body's node map). Returns its
        index among the couplings' springs (with :meth:`add_spring`'s).

        Args:
            node: the element node [-] (frame node; an ANCF node takes the translational
                part only).
            body: the body [-]; body_node: its node (index or "start", "center", "end").
            stiffness: (kx, ky, kz) [N/m] >= 0 each.
            damping: (cx, cy, cz) [N s/m] >= 0 each.
            rotational_stiffness: k_phi (3) [N m/rad] >= 0 each, about the global axes.
            rotational_damping: c_phi (3) [N m s/rad] >= 0 each, about the global axes.
        """
        from .model import ModelBuilder

        n, j, i = self._ends(node, body, body_node)
        k, c, kr, cr = (ModelBuilder._non_negative3(name, v, unit) for name, v, unit in
                        (("stiffness", stiffness, "N/m"), ("damping", damping, "N s/m"),
                         ("rotational_stiffness", rotational_stiffness, "N m/rad"),
                         ("rotational_damping", rotational_damping, "N m s/rad")))
        if not (k.any() or c.any() or kr.any() or cr.any()):
            raise ValueError("a bushing needs a stiffness or a damping > 0 in some direction, got all zero")
        if (kr.any() or cr.any()) and self._ancf(n):
            raise ValueError(f"node {n} is an ANCF node: it has no rotation, so rotational_stiffness and "
                             f"rotational_damping must be 0 for a bushing there")
        self._springs.append(dict(kind="bushing", node=n, body=j, body_node=i, k=k, c=c, k_phi=kr, c_phi=cr))
        return len(self._springs) - 1

    def save(self, path):
        """Write the system as a model file (``kind: coupled``), YAML (``.yaml``, ``.yml``)
        or JSON (``.json``) by the suffix of ``path`` [-] (its folder must exist; schema in
        docs/model_files.md): the file :func:`pipeflex.save_model` writes. Returns the
        path. ValueError for what a file cannot hold (springs, a load function, a body
        with a custom basis), or element builder calls in an order the file cannot keep."""
        from .model_writer import save_coupled
        from .multibody.body import flexible_body

        return save_coupled(self, path, ModelBuilder, flexible_body)

    def _add(self, kind, node, body, body_node, axis=None, given_axis=None) -> None:
        n = _checks.non_negative_int("node", node)
        if n >= self.model.n_nodes:
            raise ValueError(f"node must be a node of the element model, in [0, {self.model.n_nodes}), got {node}")
        if n in set(self.model.ancf_nodes or ()) and kind != "rigid":
            raise ValueError(f"node {n} is an ANCF node: it can only be clamped to a body node (rigid)")
        j = self.bodies.body_index(body)
        i = self.bodies.bodies[j].node_index(body_node)
        p_el = np.asarray(self.model.positions[n], float)
        p_b = self.bodies.node_kinematics(self.bodies.initial_state(), j, i)[0]
        gap = float(np.linalg.norm(p_el - p_b))
        if gap > 1e-9 * max(1.0, float(np.linalg.norm(p_el))):
            raise ValueError(f"{kind} coupling of element node {n} and body {j} node {i}: the nodes do not coincide "
                             f"in the assembly configuration (gap {gap:.3g} m)")
        self._joints.append(CouplingJoint(kind, n, j, i, axis, given_axis))

    def core_couplings(self) -> list:
        """The couplings as the core takes them: (node, kind, body, body node, C0, axis_b,
        perp0, perp1), with the reference orientations of the assembly configuration; then
        the springs, (node, 3, body, body node, k, c, p0 of the node, p0 of the body node),
        and bushings, (node, 4, body, body node, k, c, k_phi, c_phi, p0 of the node, p0 of
        the body node, A0 of the body node)."""
        st0 = as_core(self.model, None)
        b0 = self.bodies.initial_state()
        out = []
        for c in self._joints:
            Aa = st0.rotation(c.node)
            Ab = self.bodies.node_kinematics(b0, c.body, c.body_node)[1]
            axis_b, perp = np.array([0.0, 0.0, 1.0]), np.zeros((2, 3))
            if self._ancf(c.node):  # the slope's direction, in the body node's frame
                slope = np.array(st0.q[6 * c.node + 3:6 * c.node + 6])
                axis_b = Ab.T @ (slope / np.linalg.norm(slope))
            elif c.kind == "hinge":
                ax = np.asarray(c.axis)
                axis_b = Ab.T @ ax
                perp = (Aa.T @ np.linalg.svd(ax.reshape(1, 3))[2][1:].T).T
            out.append((c.node, KINDS.index(c.kind), c.body, c.body_node, Aa.T @ Ab, axis_b, perp[0], perp[1]))
        for sp in getattr(self, "_springs", ()):  # after the joints: they add no constraint rows
            n, j, i = sp["node"], sp["body"], sp["body_node"]
            p_b, A_b = self.bodies.node_kinematics(b0, j, i)[:2]
            p_n = np.asarray(self.model.positions[n], float)
            if sp["kind"] == "axial":
                out.append((n, 3, j, i, sp["k"], sp["c"], p_n, p_b))
            else:
                out.append((n, 4, j, i, sp["k"], sp["c"], sp["k_phi"], sp["c_phi"], p_n, p_b, A_b))
        return out


    @property
    def n_coordinates(self) -> int:
        return self.model.n_dofs + self.bodies.n_coordinates

    def system(self, state=None, body_state: Optional[MultibodyState] = None, coupling_forces=None, *,
               mass_flow: Optional[float] = None) -> "_core.System":
        """The coupled system as the core's one system object (``pipeflex._core.System``):
        the element model on ``state`` (a core State, updated in place by the analyses run
        on it; default the reference configuration), the bodies on a copy of ``body_state``
        (default their assembly configuration at rest) and the couplings' multipliers
        ``coupling_forces`` (a guess; default zero), with mdot [kg/s] ``mass_flow`` (default
        the element model's) for the loads that depend on it."""
        bs = self.bodies.initial_state() if body_state is None else body_state
        lam_c = np.zeros(0) if coupling_forces is None else np.asarray(coupling_forces, float)
        return _core.coupled_system(self.model.core, self.model.initial_state() if state is None else state,
                                    self.model.load_state(mass_flow=mass_flow), self.bodies.core, bs.r, bs.R, bs.eta,
                                    bs.v, bs.a, bs.lam, bs.t, self.core_couplings(), lam_c)

    # The protocol of the analyses (pipeflex.analysis: one driver for every formulation; the
    # same methods on pipeflex.Model and pipeflex.multibody.MultibodySystem).

    def _system(self, state=None, *, mass_flow: Optional[float] = None) -> "_core.System":
        """The core system on a copy of ``state``: a :class:`CoupledState`, or a result that
        holds one (a :class:`CoupledStatic`, a steady rotation's ``SystemSteadyRotation``:
        their ``state``, ``body_state`` and ``coupling_forces``); None: the assembly
        configuration at rest. mdot [kg/s] ``mass_flow`` (None: the model's) for the loads
        that depend on it."""
        if state is None:
            st, bs, lam_c = as_core(self.model, None), None, None
        elif all(hasattr(state, k) for k in ("state", "body_state", "coupling_forces")) and state.state is not None:
            self.bodies.check_state(state.body_state, "state.body_state")
            st, bs, lam_c = as_core(self.model, state.state), state.body_state, state.coupling_forces
        else:
            raise TypeError(f"state of a CoupledSystem must be a CoupledStatic or a SystemSteadyRotation (results of "
                            f"pipeflex.static_equilibrium and pipeflex.steady_rotation on it) or a CoupledState, got "
                            f"{type(state).__name__}")
        return self.system(st, bs, lam_c, mass_flow=mass_flow)

    def _state_of(self, system) -> "CoupledState":
        """The end state of an analysis run on ``system`` (from :meth:`_system`)."""
        r, R, eta, v, a, lam, t = system.body_state
        bs = MultibodyState(np.array(r), np.array(R), np.array(eta), np.array(v), np.array(a), np.array(lam), float(t))
        return CoupledState(State.from_core(system.element_state, self.model), bs,
                            np.array(system.coupling_multipliers, float))

    #: :func:`~pipeflex.linearize` without a state: about the static equilibrium (its
    #: multipliers balance its forces; others give a wrong K).
    _linearize_at_equilibrium = True

    def _gravity_rebuild(self):
        """(gravity g [m/s^2] (3,), rebuild(g) -> a copy with gravity g in its element model
        and its bodies, the same couplings and springs), for continuation in the gravity;
        None if a part was not built by its builder; ValueError if the parts' gravities differ."""
        g_model, g_bodies = np.asarray(self.model.gravity, float), np.asarray(self.bodies.gravity, float)
        if not np.array_equal(g_model, g_bodies):
            raise ValueError(f"continuation in the gravity sets the gravity of the coupled system's element model "
                             f"and of its bodies, which differ ({g_model.tolist()} and {g_bodies.tolist()} m/s^2): "
                             "give a callable rebuild(value) -> system instead")
        parts = self.model._gravity_rebuild(), self.bodies._gravity_rebuild()
        if parts[0] is None or parts[1] is None:
            return None
        (_, model_at), (_, bodies_at) = parts

        def rebuild(g):
            out = CoupledSystem(model_at(g), bodies_at(g))
            out._joints = list(self._joints)  # the same nodes: the couplings hold as they are
            out._springs = list(self._springs)
            return out

        return g_model, rebuild

    def _nodal_loads(self):
        """The loads as (point, force [N] (3,)): the element model's (point = node), then
        the bodies' after the element nodes; None if a part's are unknown."""
        parts = self.model._nodal_loads(), self.bodies._nodal_loads()
        if parts[0] is None or parts[1] is None:
            return None
        return parts[0] + [(self.model.n_nodes + k, f) for k, f in parts[1]]

    def _linearization(self, system, mass_flow: float, mass_flow_rate: float = 0.0) -> dict:
        """:func:`~pipeflex.linearize`'s fields for ``system`` at mdot [kg/s] ``mass_flow``
        changing at ``mass_flow_rate`` [kg/s^2]: the core's linear matrices reduced to the joints' and couplings' null space."""
        out = _core.linear_matrices(system, mass_flow, mass_flow_rate=mass_flow_rate)
        return constrained_fields(out, mass_flow, self._state_of(system))

    def _equilibrium_state(self, result):
        """The state a static result holds (what :meth:`_system` takes): a
        :class:`CoupledStatic` holds every part and multiplier itself."""
        return result

    def _flow_residual(self, state, mass_flow: float, mass_flow_rate: float) -> np.ndarray:
        """The element model's residual, then the bodies' [N, N m, ...] at ``state`` (a
        :class:`CoupledState`) under the full loads with mdot [kg/s] ``mass_flow`` changing
        at ``mass_flow_rate`` [kg/s^2], without the couplings' forces C_c^T lambda_c: they
        do not depend on the flow, and the parametric analysis differences this in the flow."""
        return np.concatenate([self.model._flow_residual(state.state, mass_flow, mass_flow_rate),
                               self.bodies._flow_residual(state.body_state, mass_flow, mass_flow_rate)])

    def _zero_flow_growth_hint(self) -> str:
        """The element inlets joined to bodies, named as a likely cause of a growth that
        starts with the flow, for :func:`~pipeflex.critical_mass_flow`'s error ('' if none).

        Why: the unsplit element's inlet end term is the force that accelerates the incoming
        fluid to the inlet's velocity v (docs/theory.md), which does the work mdot |v|^2 on
        the pipe: a mode that moves the inlet gains energy at a rate proportional to the flow.
        A clamped inlet never moves; one held by a body that carries no fluid moves with the
        body's modes, e.g. a stiff hub's (9e4 to 3e9 rad/s) grow at Re lambda = 2.6e-3 to
        3.1e-3 1/s per kg/s (measured from 0.003 to 24 kg/s, the same for hubs 1e2 to 1e6
        times stiffer): the model is unstable from the first flow, not at round-off."""
        ends = [e.nodes if e.flow_factor > 0 else e.nodes[::-1] for e in self.model.elements
                if e.kind == "pipe" and e.flow_factor != 0 and e.section.fluid_mass > 0]
        outlets = {q for _, q in ends}
        inlets = sorted({j.node for j in self.joints if any(p == j.node for p, _ in ends) and j.node not in outlets})
        if not inlets:
            return ""
        return (f"; element node(s) {', '.join(map(str, inlets))}, an inlet of the flow, move(s) with a body: the "
                "inlet end term (the force accelerating the incoming fluid to the inlet's velocity) feeds every mode "
                "that moves the inlet, at a rate proportional to the flow. Where the fluid comes from a still "
                "reservoir, mark the inlet with ModelBuilder.reservoir_inlet(node) (docs/theory.md)")

    def _rotation_hinge(self):
        """:func:`~pipeflex.steady_rotation`'s hinge: (name, point [m], axis, body or -1, -1,
        element coordinate or -1) of the one body hinged to the ground or element hinge."""
        from .analysis.steady import hinge_of

        return hinge_of(type(self).__name__, bodies=self.bodies, model=self.model)

    def _steady_rotation_parts(self, state: "CoupledState") -> dict:
        """:class:`~pipeflex.SteadyRotation`'s fields of the end ``state`` (from
        :meth:`_state_of`): the element state, the bodies' and the couplings' forces."""
        return dict(state=state.state, body_state=state.body_state, coupling_forces=state.coupling_forces)

    def _check_transient(self) -> None:
        """Nothing: :func:`~pipeflex.simulate` integrates every coupled system."""

    def _transient_parts(self, out: dict, system, stats: dict, metadata: dict) -> dict:
        """:class:`~pipeflex.TransientResult`'s fields from the core's record ``out`` of a run
        on ``system``: the element motion and energies, the bodies' motion in ``bodies``,
        the couplings' multipliers in ``coupling_forces`` and the end state."""
        bodies = body_motion(self.bodies, out, stats, "body_")
        for k in ("r", "R", "eta", "v", "a", "lam", "drift"):
            out.pop("body_" + k)
        forces = np.array(out.pop("coupling_multipliers"))
        metadata.update(coupled=True, n_nodes=self.model.n_nodes, n_dofs=self.n_dofs)
        return dict(out, final_state=self._state_of(system), bodies=bodies, coupling_forces=forces)

    @property
    def n_nodes(self) -> int:
        """Nodes of the element model and of the bodies."""
        return self.model.n_nodes + self.bodies.n_nodes

    def _orbit_chart(self, base):
        """The periodic orbits' chart about ``base`` (a static result of this system; None:
        the assembly at rest): the element model's and the bodies' charts stacked."""
        from .charts import CoupledChart

        if base is None:  # the assembly at rest, the couplings' multipliers zero
            base = StaticResult(state=State.from_core(as_core(self.model, None), self.model), iterations=0,
                                residual=0.0, mass_flow=self.mass_flow, body_state=self.bodies.initial_state(),
                                coupling_forces=np.zeros(self.n_constraints - self.bodies.n_constraints))
        return CoupledChart(self, base)

    def _static_start(self, state) -> "_StaticWork":
        """The static driver's working state: a copy of ``state`` (a :class:`CoupledState`
        or a static result of this system; None: the assembly at rest)."""
        if state is None:
            bs = self.bodies.initial_state()
            return _StaticWork(as_core(self.model, None), bs, np.zeros(self.n_constraints - self.bodies.n_constraints))
        if not isinstance(state, (CoupledState, StaticResult, _StaticWork)) or state.body_state is None:
            raise TypeError(f"state must be a CoupledStatic (pipeflex.static_equilibrium(system)), "
                            f"got {type(state).__name__}")
        self.bodies.check_state(state.body_state, "state.body_state")
        forces = np.zeros(self.n_constraints - self.bodies.n_constraints) if state.coupling_forces is None \
            else np.array(state.coupling_forces, float)
        return _StaticWork(as_core(self.model, state.state), state.body_state.copy(), forces)

    def _static_newton(self, state, solve, *, mass_flow, load_factor, max_iterations, start=None) -> dict:
        """One static Newton from the CoupledState ``state`` (updated in place): the driver's
        ``solve(system)`` on the system object at rest; its dict, ``why`` if not converged."""
        bs = state.body_state
        zero = np.zeros_like(bs.eta)
        sys = self.system(state.state, MultibodyState(bs.r, bs.R, bs.eta, zero, zero, bs.lam, 0.0),
                          state.coupling_forces, mass_flow=mass_flow)
        out = solve(sys)
        end = self._state_of(sys)
        state.body_state, state.coupling_forces = replace(end.body_state, v=zero, a=zero.copy()), end.coupling_forces
        # a singular KKT matrix or a correction beyond the model is its mechanism error (a
        # rigid motion left free, or a motion locked twice): the static driver does not
        # continue it by arc length
        out["final"] = bool(out["singular"] or out["diverged"])
        if not out["converged"]:
            out["why"] = ("a singular KKT matrix" if out["singular"] else
                          f"a correction of {out['correction']:.3g} m, beyond the model's size" if out["diverged"] else
                          f"no convergence in {max_iterations} iterations (residual {out['residual']:.3g} N)")
        return out

    def _static_increment(self, start: "_StaticWork", end: "_StaticWork") -> np.ndarray:
        """The increment from ``start`` to ``end`` (element, then bodies): the continuation's secant."""
        return np.concatenate([self.model._static_increment(start.state, end.state),
                               self.bodies._static_increment(start.body_state, end.body_state)])

    def _static_failure(self, out, *, load_factor, mass_flow, reached, ramp, halvings, max_iterations,
                        earlier) -> Exception:
        """The error of a load stepping whose step failed with ``out``."""
        lf = load_factor
        where = f"at load factor {lf:.6g} (from {reached[1]:.6g}, after {halvings} halvings of the load step)"
        if out["singular"] or out["diverged"]:
            what, large = ("singular KKT matrix", "") if out["singular"] else (
                f"a correction of {out['correction']:.3g} m, beyond the model's size (a nearly singular tangent)",
                ", or a load step too large (more load_steps or max_bisections)")
            return SingularMatrixError(f"coupled static solve: {what} {where}, iteration {out['iterations']}: a "
                                       f"mechanism (a rigid motion that supports, joints and couplings leave free, "
                                       f"loaded) or a motion locked twice{large}", load_factor=lf,
                                       iteration=out["iterations"], residual=out["residual"], mass_flow=mass_flow)
        return ConvergenceError(f"coupled static solve did not converge {where} after {max_iterations} iterations "
                                f"(last correction {out['correction']:.3g}, residual {out['residual']:.3g} N)",
                                load_factor=lf, iteration=max_iterations, residual=out["residual"],
                                mass_flow=mass_flow)

    def _static_result(self, state: "_StaticWork", *, iterations, residual, mass_flow, limit_points=()):
        """The StaticResult of the equilibrium ``state``: the element model's State, the
        bodies' (at rest) and the couplings' multipliers."""
        bs = state.body_state
        zero = np.zeros_like(bs.eta)
        return StaticResult(State.from_core(state.state, self.model), iterations, residual, mass_flow,
                            limit_points, MultibodyState(bs.r, bs.R, bs.eta, zero, zero.copy(), bs.lam, 0.0),
                            np.asarray(state.coupling_forces))

    @property
    def n_dofs(self) -> int:
        """Independent coordinates: coordinates less constraints (the joints and couplings
        are independent, else the static solve reports a motion locked twice)."""
        return self.n_coordinates - self.n_constraints

    def flow_scale(self) -> float:
        """mdot_ref [kg/s], the natural unit of mass flow (:meth:`pipeflex.Model.flow_scale`):
        the smaller of the element model's and the bodies' that carry fluid."""
        scales = []
        for part in (self.model, self.bodies):
            try:
                scales.append(part.flow_scale())
            except ValueError:  # this part carries no fluid
                pass
        if not scales:
            raise ValueError("the system has no element or body that carries fluid")
        return min(scales)

    @property
    def n_constraints(self) -> int:
        rows = {"rigid": 6, "hinge": 5, "spherical": 3}
        return self.bodies.n_constraints + sum(3 if self._ancf(c.node) else rows[c.kind] for c in self._joints)

    def _ancf(self, node: int) -> bool:
        return node in set(self.model.ancf_nodes or ())


#: A coupled transient: :class:`pipeflex.TransientResult` (one type for every formulation):
#: the element motion and energies, ``bodies`` (a :class:`~pipeflex.multibody.MultibodyResult`
#: at the same times; its ``drift`` is not computed: NaN), ``coupling_forces`` (n_out, rows)
#: the couplings' multipliers [N, N m], ``elements`` (the result itself, for its element part).
CoupledResult = TransientResult


@dataclass(frozen=True)
class CoupledState(Result):
    """The state of a coupled system: ``state`` (the element model's
    :class:`~pipeflex.State`), ``body_state`` (a :class:`~pipeflex.multibody.MultibodyState`
    with the bodies' joint multipliers) and ``coupling_forces`` (the couplings' multipliers
    [N, N m]; None: zero)."""

    state: State
    body_state: MultibodyState
    coupling_forces: Optional[np.ndarray] = None


#: A coupled system's static equilibrium is :func:`pipeflex.static_equilibrium`'s one result
#: type: ``state`` (the element model's :class:`~pipeflex.State`), ``body_state`` (a
#: :class:`~pipeflex.multibody.MultibodyState` with the bodies' joint multipliers),
#: ``coupling_forces`` (the couplings' multipliers [N, N m]), ``iterations`` (Newton's, all
#: load steps), ``residual`` [N] and ``mass_flow`` mdot [kg/s].
CoupledStatic = StaticResult


@dataclass
class _StaticWork:
    """A coupled system's state while the static driver works on it (updated in place):
    ``state`` the element model's (a ``_core.State``), ``body_state`` the bodies'
    :class:`~pipeflex.multibody.MultibodyState`, ``coupling_forces`` the couplings'
    multipliers [N, N m]."""

    state: object
    body_state: MultibodyState
    coupling_forces: np.ndarray

    def copy(self) -> "_StaticWork":
        return _StaticWork(self.state.copy(), self.body_state.copy(), np.array(self.coupling_forces, float))


def static_equilibrium(system: CoupledSystem, *, state: Optional[StaticResult] = None,
                       mass_flow: Optional[float] = None, load_steps: int = 1,
                       tol: float = 1e-10, max_iterations: int = 30, max_bisections: int = 8,
                       **options) -> StaticResult:
    """Static equilibrium of a :class:`CoupledSystem`: :func:`pipeflex.static_equilibrium`
    (the core's Newton on the scaled KKT matrix of the element and body equations with
    their joints, loads and gravity in ``load_steps`` increments halved where Newton
    fails; ``options``: ``from_mass_flow``, ``path``, ``arc_steps``, its flow and
    arc-length continuations).

    Args:
        state: a static result of the system to start from (e.g. the equilibrium at
            another flow; its multipliers too), default the assembly configuration.
        mass_flow: mdot [kg/s] (default: the element model's).
        load_steps: increments of the loads and gravity.
        tol: Newton tolerance on the correction, relative to the model size [-].
        max_iterations: Newton iterations per load step.
        max_bisections: halvings of the increment allowed in all.

    Raises:
        SingularMatrixError: the KKT matrix is singular, or Newton's correction leaves the
            model at every halving (a mechanism: a rigid motion that neither supports,
            joints nor couplings lock, or a motion locked twice).
        ConvergenceError: no convergence after the halvings; ``load_factor`` the failed
            step's, ``iteration``, ``residual`` [N] and ``mass_flow`` [kg/s] its own.
    """
    from .analysis.static import static_equilibrium as solve

    if not isinstance(system, CoupledSystem):
        raise ValueError("system must be a pipeflex.CoupledSystem")
    return solve(system, state=state, mass_flow=mass_flow, load_steps=load_steps, tol=tol,
                 max_iterations=max_iterations, max_bisections=max_bisections, **options)


#: The linearisation of a coupled system: :class:`pipeflex.Linearization` (one type for every
#: formulation): coordinates [z_el; q_b], ``state`` a :class:`CoupledState`.
CoupledLinearization = Linearization


def linearize(system: CoupledSystem, state=None, *, mass_flow: Optional[float] = None) -> Linearization:
    """:func:`pipeflex.linearize` of a :class:`CoupledSystem` (the same driver): about
    ``state`` (a :class:`CoupledStatic` or :class:`CoupledState` with its multipliers;
    default: the static equilibrium at ``mass_flow`` mdot [kg/s], default the state's flow),
    K with the geometric stiffness of the joints' and couplings' reactions."""
    if not isinstance(system, CoupledSystem):
        raise ValueError("system must be a pipeflex.CoupledSystem")
    return _linearize(system, state, mass_flow=mass_flow)


def simulate(system: CoupledSystem, t_end: float, *, step: float, n_outputs: int = 201,
             state: Optional[State] = None, body_state: Optional[MultibodyState] = None,
             mass_flow=None, load_factor=1.0, rho_inf: float = RHO_INF, newton_tol: float = NEWTON_TOL,
             max_newton: int = MAX_NEWTON, max_steps: int = MAX_STEPS, work: bool = True,
             progress: Optional[bool] = None) -> TransientResult:
    """:func:`pipeflex.simulate` of a :class:`CoupledSystem` (the same driver,
    generalised-alpha) from t = 0 to ``t_end`` [s] with the step ``step`` h [s], from the
    element model's ``state`` and the bodies' ``body_state`` (default: their assembly
    configurations at rest; they must satisfy the couplings; the bodies' rates are kept,
    their accelerations and the multipliers are the integrator's). Options as
    :func:`pipeflex.simulate`'s (``rho_inf`` < 1: index-3 constraints need numerical
    damping).

    Raises:
        ValueError: bad options or states; ConvergenceError: where and why Newton failed.
    """
    if not isinstance(system, CoupledSystem):
        raise ValueError("system must be a pipeflex.CoupledSystem")
    start = None
    if state is not None or body_state is not None:
        if body_state is not None:
            system.bodies.check_state(body_state, "body_state")
        bs = system.bodies.initial_state() if body_state is None else body_state
        zero = np.zeros_like(bs.eta)
        start = CoupledState(State.from_core(as_core(system.model, state), system.model),
                             MultibodyState(bs.r, bs.R, bs.eta, bs.v, zero, np.zeros_like(bs.lam), 0.0))
    return _simulate(system, t_end, integrator="generalized_alpha", state=start, n_outputs=n_outputs,
                     mass_flow=mass_flow, load_factor=load_factor, progress=progress, step=step, rho_inf=rho_inf,
                     newton_tol=newton_tol, max_newton=max_newton, max_steps=max_steps, work=work)
