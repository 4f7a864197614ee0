"""Static, linearised and transient analyses of a :class:`MultibodySystem`.

Time integration (C++): the index-3 equations (positions constrained exactly) with the
project's one Lie group generalised-alpha integrator (``GeneralizedAlpha`` in
``cpp/src/generalized_alpha.cpp``, Arnold & Bruls 2007 / Bruls, Cardona & Arnold 2012),
the same that integrates element models: rotations are updated as R <- exp(Dq~) R with
the step's increment Dq, so there is no rotation singularity and no normalisation
constraint.
Index 3 rather than van Voorthuizen et al.'s index-1 form (eq. 70, accelerations of the constraints)
because the position constraints then hold to the Newton tolerance at every step with
no drift stabilisation; the velocity-level drift ``max abs(C_q v)`` (not enforced) is
reported. Constraint rows are scaled by the iteration matrix's size. Newton is
modified: the sparse iteration matrix is kept over steps while the corrections contract
fast, and re-evaluated when they contract slowly.
"""
from __future__ import annotations

import time as _time
import warnings
from dataclasses import dataclass, field, replace
from typing import Optional, Tuple

import numpy as np

from .. import _checks, _core
from ..analysis import constrained
from ..analysis.static import StaticResult
from .._options import renamed
from ..time_functions import time_function
from ..results import COUNTERS, Result
from .body import node_index
# the statics' constants and helpers, where they were (docs and tests name them here)
from .statics import (DEFORMATION_LIMIT, FORCE_FLOOR, RESIDUAL_TOL, _bending_force,  # noqa: F401
                      _largest_deformation, _not_converged)  # noqa: F401
from .system import MultibodyState, MultibodySystem, TimeFunction


#: Default of :func:`simulate`'s ``max_steps``: the most steps a run may take (refused
#: before the first step), the same as :func:`pipeflex.simulate`'s.
MAX_STEPS = 10_000_000


#: A system of bodies' static equilibrium is :func:`pipeflex.static_equilibrium`'s one
#: result type (``state``: a :class:`MultibodyState` with the joint reactions in ``lam``).
MultibodyStatic = StaticResult


def static_equilibrium(system: MultibodySystem, *, state: Optional[MultibodyState] = None,
                       mass_flow: Optional[float] = None, t: float = 0.0, load_steps: int = 1,
                       tol: float = 1e-10, max_iterations: int = 30, max_bisections: int = 8,
                       **options) -> StaticResult:
    """Static equilibrium (at rest) under the loads at time ``t``, gravity and the flow:
    :func:`pipeflex.static_equilibrium` (its load stepping, arc-length and flow
    continuation: ``options`` ``from_mass_flow``, ``path``, ``arc_steps``) from ``state``
    at time ``t`` [s].

    Loads and gravity are applied in ``load_steps`` equal increments (halved
    automatically, at most ``max_bisections`` times, when Newton fails); Newton's method
    on the coordinates and the Lagrange multipliers, converged when the increment is below
    ``tol`` times the model's size (``system.length_scale``: the assembly's largest
    extent) (or stalls at round-off within 1e3 tol).

    Step acceptance: a converged step in which a body's elastic displacement (a node's,
    in the body's frame: its reduction basis times its elastic coordinates) exceeds
    :data:`DEFORMATION_LIMIT` of the body's length is a root of the equations outside the
    floating frame's small elastic deformation; it is rejected and the step halved.

    Mechanisms (the joints leave a rigid motion of the frames free; the core's frame Gram
    matrix tells): neutral directions keep their assembly value; loads that drive one (the
    residual's generalised force on a free rigid motion above :data:`RESIDUAL_TOL` of the
    applied force level, the round-off of the joint reactions and :data:`FORCE_FLOOR` of
    the bodies' bending force scale EI / L^2) raise.

    Args:
        state: starting guess (default: the assembly configuration).
        mass_flow: mdot [kg/s] (default: the system's).
        t: time [s] at which the loads' time functions are evaluated.
        load_steps: increments of the loads and gravity.
        tol: Newton tolerance on the increment, relative to the model's size [-].
        max_iterations: Newton iterations per load step.
        max_bisections: halvings of the increment allowed in all.

    Raises:
        ValueError: bad options or a state that does not fit the system.
        ConvergenceError: with the load factor, iteration and residual where it failed;
            also when the halved steps still end beyond :data:`DEFORMATION_LIMIT` (the
            message names the body: the floating frame's small-deformation assumption).
        SingularMatrixError: the loads drive a mechanism: the residual's generalised force
            on the rigid motions the joints leave free exceeds the allowance above (no
            static equilibrium near the assembly).
    """
    from ..analysis.static import static_equilibrium as solve

    t = _checks.finite("t", t)
    if state is not None:
        system.check_state(state)
    st = replace(system.initial_state() if state is None else state, t=t)
    return solve(system, state=st, mass_flow=mass_flow, load_steps=load_steps, tol=tol,
                 max_iterations=max_iterations, max_bisections=max_bisections, **options)


@dataclass(frozen=True)
class MultibodyLinearization(constrained.ConstrainedLinearization):
    """The linearisation of a system of bodies: ``state`` a
    :class:`~pipeflex.multibody.MultibodyState` with its multipliers."""


