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
alone: :func:`simulate`, also reached through :func:`pipeflex.simulate`.

Coordinates: the element model's reduced coordinates, then the bodies' (body after body);
multipliers: the bodies' joints, then the couplings (:attr:`CoupledResult.coupling_forces`).
A planar ANCF node is clamped to a body node in the x-y plane (3 rows: its position, and
its slope's direction; the slope's length, the root's axial strain, stays free), so a
rotating ANCF beam can hang on a hub body with inertia and a motor torque instead of a
prescribed hub angle.
"""
from __future__ import annotations

import time as _time
from dataclasses import dataclass, field, replace
from typing import List, Optional, Sequence, Tuple

import numpy as np

from . import _checks, _core, _progress
from .analysis import constrained
from .analysis.static import StaticResult
from .analysis.transient import TransientResult, _step_used
from .model import Model
from .multibody.analysis import MAX_STEPS, MultibodyResult
from .multibody.system import MultibodyState, MultibodySystem
from .errors import ConvergenceError, SingularMatrixError
from .results import COUNTERS, Result
from .state import State, as_core
from .time_functions import time_function

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
        self._add("hinge", node, body, body_node, tuple(_checks.unit_vector("axis", axis)))

    def spherical(self, node: int, body: int, body_node="start") -> None:
        """Spherical joint: equal positions, free relative rotation."""
        self._add("spherical", node, body, body_node)

    def _add(self, kind, node, body, body_node, axis=None) -> None:
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
        self._joints.append(CouplingJoint(kind, n, j, i, axis))

    def core_couplings(self) -> list:
        """The couplings as the core takes them: (node, kind, body, body node, C0, axis_b,
        perp0, perp1), with the reference orientations of the assembly configuration."""
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
        return out

    def _linearize(self, state=None, *, mass_flow=None) -> "CoupledLinearization":
        """:func:`pipeflex.linearize`'s entry for a coupled system."""
        return linearize(self, state, mass_flow=mass_flow)

    def _simulate(self, t_end, *, integrator, state, t_start, n_outputs, times, mass_flow, load_factor, progress,
                  **options) -> "CoupledResult":
        """:func:`pipeflex.simulate`'s entry for a coupled system."""
        if integrator not in ("auto", "generalized_alpha") or t_start != 0.0 or times is not None:
            raise ValueError("a CoupledSystem is integrated by generalised-alpha from t_start = 0 with n_outputs "
                             "equally spaced outputs (pipeflex.coupled.simulate)")
        return simulate(self, t_end, n_outputs=n_outputs, state=state, mass_flow=mass_flow, load_factor=load_factor,
                        progress=progress, **{"step": 1e-3, **options})

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

    def _system(self, state=None, *, mass_flow: Optional[float] = None) -> "_core.System":
        """The core system object on a copy of ``state`` (a :class:`CoupledState`, or a
        static result of this system: its parts and multipliers; None: the assembly at
        rest), mdot [kg/s] ``mass_flow`` (None: the element model's)."""
        st = self._static_start(state)
        return self.system(st.state, st.body_state, st.coupling_forces, mass_flow=mass_flow)

    def _state_of(self, system) -> "CoupledState":
        """The end state of an analysis run on ``system``: its parts and multipliers."""
        return CoupledState(system.element_state, MultibodyState(*system.body_state),
                            np.array(system.coupling_multipliers, float))

    def _static_start(self, state) -> "CoupledState":
        """The static driver's working state: a copy of ``state`` (see :meth:`_system`)."""
        if state is None:
            bs = self.bodies.initial_state()
            return CoupledState(as_core(self.model, None), bs,
                                np.zeros(self.n_constraints - self.bodies.n_constraints))
        if not isinstance(state, (CoupledState, StaticResult)) or state.body_state is None:
            raise TypeError(f"state must be a CoupledStatic (pipeflex.static_equilibrium(system)), "
                            f"got {type(state).__name__}")
        self.bodies.check_state(state.body_state, "state.body_state")
        return CoupledState(as_core(self.model, state.state), state.body_state.copy(),
                            np.array(state.coupling_forces, float))

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

    def _static_increment(self, start: "CoupledState", end: "CoupledState") -> np.ndarray:
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

    def _static_result(self, state: "CoupledState", *, iterations, residual, mass_flow, limit_points=()):
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


@dataclass(frozen=True)
class CoupledResult(Result):
    """A coupled transient: ``elements`` (a :class:`~pipeflex.TransientResult`: node
    positions, rotations, velocities, the element model's energies), ``bodies`` (a
    :class:`~pipeflex.multibody.MultibodyResult` at the same times; its ``drift`` is not
    computed: NaN), ``coupling_forces`` (n_out, rows) the couplings' multipliers [N, N m]
    (forces and moments on the element nodes, as the bodies' joint multipliers), and
    ``stats`` (steps, Newton iterations, Jacobians, failed steps, wall time [s])."""

    elements: TransientResult
    bodies: MultibodyResult
    coupling_forces: np.ndarray
    stats: dict = field(default_factory=dict)

    @property
    def t(self) -> np.ndarray:
        return self.elements.t


#: A coupled system's static equilibrium is :func:`pipeflex.static_equilibrium`'s one result
#: type: ``state`` (the element model's :class:`~pipeflex.State`), ``body_state`` (a
#: :class:`~pipeflex.multibody.MultibodyState` with the bodies' joint multipliers),
#: ``coupling_forces`` (the couplings' multipliers [N, N m]), ``iterations`` (Newton's, all
#: load steps), ``residual`` [N] and ``mass_flow`` mdot [kg/s].
CoupledStatic = StaticResult


@dataclass
class CoupledState:
    """A coupled system's state in its analyses: ``state`` the element model's (a
    ``_core.State``), ``body_state`` the bodies' :class:`~pipeflex.multibody.MultibodyState`,
    ``coupling_forces`` the couplings' multipliers [N, N m] (what a static result holds)."""

    state: object
    body_state: MultibodyState
    coupling_forces: np.ndarray

    def copy(self) -> "CoupledState":
        return CoupledState(self.state.copy(), self.body_state.copy(), np.array(self.coupling_forces, float))


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


@dataclass(frozen=True)
class CoupledLinearization(constrained.ConstrainedLinearization):
    """The linearisation of a coupled system: coordinates [z_el; q_b], ``state`` a
    :class:`CoupledStatic`."""


def linearize(system: CoupledSystem, state: Optional[CoupledStatic] = None, *,
              mass_flow: Optional[float] = None) -> CoupledLinearization:
    """Linearise a :class:`CoupledSystem` about ``state`` (a :class:`CoupledStatic` with its
    multipliers; default: the static equilibrium at ``mass_flow`` mdot [kg/s]): the one
    constrained linearisation of the bodies (:mod:`pipeflex.analysis.constrained`), K with
    the geometric stiffness of the joints' and couplings' reactions."""
    if not isinstance(system, CoupledSystem):
        raise ValueError("system must be a pipeflex.CoupledSystem")
    if state is not None and (not isinstance(state, CoupledStatic) or state.body_state is None):
        raise TypeError(f"state must be a CoupledStatic (pipeflex.static_equilibrium(system)), "
                        f"got {type(state).__name__}")
    model = system.model
    mdot = (model.mass_flow if state is None else state.mass_flow) if mass_flow is None else \
        _checks.finite("mass_flow", mass_flow)
    st = static_equilibrium(system, mass_flow=mdot) if state is None else state
    out = _core.linear_matrices(system.system(as_core(model, st.state), st.body_state, st.coupling_forces,
                                              mass_flow=mdot), mdot)
    return constrained.linearization(CoupledLinearization, out, mdot, st)


def simulate(system: CoupledSystem, t_end: float, *, step: float, n_outputs: int = 201,
             state: Optional[State] = None, body_state: Optional[MultibodyState] = None,
             mass_flow=None, load_factor=1.0, rho_inf: float = 0.8, newton_tol: float = 1e-9,
             max_newton: int = 12, max_steps: int = MAX_STEPS, work: bool = True,
             progress: Optional[bool] = None) -> CoupledResult:
    """Integrate a :class:`CoupledSystem` from t = 0 to ``t_end`` [s] with generalised-alpha.

    Args:
        step: h [s], the largest step (halved where Newton fails, restored after); each
            output interval is split into equal steps no longer than h, and the result's
            ``elements.metadata["step"]`` is the step taken (``["requested_step"]``: h).
        n_outputs: equally spaced output times.
        state, body_state: initial states of the element model and of the bodies (default:
            their assembly configurations at rest); they must satisfy the couplings.
        mass_flow: mdot [kg/s] through the pipe elements and the bodies that carry fluid: a
            number, a table ``(times [s], values)`` or a :class:`~pipeflex.Sine`; default the
            element model's.
        load_factor: scales the element model's nodal loads (number, table or Sine).
        rho_inf: spectral radius at infinite frequency in [0, 1) (index-3 constraints need
            numerical damping, as :func:`pipeflex.multibody.simulate`).
        newton_tol: Newton tolerance on the position error left, relative to the model size.
        max_newton, max_steps: Newton iterations per step; steps (failed ones included).
        work: integrate the work of the fluid forces and loads on the elements.
        progress: None (a bar in a notebook or on a terminal once the run is long, else
            log lines), True (always) or False (nothing); as :func:`pipeflex.simulate`.

    Raises:
        ValueError: bad options or states; ConvergenceError: where and why Newton failed.
    """
    if not isinstance(system, CoupledSystem):
        raise ValueError("system must be a pipeflex.CoupledSystem")
    t1 = _checks.positive("t_end", t_end)
    h = _checks.positive("step", step)
    n_out = _checks.positive_int("n_outputs", n_outputs)
    rho = _checks.rho_inf_with_multipliers(rho_inf)
    model, bodies = system.model, system.bodies
    opt = _core.TransientOptions()
    opt.step = min(h, t1)
    opt.rho_inf = rho
    opt.newton_tol = _checks.positive("newton_tol", newton_tol)
    opt.max_newton = _checks.positive_int("max_newton", max_newton)
    opt.max_steps = _checks.positive_int("max_steps", max_steps)
    opt.work = bool(work)
    st = as_core(model, state)
    if body_state is not None:
        bodies.check_state(body_state, "body_state")
    bs = bodies.initial_state() if body_state is None else body_state
    flow = time_function("mass_flow", model.mass_flow if mass_flow is None else mass_flow)
    loads = time_function("load_factor", load_factor)
    times = list(np.linspace(0.0, t1, max(n_out, 2)))
    bar = _progress.Progress(progress, t1, desc="simulate (coupled)", unit="s", leave=False)
    wall = _time.perf_counter()
    with bar:
        # from t = 0 with the bodies' rates (consistent accelerations and multipliers: the integrator's)
        zero = np.zeros_like(bs.eta)
        sys = system.system(st, MultibodyState(bs.r, bs.R, bs.eta, bs.v, zero, np.zeros_like(bs.lam), 0.0))
        out = _core.integrate(sys, flow, loads, times, opt, None if bar.mode == "off" else bar.update)
        bar.update(t1)  # the core reports at most every 0.1 s, not the end
    wall = _time.perf_counter() - wall
    stats = {k: int(out.pop(k)) for k in COUNTERS}
    stats["wall_time"] = wall
    body = {k: out.pop("body_" + k) for k in ("r", "R", "eta", "v", "a", "lam", "drift")}
    lams = out.pop("coupling_multipliers")
    if not opt.work:
        out["fluid_work"][:] = np.nan
        out["load_work"][:] = np.nan
    # the step taken (each output interval in equal steps, as simulate reports it) and the one asked for
    meta = {"integrator": "generalized_alpha", "step": _step_used(opt.step, np.asarray(times)),
            "requested_step": float(opt.step), "coupled": True}
    elements = TransientResult(**out, stats=stats, metadata=meta,
                               final_state=State.from_core(st, model))
    body_res = MultibodyResult(out["t"].copy(), body["r"], body["R"], body["eta"], body["v"], body["drift"],
                               np.array(bodies.offsets), bodies.n_constraints,
                               tuple(np.array(b.nodes_s) for b in bodies.bodies),
                               tuple(np.array(b.basis) for b in bodies.bodies), stats)
    return CoupledResult(elements, body_res, np.array(lams), stats)