def linearize(system: MultibodySystem, state: Optional[MultibodyState] = None, *,
              mass_flow: Optional[float] = None) -> MultibodyLinearization:
    """Linearise about ``state`` with its multipliers (default: the static equilibrium at
    ``mass_flow`` mdot [kg/s], so that the joint reactions, e.g. of the flow's junction
    forces, are consistent): K includes the geometric stiffness of the joint reactions,
    the loads and the junction forces. Linearising about a state whose multipliers do
    not balance its forces gives a wrong K."""
    mdot = system.mass_flow if mass_flow is None else _checks.finite("mass_flow", mass_flow)
    if state is not None:
        system.check_state(state)
    st = static_equilibrium(system, mass_flow=mdot).state if state is None else state
    out = _core.linear_matrices(system.system(st), mdot)
    return constrained.linearization(MultibodyLinearization, out, mdot, st)


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


@renamed(tol="newton_tol", max_iterations="max_newton")
def simulate(system: MultibodySystem, t_end: float, *, step: float, state: Optional[MultibodyState] = None,
             mass_flow: Optional[TimeFunction] = None, n_outputs: int = 201, rho_inf: float = 0.8,
             newton_tol: float = 1e-9, max_newton: int = 12, refresh: Optional[int] = None,
             max_steps: int = MAX_STEPS) -> MultibodyResult:
    """Integrate the constrained equations of motion from ``state`` (default: the
    assembly configuration at rest) to ``t_end`` [s] with the fixed ``step`` h [s].
    Option names as :func:`pipeflex.simulate`'s generalised-alpha (``step``,
    ``rho_inf``, ``newton_tol``, ``max_newton``).

    Args:
        mass_flow: mdot [kg/s]: a number, a table (times [s], values) or a
            :class:`~pipeflex.Sine` (its slope gives the fluid's tangential acceleration
            sddot); default the system's.
        n_outputs: output times, evenly spaced over [t0, t_end] (rounded to steps).
        rho_inf: spectral radius at infinite frequency, in [0, 1): the index-3 equations
            need numerical damping (with 1, as for Newmark's average acceleration, the
            multipliers' errors grow like 1/h^2 and a spinning body blows up). Default
            0.8: bodies with a preimposed curvature need <= 0.8 when they spin (a freely
            spinning semicircular pipe diverges at 0.9 with h = 1 ms, 0.95 at any step).
            (:func:`pipeflex.simulate`'s generalised-alpha defaults to 0.9 and allows 1:
            its supports are eliminated, there are no multipliers to damp.)
        newton_tol: Newton tolerance on the position error left after a step's iterations
            (estimated from the corrections' contraction, as in :func:`pipeflex.simulate`),
            relative to the model's size, system.length_scale (an iteration that stalls within
            10 newton_tol with an iteration matrix evaluated in the step is accepted:
            round-off). ``tol=`` is its deprecated name.
        max_newton: Newton iterations per step (``max_iterations=`` is its deprecated name);
            a step whose Newton fails is halved (down to 1e-12 s) and the step restored
            after.
        refresh: deprecated, without effect: the iteration matrix is re-evaluated when
            Newton contracts slowly, as in :func:`pipeflex.simulate`.
        max_steps: the most steps the run may take (10^7): a run that needs more is
            refused before it starts (ValueError). Ctrl-C stops a run (KeyboardInterrupt).

    Raises:
        ValueError: bad options.
        ConvergenceError: with the time, iteration and residual where Newton failed.
    """
    t_end = _checks.finite("t_end", t_end)
    h = _checks.positive("step", step)
    n_out = _checks.positive_int("n_outputs", n_outputs)
    rho = _checks.rho_inf_with_multipliers(rho_inf)
    tol = _checks.positive("newton_tol", newton_tol)
    max_iterations = _checks.positive_int("max_newton", max_newton)
    if refresh is not None:
        warnings.warn("simulate(): 'refresh' is deprecated and has no effect (the iteration matrix is re-evaluated "
                      "when Newton contracts slowly)", DeprecationWarning, stacklevel=2)
    max_steps = _checks.positive_int("max_steps", max_steps)
    if state is not None:
        system.check_state(state)
    st = system.initial_state() if state is None else state.copy()
    t0 = st.t
    if t_end <= t0:
        raise ValueError(f"t_end = {t_end} must be after the start time {t0}")
    flow = time_function("mass_flow", system.mass_flow if mass_flow is None else mass_flow)
    steps = np.ceil((t_end - t0) / h - 1e-9)  # may be inf
    if not steps <= max_steps:  # refused before the output steps are laid out (the core checks again)
        raise ValueError(f"step = {h} s gives {steps:.6g} steps to t_end = {t_end} s; max_steps = {max_steps} "
                         "(raise step or max_steps, or shorten the run)")
    n_steps = max(1, int(steps))
    out_steps = [int(k) for k in np.unique(np.round(np.linspace(0, n_steps, n_out)).astype(int))]
    wall = _time.perf_counter()
    step = (t_end - t0) / n_steps  # the step used: the interval in whole steps
    times = [t_end if k == n_steps else t0 + k * step for k in out_steps]
    opt = _core.TransientOptions()
    opt.step, opt.rho_inf, opt.newton_tol, opt.max_newton, opt.max_steps = step, rho, tol, max_iterations, max_steps
    out = _core.integrate(system.system(st), flow, time_function("load_factor", 1.0), times, opt)
    stats = {k: int(out[k]) for k in COUNTERS}
    stats["wall_time"] = _time.perf_counter() - wall
    stats["step"] = step
    return MultibodyResult(out["t"], out["r"], out["R"], out["eta"], out["v"], out["drift"],
                           np.array(system.offsets), system.n_constraints,
                           tuple(np.array(b.nodes_s) for b in system.bodies),
                           tuple(np.array(b.basis) for b in system.bodies), stats)
