"""Nonlinear frequency response: periodic orbits of a harmonically forced model, continued
in the forcing frequency, their Floquet multipliers, the folds (jump frequencies), the
backbone of the free undamped oscillation, and a stepped-sine transient sweep to check
the jumps.

The forcing multiplies the model's nodal loads by the load factor

    lambda(t) = mean + A sin(Omega t + phase)

(a :class:`~pipeflex.Sine` whose ``omega`` is the continued Omega). Its period T = 2 pi /
Omega is fixed by the forcing, so a T-periodic orbit needs no phase condition: it is a
state x0 = (z0, v0) with

    F(x0, Omega) = phi_T(x0; Omega) - x0 = 0,

phi_T the generalised-alpha flow map from t = 0 (the forcing's phase at t = 0) over one
period in N equal steps (the stroboscopic map; :func:`pipeflex.periodic_orbit`'s flow map
with the load factor). Newton's Jacobian d F / d x0 = Phi - I comes from the flow map's
tangent-linear map (Phi, the monodromy matrix, exact for the discrete map); d F / d Omega
is a central difference of two flow maps. The curve is continued by pseudo-arclength in
(x0, Omega), scaled by the first orbit's size and the frequency span, so it passes the
folds where Omega turns (the jump frequencies of a hardening or softening response).
Every point keeps all 2 n Floquet multipliers (the eigenvalues of Phi: a forced orbit has
no trivial multiplier 1); it is stable when all lie inside the unit circle.
"""
from __future__ import annotations

import copy
from dataclasses import dataclass, field, replace
from typing import Optional, Sequence, Tuple

import numpy as np

from .. import _checks, _core
from .._blas import pinned as blas_pinned
from .._progress import logger
from ..errors import ConvergenceError
from ..results import FIELDS, Result
from ..time_functions import Sine, time_function
from .periodic import NEUTRAL, _chart, _options, _Shooter

#: generalised-alpha steps per forcing period unless given
STEPS_PER_PERIOD = 128
#: relative step of the central difference d F / d Omega
DOMEGA = 1e-6
#: the continuation's step grows 1.5 times while the corrector moves the predictor by
#: less than half this fraction of the step (in the scaled arclength), and halves above
#: twice it
MISS = 0.15

FIELDS["FrequencyResponse"] = {
    "frequency": ("rad/s", "forcing angular frequency Omega", ("point",)),
    "amplitude": ("m", "largest displacement of the watched coordinate over the period", ("point",)),
    "stable": (None, "orbit stable", ("point",)),
    "max_multiplier": ("1", "largest modulus of the Floquet multipliers", ("point",)),
    "multipliers": ("1", "Floquet multipliers by decreasing modulus", ("point", "multiplier")),
    "residual": (None, "periodicity defect max(abs(z_T - z0), abs(v_T - v0) / Omega) (m, rad)", ("point",)),
    "folds": ("rad/s", "forcing frequency of a fold (jump frequency)", ("fold",)),
    "fold_amplitudes": ("m", "amplitude at a fold", ("fold",)),
    "backbone_frequency": ("rad/s", "angular frequency of the free undamped oscillation", ("backbone",)),
    "backbone_amplitude": ("m", "amplitude of the free undamped oscillation", ("backbone",)),
}
FIELDS["FrequencySweep"] = {
    "frequency": ("rad/s", "forcing angular frequency Omega", ("step",)),
    "amplitude": ("m", "largest displacement of the watched coordinate over the measured periods", ("step",)),
}
FIELDS["Backbone"] = {
    "frequency": ("rad/s", "angular frequency of the free undamped oscillation", ("point",)),
    "amplitude": ("m", "largest displacement of the watched coordinate", ("point",)),
    "period": ("s", "period of the free oscillation", ("point",)),
}


@dataclass(frozen=True)
class Backbone(Result):
    """The free undamped oscillation's amplitude-frequency relation (:func:`backbone`).

    Attributes:
        frequency: (k,) omega [rad/s] = 2 pi / period of each free periodic orbit.
        amplitude: (k,) largest displacement [m] of the watched coordinate from the base.
        period: (k,) [s].
        node, component: the watched coordinate (0, 1, 2 = x, y, z).
    """

    frequency: np.ndarray
    amplitude: np.ndarray
    period: np.ndarray
    node: int
    component: int
    stats: dict = field(default_factory=dict)

    def to_xarray(self):
        """``frequency``, ``amplitude``, ``period`` over ``point`` (units, long names)."""
        from ..results import to_dataset

        return to_dataset("Backbone", {n: getattr(self, n) for n in ("frequency", "amplitude", "period")},
                          {"point": ("point", np.arange(len(self.frequency)), {"long_name": "orbit index"})},
                          {"node": self.node, "component": self.component})


@dataclass(frozen=True)
class FrequencyResponse(Result):
    """A forced response curve: T-periodic orbits continued in the forcing frequency.

    Attributes:
        frequency: (k,) Omega [rad/s] of each orbit, in the order continued (it turns back
            at a fold).
        amplitude: (k,) largest abs(x_c(t) - x_c(base)) over the period of the watched node
            coordinate [m] (samples at the N steps, the peak refined by a parabola).
        stable: (k,) all Floquet multipliers inside the unit circle (to NEUTRAL).
        multipliers: (k, 2 n) Floquet multipliers of each orbit by decreasing modulus [-].
        max_multiplier: (k,) the largest modulus [-].
        residual: (k,) periodicity defect: the largest of abs(z_T - z0) and
            abs(v_T - v0) / Omega [m, rad] (``phi_T(x0) - x0`` = (z_T - z0, v_T - v0)).
        folds: Omega [rad/s] where the curve turns (the jump frequencies), in the order met.
        fold_amplitudes: the amplitude there [m].
        starts: (k, 2 n) each orbit's (z0, v0) at t = 0 in the chart of ``base``.
        base: the chart's base state (coordinates are measured from it).
        node, component: the watched coordinate (0, 1, 2 = x, y, z of the node).
        forcing: the load factor's (mean, A, phase) [-, -, rad].
        steps: N, generalised-alpha steps per period.
        backbone: a :class:`Backbone` drawn beside the curve, or None.
    """

    frequency: np.ndarray
    amplitude: np.ndarray
    stable: np.ndarray
    multipliers: np.ndarray
    max_multiplier: np.ndarray
    residual: np.ndarray
    folds: np.ndarray
    fold_amplitudes: np.ndarray
    starts: np.ndarray
    base: object
    node: int
    component: int
    forcing: tuple
    steps: int
    backbone: Optional[Backbone] = None
    stats: dict = field(default_factory=dict)

    def unstable_region(self) -> Tuple[float, float]:
        """(Omega_min, Omega_max) [rad/s] of the unstable orbits ((nan, nan) if none)."""
        w = self.frequency[~self.stable]
        return (float(w.min()), float(w.max())) if len(w) else (np.nan, np.nan)

    def plot(self, ax=None, *, backbone: bool = True, label: Optional[str] = None):
        """Amplitude over Omega: stable orbits solid, unstable dashed, folds marked, the
        backbone (if computed and ``backbone``) dotted. Returns the axes."""
        import matplotlib.pyplot as plt

        if ax is None:
            ax = plt.figure(figsize=(6, 4)).add_subplot()
        w, a, s = self.frequency, self.amplitude, self.stable
        # runs of equal stability, each joined to the next point so the line is unbroken
        edges = np.flatnonzero(np.diff(s.astype(int))) + 1
        color = None
        for lo, hi in zip(np.r_[0, edges], np.r_[edges, len(w)]):
            seg = slice(lo, min(hi + 1, len(w)))
            line, = ax.plot(w[seg], a[seg], "-" if s[lo] else "--", color=color,
                            label=(label or "forced response") if lo == 0 else None)
            color = line.get_color()
        if len(self.folds):
            ax.plot(self.folds, self.fold_amplitudes, "o", color=color, mfc="none", label="folds")
        if backbone and self.backbone is not None:
            ax.plot(self.backbone.frequency, self.backbone.amplitude, ":", color="k", label="backbone")
        ax.set_xlabel(r"forcing frequency $\Omega$ [rad/s]")
        ax.set_ylabel(f"amplitude of node {self.node} {'xyz'[self.component]} [m]")
        ax.legend()
        return ax

    def to_xarray(self):
        """The curve as an ``xarray.Dataset``: ``frequency``, ``amplitude``, ``stable``,
        ``max_multiplier``, ``residual`` over ``point``, the multipliers
        (``multipliers_real``, ``multipliers_imag``) over (point, multiplier), ``folds``
        and ``fold_amplitudes`` over ``fold``, the backbone (if any) over ``backbone``;
        units and long names; node, component, forcing and steps as attributes."""
        from ..results import to_dataset

        names = ("frequency", "amplitude", "stable", "max_multiplier", "multipliers", "residual", "folds",
                 "fold_amplitudes")
        values = {n: getattr(self, n) for n in names}
        coords = {"point": ("point", np.arange(len(self.frequency)), {"long_name": "orbit index along the curve"})}
        if self.backbone is not None:
            values["backbone_frequency"] = self.backbone.frequency
            values["backbone_amplitude"] = self.backbone.amplitude
        mean, amp, phase = self.forcing
        return to_dataset("FrequencyResponse", values, coords,
                          {"node": self.node, "component": self.component, "forcing_mean": mean,
                           "forcing_amplitude": amp, "forcing_phase": phase, "steps": self.steps})


@dataclass(frozen=True)
class FrequencySweep(Result):
    """A stepped-sine transient sweep (:func:`frequency_sweep`).

    Attributes:
        frequency: (k,) Omega [rad/s] in the order swept.
        amplitude: (k,) largest abs(x_c - x_c(base)) [m] over the last ``measure`` periods
            at each Omega.
        node, component: the watched coordinate.
        final_state: the state at the end of the sweep.
    """

    frequency: np.ndarray
    amplitude: np.ndarray
    node: int
    component: int
    final_state: object = None
    stats: dict = field(default_factory=dict)

    def jump(self) -> Tuple[float, float]:
        """(Omega [rad/s], relative change [-]) of the largest relative amplitude change
        between consecutive steps: where the response jumped."""
        a = self.amplitude
        rel = np.abs(np.diff(a)) / np.maximum(np.minimum(a[1:], a[:-1]), 1e-300)
        k = int(np.argmax(rel))
        return float(self.frequency[k]), float(rel[k])

    def to_xarray(self):
        """``frequency``, ``amplitude`` over ``step`` (units, long names)."""
        from ..results import to_dataset

        return to_dataset("FrequencySweep", {"frequency": self.frequency, "amplitude": self.amplitude},
                          {"step": ("step", np.arange(len(self.frequency)), {"long_name": "sweep step"})},
                          {"node": self.node, "component": self.component})


# -- the forcing ------------------------------------------------------------------------

def _nodal_loads(model) -> Optional[list]:
    """The nodal loads as (point, force [N]) (the model class's ``_nodal_loads``: an element
    model's point is its node, a MultibodySystem's its node among the bodies' stacked nodes,
    a coupled system's both, the bodies' after the element nodes); None: unknown (a model
    not built by its builder)."""
    loads = getattr(model, "_nodal_loads", None)
    return None if loads is None else loads()


def _load_spec(load, keys):
    """``load`` as a dict of ``keys`` (a tuple in that order, or a dict), checked."""
    if isinstance(load, dict):
        spec = dict(load)
    else:
        try:
            spec = dict(zip(keys, load))
        except TypeError:
            spec = None
    names = ", ".join(keys[:-2])
    if spec is None or any(k not in spec for k in keys[:-1]) or set(spec) - set(keys):
        raise ValueError(f"load must be ({names}, force) or ({names}, force, moment) [N, N m] or a dict with "
                         f"{names}, force (and moment); got {load!r}")
    return spec


def _with_load(model, load):
    """A copy of ``model`` with the nodal ``load`` added (the copy's only nodal load), the
    loaded point and the force [N]: an element model's (node, force[, moment]) or
    dict(node=, force=, moment=); a MultibodySystem's (body, node, force[, moment]) or
    dict(body=, node=, force=, moment=) (node: an index or "start"/"end"; its class's
    ``_with_body_load``)."""
    with_body_load = getattr(model, "_with_body_load", None)
    if with_body_load is not None:
        return with_body_load(_load_spec(load, ("body", "node", "force", "moment")))
    spec = _load_spec(load, ("node", "force", "moment"))
    d = getattr(model, "_description", None) or {}
    if d.get("_loads"):
        raise ValueError("load= adds the forced load to a model without nodal loads, but this model has "
                         f"{len(d['_loads'])}: give the forcing as load_factor= (it scales all the model's "
                         "nodal loads) instead")
    out = _rebuilt(model, lambda b: b.add_load(spec["node"], force=spec.get("force", (0.0, 0.0, 0.0)),
                                               moment=spec.get("moment", (0.0, 0.0, 0.0))), what="load=")
    return out, int(spec["node"]), np.asarray(spec.get("force", (0.0, 0.0, 0.0)), float)


def _forcing(model, load, load_factor):
    """(model, (mean, A, phase), default node, default component) of the forcing."""
    if load is None and load_factor is None:
        raise ValueError("no forcing: give load= (a nodal load (node, force [N]) driven by A sin(Omega t)) or "
                         "load_factor=pipeflex.Sine(omega=..., envelope=A) (it scales the model's nodal loads)")
    sine = Sine(omega=1.0) if load_factor is None else load_factor
    if not isinstance(sine, Sine):
        raise ValueError(f"load_factor must be a pipeflex.Sine (its omega is replaced by each Omega of the curve), "
                         f"got {load_factor!r}")
    if not np.isscalar(sine.envelope):
        raise ValueError("load_factor.envelope must be a number A (a constant forcing amplitude), got a table")
    amp = _checks.finite("load_factor.envelope", sine.envelope)
    mean = _checks.finite("load_factor.mean", sine.mean)
    phase = _checks.finite("load_factor.phase", sine.phase)
    if amp == 0.0:
        raise ValueError("no forcing: load_factor.envelope (the forcing amplitude A) is 0")
    node = component = None
    if load is not None:
        model, node, force = _with_load(model, load)
        component = int(np.argmax(np.abs(force)))
    else:
        loads = _nodal_loads(model)
        if loads == []:
            raise ValueError("no forcing: the model has no nodal loads for load_factor to scale; add one "
                             "(ModelBuilder.add_load, MultibodyBuilder.add_load) or give load=(node, force) "
                             "(bodies: load=(body, node, force))")
        if loads:
            node, component = loads[0][0], int(np.argmax(np.abs(loads[0][1])))
    return model, (mean, amp, phase), node, component


def _table(forcing, omega):
    mean, amp, phase = forcing
    return time_function("load_factor", Sine(omega=float(omega), envelope=amp, phase=phase, mean=mean))


def _frequencies(frequencies):
    try:
        w0, w1 = (float(w) for w in frequencies)
    except (TypeError, ValueError):
        raise ValueError(f"frequencies must be (Omega_start, Omega_end) [rad/s], got {frequencies!r}") from None
    for w in (w0, w1):
        if not np.isfinite(w) or w <= 0.0:
            raise ValueError(f"frequencies must be positive and finite [rad/s], got {frequencies!r}")
    if w0 == w1:
        raise ValueError(f"frequencies must differ (a span to continue over), got {frequencies!r}")
    return w0, w1


def _watch(chart, node, component):
    n_points = chart.positions(np.zeros(chart.n)).shape[1]
    if node is None:
        raise ValueError("node is needed: the node whose coordinate's amplitude is recorded")
    node = _checks.non_negative_int("node", node)
    if node >= n_points:
        raise ValueError(f"node must be in [0, {n_points}), got {node}")
    if component not in (0, 1, 2):
        raise ValueError(f"component must be 0, 1 or 2 (x, y, z), got {component!r}")
    return node, component


def _peak(y):
    """max abs(y) of samples of a smooth periodic signal, refined by the parabola through
    the largest sample and its neighbours (cyclically: y[-1] repeats y[0])."""
    y = np.abs(np.asarray(y, float)[:-1]) if len(y) > 3 else np.abs(np.asarray(y, float))
    k = int(np.argmax(y))
    a, b, c = y[k - 1], y[k], y[(k + 1) % len(y)]
    den = a - 2.0 * b + c
    return float(b - 0.125 * (a - c) ** 2 / den) if den < 0.0 else float(b)


class _Forced(_Shooter):
    """The stroboscopic map of the forced model: the flow map over T = 2 pi / Omega with
    the load factor mean + A sin(Omega t + phase)."""

    def __init__(self, model, chart, steps, opt, forcing, mass_flow):
        super().__init__(model, chart, steps, opt)
        self.forcing = forcing
        self.mass_flow = float(mass_flow)

    def map(self, x, omega, sensitivity=False):
        n = self.n
        self.calls += 1
        # a fresh system on the base each time: a flow map moves its system's state
        out = _core.flow_map(self.chart.system(self.mass_flow), self.mass_flow, np.asarray(x[:n], float), np.asarray(x[n:], float),
                             2.0 * np.pi / omega, self.steps, bool(sensitivity), self.opt,
                             load_factor=_table(self.forcing, omega))
        self.newton_iterations += int(out["newton_iterations"])
        return out

    def residual(self, out, x):
        return np.concatenate([out["z"][-1], out["v"]]) - x

    def defect(self, F, omega):
        """max(abs(dz), abs(dv) / Omega) of the residual F = (dz, dv) [m, rad]: the rates'
        defect over Omega is the displacement it makes over a radian of the period."""
        n = self.n
        return float(max(np.abs(F[:n]).max(), np.abs(F[n:]).max() / omega))

    def d_omega(self, x, omega):
        d = DOMEGA * omega
        return (self.residual(self.map(x, omega + d), x) - self.residual(self.map(x, omega - d), x)) / (2.0 * d)

    def amplitude(self, out, watch):
        node, component = watch
        x = self.chart.positions(out["z"])[:, node, component]
        return _peak(x - self.chart.positions(np.zeros(self.n))[0, node, component])


def _newton(sh, x, omega, *, tol, max_iterations, Phi=None, dF=None, arc=None):
    """Chord Newton on F(x, Omega) = 0 [with the arclength row arc = (y_prev, t, h, s):
    t . ((y - y_prev) / s) = h, y = (x, Omega), Omega then unknown]. Phi, dF: the
    Jacobian's blocks to start from (refreshed where the defect stops falling fast).
    Returns (x, omega, out (with the monodromy at the solution), iterations, residual)."""
    n2 = len(x)
    x, omega = np.array(x, float), float(omega)
    out = sh.map(x, omega, sensitivity=Phi is None)
    fresh = Phi is None
    if fresh:
        Phi = out["monodromy"]
    previous = np.inf
    for it in range(1, max_iterations + 1):
        F = sh.residual(out, x)
        res = sh.defect(F, omega)
        if not np.isfinite(res):
            raise ConvergenceError(f"forced response: the periodicity defect is not finite at Omega = {omega:.6g} "
                                   f"rad/s (iteration {it})", iteration=it)
        rows = [F]
        if arc is not None:
            y_prev, t, h, s = arc
            g = float(t @ ((np.r_[x, omega] - y_prev) / s)) - h
            rows.append([g])
        done = res <= tol and (arc is None or abs(g) <= 1e-10 * max(1.0, abs(h)))
        if done:
            if not fresh:  # the multipliers need the monodromy at the solution
                out = sh.map(x, omega, sensitivity=True)
            return x, omega, out, it, res
        if not fresh and res > 0.25 * previous:
            out = sh.map(x, omega, sensitivity=True)
            Phi, fresh = out["monodromy"], True
            if arc is not None:
                dF = sh.d_omega(x, omega)
        previous = res
        J = Phi - np.eye(n2)
        if arc is not None:
            if dF is None:
                dF = sh.d_omega(x, omega)
            J = np.block([[J, dF[:, None]], [(t / s)[None, :]]])
        step = np.linalg.solve(J, -np.concatenate(rows))
        for _ in range(6):  # backtrack while the defect grows tenfold (or the map fails)
            x_try = x + step[:n2]
            w_try = omega + step[n2] if arc is not None else omega
            if w_try > 0.0:
                try:
                    out_try = sh.map(x_try, w_try)
                    if sh.defect(sh.residual(out_try, x_try), w_try) <= 10.0 * res:
                        break
                except ConvergenceError:
                    pass
            step = 0.5 * step
        else:
            raise ConvergenceError(f"forced response: no Newton step reduces the periodicity defect {res:.3g} at "
                                   f"Omega = {omega:.6g} rad/s", iteration=it, residual=res)
        x, omega, out, fresh = x_try, w_try, out_try, False
    raise ConvergenceError(f"forced response: shooting did not converge in {max_iterations} iterations at Omega = "
                           f"{omega:.6g} rad/s (periodicity defect {res:.3g})", iteration=max_iterations, residual=res)


def _size(x, omega):
    """The Euclidean norm of (z0, v0 / Omega) [m, rad]: the orbit's size in the arclength."""
    n = len(x) // 2
    return float(np.linalg.norm(np.r_[x[:n], x[n:] / omega]))


def _multipliers(Phi):
    mu = np.linalg.eigvals(Phi)
    return mu[np.argsort(-np.abs(mu), kind="stable")]


def _fold(s, w, a):
    """Omega and amplitude at the vertex of the parabola Omega(s) through three points."""
    c = np.polyfit(s, w, 2)
    if c[0] == 0.0:
        return float(w[1]), float(a[1])
    sv = -c[1] / (2.0 * c[0])
    if not min(s) <= sv <= max(s):
        return float(w[1]), float(a[1])
    return float(np.polyval(c, sv)), float(np.polyval(np.polyfit(s, a, 2), sv))


@blas_pinned
def forced_response(model, *, frequencies: Sequence[float], load=None, load_factor: Optional[Sine] = None,
                    node: Optional[int] = None, component: Optional[int] = None, state=None,
                    mass_flow: Optional[float] = None, steps: int = STEPS_PER_PERIOD, max_points: int = 100,
                    ds: Optional[float] = None, max_step: Optional[float] = None, tol: float = 1e-9,
                    max_iterations: int = 12, newton_tol: float = 1e-12, rho_inf: float = 0.9,
                    backbone: bool = False, backbone_options: Optional[dict] = None) -> FrequencyResponse:
    """The nonlinear frequency response: T-periodic orbits under the load factor
    ``mean + A sin(Omega t + phase)`` continued in Omega from ``frequencies[0]`` towards
    ``frequencies[1]`` by pseudo-arclength, through the folds.

    Args:
        model: an element :class:`~pipeflex.Model`, a
            :class:`~pipeflex.multibody.MultibodySystem` or a :class:`~pipeflex.CoupledSystem`,
            damped (e.g. :meth:`ModelBuilder.rayleigh_damping`, the sections' ``eta_*``, a
            body's ``modal_damping``) so that the forced orbit is bounded and attracts.
        frequencies: (Omega_start, Omega_end) [rad/s], both > 0.
        load: a nodal load driven by A sin(Omega t + phase), added to a copy of the model,
            which must have no nodal loads of its own: an element model's (node, force [N])
            or (node, force [N], moment [N m]) or a dict with these keys; a
            MultibodySystem's (body, node, force[, moment]) or such a dict (node: an index
            or "start" / "end"). A coupled system takes ``load_factor=`` only.
        load_factor: a :class:`~pipeflex.Sine`: envelope A [-] (a number), phase [rad],
            mean [-]; its omega is replaced by each Omega. It scales all the model's
            nodal loads (a MultibodySystem's :meth:`~pipeflex.multibody.MultibodyBuilder.add_load`
            loads; with ``load=``: that load; default A = 1).
        node: the node whose coordinate's amplitude is recorded (default the loaded node;
            with bodies a point of the stacked nodes, as in :attr:`~pipeflex.PeriodicOrbit.x`).
        component: 0, 1, 2 = x, y, z of that node (default the load's largest force component).
        state: the chart's base (default the reference configuration at rest); the
            amplitude is the displacement from it, the first orbit's Newton starts there.
        mass_flow: mdot [kg/s] (default the model's).
        steps: N, generalised-alpha steps per period (h = 2 pi / (N Omega)); the response
            is that of the discrete map: its frequencies are shifted by about
            (Omega h)^2 / 12 relative.
        max_points: orbits on the curve at most.
        ds: first step in the scaled arclength (x0 over the largest orbit's size so far,
            the norm of (z0, v0 / Omega), Omega over abs(Omega_end - Omega_start)); default 0.05. Halved on a failure or where the
            corrector moves the predictor by more than 2 MISS of the step, grown 1.5 times
            where it moves it by less than MISS / 2, up to ``max_step`` (default 10 ds).
        tol: Newton tolerance on the periodicity defect, the largest of abs(z_T - z0) and
            abs(v_T - v0) / Omega [m, rad] (the integrator's ``newton_tol`` bounds how low
            it can go: about 1e-10 of the model's size).
        max_iterations: Newton iterations per orbit.
        newton_tol, rho_inf: the integrator's options (as :func:`pipeflex.simulate`);
            rho_inf = 0.9 damps the stiff modes a rough Newton iterate excites (e.g. the
            steel Coriolis tube's axial ones at rho_inf = 1) and leaves a slow mode alone
            (its spectral radius differs from 1 by O((omega h)^4)); rho_inf = 1 is the
            trapezoidal rule, whose response is exactly the continuous one at
            2 / h tan(Omega h / 2).
        backbone: also compute the :func:`backbone` (the model's undamped free
            oscillation at the watched coordinate, up to the curve's largest amplitude);
            ``backbone_options``: its keyword arguments.

    Returns:
        :class:`FrequencyResponse`; ``stats``: flow maps, their Newton iterations, the
        orbits' shooting iterations, wall time [s].

    Raises:
        ValueError: bad input (frequencies <= 0, no forcing, a load_factor that is not a Sine).
        ConvergenceError: no orbit at the first frequency.
    """
    import time

    t_start = time.perf_counter()
    w0, w1 = _frequencies(frequencies)
    model, forcing, load_node, load_component = _forcing(model, load, load_factor)
    node = load_node if node is None else node
    component = (1 if load_component is None else load_component) if component is None else component
    chart = _chart(model, state)
    watch = _watch(chart, node, component)
    steps = _checks.flow_map_steps("steps", steps, chart.n)
    tol = _checks.positive("tol", tol)
    max_points = _checks.positive_int("max_points", max_points)
    max_iterations = _checks.positive_int("max_iterations", max_iterations)
    mdot = float(getattr(model, "mass_flow", 0.0)) if mass_flow is None else _checks.finite("mass_flow", mass_flow)
    sh = _Forced(model, chart, steps, _options(chart, newton_tol, rho_inf), forcing, mdot)
    n2 = 2 * chart.n

    x, omega, out, it, res = _newton(sh, np.zeros(n2), w0, tol=tol, max_iterations=max_iterations)
    Phi = out["monodromy"]
    dF = sh.d_omega(x, omega)
    # scales of the arclength: the first orbit's size (or a small fraction of the model's),
    # rates times Omega; Omega over the span
    size = max(_size(x, omega), 1e-9 * chart.length_scale)
    s = np.r_[np.full(n2 // 2, size), np.full(n2 // 2, size * max(w0, w1)), abs(w1 - w0)]
    direction = 1.0 if w1 > w0 else -1.0
    # first tangent: (Phi - I) dx + dF dOmega = 0 with dOmega along the span
    dx = np.linalg.solve(Phi - np.eye(n2), -dF * direction)
    t = np.r_[dx, direction] / s
    t /= np.linalg.norm(t)
    ds = 0.05 if ds is None else _checks.positive("ds", ds)
    max_step = 10.0 * ds if max_step is None else _checks.positive("max_step", max_step)
    h = ds
    pts = []

    def keep(x, omega, out, res):
        mu = _multipliers(out["monodromy"])
        pts.append(dict(x=x, omega=omega, amplitude=sh.amplitude(out, watch), mu=mu, residual=res,
                        stable=bool(np.abs(mu).max(initial=0.0) <= 1.0 + NEUTRAL)))

    keep(x, omega, out, res)
    iterations = [it]
    while len(pts) < max_points:
        y_prev = np.r_[x, omega]
        y_pred = y_prev + h * t * s
        try:
            xn, wn, out_n, it, res = _newton(sh, y_pred[:n2], y_pred[n2], tol=tol, max_iterations=max_iterations,
                                             Phi=Phi, dF=dF, arc=(y_prev, t, h, s))
        except (ConvergenceError, np.linalg.LinAlgError) as exc:
            h *= 0.5
            logger.info("forced_response: no orbit at step %.3g (%s); halving the step", 2 * h, exc)
            if h < 1e-6 * ds:
                break
            continue
        # the orbit's size scales x0 in the arclength: the running largest, so that the
        # steps follow the curve as its amplitude grows (the secant tangent rescaled)
        grown = _size(xn, wn)
        if grown > size:
            size = grown
            s = np.r_[np.full(n2 // 2, size), np.full(n2 // 2, size * max(w0, w1)), abs(w1 - w0)]
        miss = float(np.linalg.norm((np.r_[xn, wn] - y_pred) / s)) / h
        logger.debug("forced_response: step %.3g, miss %.3g, size %.3g", h, miss, size)
        new_t = (np.r_[xn, wn] - y_prev) / s
        new_t /= np.linalg.norm(new_t)
        x, omega, Phi = xn, wn, out_n["monodromy"]
        dF = sh.d_omega(x, omega)
        t = new_t
        keep(x, omega, out_n, res)
        iterations.append(it)
        logger.info("forced_response: orbit %d at Omega = %.8g rad/s: amplitude %.4g m, %s (%d iterations)",
                    len(pts), omega, pts[-1]["amplitude"], "stable" if pts[-1]["stable"] else "unstable", it)
        if (omega - w1) * direction >= 0.0 or (omega - w0) * direction < 0.0:
            break  # past the end, or turned back below the start
        # the step by the predictor's miss (the curve's turn over the step), not by
        # Newton's iterations (chord iterations converge linearly: their count follows tol)
        if miss < 0.5 * MISS:
            h = min(1.5 * h, max_step)
        elif miss > 2.0 * MISS:
            h *= 0.5
    w = np.array([p["omega"] for p in pts])
    a = np.array([p["amplitude"] for p in pts])
    # folds: Omega turns between consecutive steps; located at the vertex of the parabola
    # through the three points around the turn (in the arclength of the scaled curve)
    # (in the amplitude and Omega, scaled by their ranges)
    ys = np.c_[w / max(np.ptp(w), 1e-300), np.array([p["amplitude"] for p in pts]) / max(np.ptp(a), 1e-300)]
    arc = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(ys, axis=0), axis=1))]
    folds, fold_amps = [], []
    dw = np.diff(w)
    for k in range(1, len(dw)):
        if dw[k] * dw[k - 1] < 0.0:
            f, fa = _fold(arc[k - 1:k + 2], w[k - 1:k + 2], a[k - 1:k + 2])
            folds.append(f)
            fold_amps.append(fa)
    bb = None
    if backbone:
        opts = {"node": watch[0], "component": watch[1], "amplitude_max": float(a.max()), "state": state,
                **(backbone_options or {})}
        bb = _free_backbone(model, **opts)  # (the argument ``backbone`` hides the function)
    mu = np.array([p["mu"] for p in pts])
    return FrequencyResponse(
        frequency=w, amplitude=a, stable=np.array([p["stable"] for p in pts]), multipliers=mu,
        max_multiplier=np.abs(mu).max(axis=1), residual=np.array([p["residual"] for p in pts]),
        folds=np.array(folds), fold_amplitudes=np.array(fold_amps), starts=np.array([p["x"] for p in pts]),
        base=chart.base, node=watch[0], component=watch[1], forcing=tuple(forcing), steps=steps, backbone=bb,
        stats={"flow_maps": sh.calls, "newton_iterations": sh.newton_iterations,
               "shooting_iterations": int(np.sum(iterations)), "iterations": iterations, "seconds": time.perf_counter() - t_start})


# -- the backbone -------------------------------------------------------------------------

def _rebuilt(model, edit, *, mass_flow=None, what="this"):
    """The element ``model`` built again from its description after ``edit(builder)``."""
    from ..model import ModelBuilder

    d = getattr(model, "_description", None)
    if d is None:
        raise ValueError(f"{what} needs a model built by ModelBuilder.build (its description is rebuilt)")
    b = ModelBuilder()
    vars(b).update(copy.deepcopy(d))
    edit(b)
    out = b.build(mass_flow=model.mass_flow if mass_flow is None else mass_flow,
                  floating=d.get("_floating", False))
    out.info.update(model.info)
    return out


def damped(model, *, alpha: float = 0.0, beta: float = 0.0):
    """A copy of the element ``model`` with Rayleigh damping ``alpha M + beta K``
    (:meth:`ModelBuilder.rayleigh_damping`: alpha [1/s], beta [s]; it replaces the
    model's own Rayleigh damping, the sections' damping stays): e.g. a scene built
    undamped, made fit for :func:`forced_response` (a forced orbit is bounded and
    attracts only with damping). A mode of angular frequency omega gets the damping
    ratio alpha / (2 omega) + beta omega / 2."""
    return _rebuilt(model, lambda b: b.rayleigh_damping(alpha=alpha, beta=beta), what="damped")


def _undamped(model):
    """A copy of the element ``model`` without damping and nodal loads at zero flow: the
    sections' eta_* and c_ext, the Rayleigh damping and the springs' dampers set to 0."""
    quiet = {}

    def still(sec):  # one undamped section per distinct section (shared by its elements)
        if id(sec) not in quiet:
            quiet[id(sec)] = replace(sec, eta_axial=0.0, eta_bending=0.0, eta_torsion=0.0, c_ext=0.0)
        return quiet[id(sec)]

    def edit(b):
        for e in b._elements + b._ancf:
            e["section"] = still(e["section"])
        for sp in b._springs:
            for key in ("c", "c_phi"):
                if key in sp:
                    sp[key] = 0.0 * np.asarray(sp[key]) if np.ndim(sp[key]) else 0.0
        b._rayleigh = (0.0, 0.0)
        b._loads = []  # the free oscillation: no nodal loads (the forcing among them)

    return _rebuilt(model, edit, mass_flow=0.0, what="backbone")


@blas_pinned
def backbone(model, *, node: int, component: int, amplitude_max: float, frequency: Optional[float] = None,
             n_points: int = 20, state=None, steps: int = 4 * STEPS_PER_PERIOD, tol: float = 1e-9,
             max_iterations: int = 20, newton_tol: float = 1e-13) -> Backbone:
    """The backbone: the amplitude-frequency relation of the free undamped oscillation (the
    nonlinear normal mode) of an element model at zero flow, at one node coordinate.

    The model's damping and nodal loads are removed (:func:`_undamped`: sections'
    ``eta_*``, ``c_ext``, Rayleigh damping, spring dampers) and the flow set to 0 (gravity
    stays: give its static equilibrium as ``state``), so the equations are
    conservative and time-reversible: an orbit that starts at rest at z0 and is at rest
    again at T / 2 is periodic with period T and symmetric. Shooting solves
    ``v(T / 2) = 0`` for the other coordinates of z0 and T, the watched coordinate's
    displacement held at each amplitude (natural continuation from the linear mode, with
    a secant predictor). The flow map is generalised-alpha with rho_inf = 1 (no numerical
    damping, time-symmetric) in ``steps / 2`` steps per half period; with no damping its
    Newton needs shorter steps than the damped forced response's on stiff (e.g. axial)
    modes, hence more steps by default. The predictor is the parabola through the last
    three orbits (a bending mode shortens the beam axially by a^2).

    Args:
        model: an element :class:`~pipeflex.Model` built by :class:`~pipeflex.ModelBuilder`.
        node, component: the watched coordinate (0, 1, 2 = x, y, z), a free translation of
            the node.
        amplitude_max: the largest displacement [m] of that coordinate.
        frequency: omega [rad/s] near the linear mode to follow (default the lowest mode
            that moves the coordinate).
        n_points: orbits at amplitudes amplitude_max k / n_points [m], k = 1 .. n_points,
            after two at a quarter and half of the first.
        state: the base (default the reference configuration): displacements from it.
        steps: N, steps per period (even).
        tol: Newton tolerance on max abs(v(T / 2)) / omega relative to the amplitude [-].
        max_iterations: Newton iterations per orbit; newton_tol: the integrator's.

    Returns:
        :class:`Backbone`.

    Raises:
        ValueError: bad input (the coordinate is not a free translation, amplitude_max <= 0).
        ConvergenceError: an orbit not found (e.g. past an internal resonance).
    """
    from .eigen import eigenvalues
    from .linearize import linearize

    from ..model import Model

    if not isinstance(model, Model):
        # the shooting holds the watched node's translation, a coordinate of an element
        # model; a body's node moves by its frame and its modes together
        raise ValueError(f"backbone needs an element pipeflex.Model: it holds a node's translation coordinate at "
                         f"each amplitude, and a {type(model).__name__}'s nodes move with their bodies' frames and "
                         "modes (follow its free oscillation with pipeflex.continue_orbits instead)")
    amax = _checks.positive("amplitude_max", amplitude_max)
    n_points = _checks.positive_int("n_points", n_points)
    half = max(_checks.positive_int("steps", steps) // 2, 8)
    tol = _checks.positive("tol", tol)
    free = _undamped(model)
    chart = _chart(free, state)
    node, component = _watch(chart, node, component)
    try:
        k = free.dof_index(node, "u" + "xyz"[component])
    except (ValueError, KeyError, IndexError) as exc:
        raise ValueError(f"node {node}'s {'xyz'[component]} translation is not a free coordinate of the model "
                         f"(the backbone holds it at each amplitude): {exc}") from None
    n = chart.n
    lin = linearize(free, chart.base, mass_flow=0.0)
    ev = eigenvalues(lin, vectors=True)
    lam, vec = np.asarray(ev.values), np.asarray(ev.vectors)
    basis = getattr(lin, "basis", None)
    if vec.shape[0] != n and basis is not None:  # (independent coordinates of a constrained linearisation)
        vec = np.asarray(basis @ vec)
    up = (lam.imag > 0) & (np.abs(vec[k]) > 1e-6 * np.abs(vec).max(axis=0))
    if not up.any():
        raise ValueError(f"no mode of the undamped model moves node {node}'s {'xyz'[component]} translation")
    cand = np.flatnonzero(up)
    j = cand[np.argmin(np.abs(lam.imag[cand] - frequency))] if frequency is not None else \
        cand[np.argmin(lam.imag[cand])]
    phi = vec[:, j]
    phi = (phi / phi[k]).real
    omega0 = float(lam.imag[j])
    others = np.r_[0:k, k + 1:n]
    opt = _options(chart, newton_tol, 1.0)
    calls = [0]

    def half_map(z0, T, sens):
        calls[0] += 1
        return _core.flow_map(chart.system(0.0), 0.0, z0, np.zeros(n), 0.5 * T, half, sens, opt)

    amps, freqs, periods = [], [], []
    sols = []  # (a, z0, T)
    # two smaller amplitudes first: the secant predictor then brings the coordinates the
    # linear mode leaves out (e.g. the axial shortening of a bending mode), without which a
    # large start excites the stiff modes that the undamped integrator cannot carry
    levels = amax * np.r_[0.25 / n_points, 0.5 / n_points, np.arange(1, n_points + 1) / n_points]
    for a in levels:
        if len(sols) >= 3:  # the parabola through the last three (axial shortening ~ a^2)
            aa = np.array([q[0] for q in sols[-3:]])
            L = [np.prod([(a - aa[j]) / (aa[i] - aa[j]) for j in range(3) if j != i]) for i in range(3)]
            z0 = sum(w * q[1] for w, q in zip(L, sols[-3:]))
            T = sum(w * q[2] for w, q in zip(L, sols[-3:]))
        elif len(sols) == 2:  # secant predictor in the amplitude
            (a1, z1, T1), (a2, z2, T2) = sols[-2], sols[-1]
            r = (a - a2) / (a2 - a1)
            z0, T = z2 + r * (z2 - z1), T2 + r * (T2 - T1)
        elif sols:
            a2, z2, T2 = sols[-1]
            z0, T = z2 * (a / a2), T2
        else:
            z0, T = a * phi, 2 * np.pi / omega0
        z0 = np.array(z0, float)
        z0[k] = a
        Jinv = None
        out = half_map(z0, T, True)
        for it in range(1, max_iterations + 1):
            G = out["v"]
            res = float(np.abs(G).max()) * T / (2 * np.pi)
            if res <= tol * a + 10.0 * newton_tol * chart.length_scale:  # (the flow map's own floor)
                break
            if "monodromy" in out:
                Phi = out["monodromy"]
                J = np.c_[Phi[n:, :n][:, others], 0.5 * out["a"]]
                # (a stiff undamped mode whose half period nearly divides T / 2 makes J
                # nearly singular: its direction is cut off rather than amplified)
                Jinv = np.linalg.pinv(J, rcond=1e-9)
            du = -Jinv @ G
            # at most a fifth of the amplitude per step, halved while the flow map fails
            # or the defect grows tenfold
            du *= min(1.0, 0.2 * a / max(float(np.abs(du[:-1]).max()), 1e-300))
            for _ in range(8):
                z_try, T_try = z0.copy(), T + du[-1]
                z_try[others] += du[:-1]
                try:
                    out_try = half_map(z_try, T_try, it % 3 == 0)
                    if float(np.abs(out_try["v"]).max()) * T_try / (2 * np.pi) <= 10.0 * res:
                        break
                except ConvergenceError:
                    pass
                du *= 0.5
            else:
                raise ConvergenceError(f"backbone: no Newton step lowers the defect {res:.3g} at amplitude {a:.4g} m",
                                       iteration=it, residual=res)
            z0, T, out = z_try, T_try, out_try
        else:
            raise ConvergenceError(f"backbone: no free periodic orbit at amplitude {a:.4g} m of node {node} "
                                   f"(defect {res:.3g} after {max_iterations} iterations); an internal resonance "
                                   "or a turning backbone: lower amplitude_max", iteration=max_iterations,
                                   residual=res)
        sols.append((a, z0.copy(), T))
        x = chart.positions(out["z"])[:, node, component] - chart.positions(np.zeros(n))[0, node, component]
        amps.append(max(_peak(np.r_[x, x[::-1][1:]]), abs(a)))
        freqs.append(2 * np.pi / T)
        periods.append(T)
    return Backbone(frequency=np.array(freqs), amplitude=np.array(amps), period=np.array(periods), node=node,
                    component=component, stats={"flow_maps": calls[0], "linear_frequency": omega0})


_free_backbone = backbone


# -- the transient check ----------------------------------------------------------------

def frequency_sweep(model, *, frequencies: Sequence[float], load=None, load_factor: Optional[Sine] = None,
                    node: Optional[int] = None, component: Optional[int] = None, state=None,
                    mass_flow: Optional[float] = None, periods: int = 40, measure: int = 5,
                    steps: int = 64, rho_inf: float = 0.9) -> FrequencySweep:
    """A stepped-sine sweep by transients: at each Omega in turn (the order given: up or
    down), ``periods`` periods of the forcing from the last state, the amplitude measured
    over the last ``measure`` of them. The forcing's phase is continuous across the steps.
    Its amplitude follows the stable branch it is on and jumps past a fold: the transient
    check of :func:`forced_response`'s folds.

    Args:
        model, load, load_factor, node, component, mass_flow: as :func:`forced_response`
            (bodies and coupled systems run the flow map, as :func:`forced_response`).
        frequencies: the Omega [rad/s] (> 0) to step through, in order.
        state: the start (default the reference configuration at rest) and the base the
            amplitude is measured from.
        periods: forcing periods integrated at each Omega (enough for the transient to
            decay: several times 1 / (zeta Omega) / (2 pi)).
        measure: the last periods at each Omega over which the amplitude is taken.
        steps: generalised-alpha steps per period; rho_inf: its spectral radius.

    Returns:
        :class:`FrequencySweep`; ``stats["seconds"]`` the wall time.
    """
    import time

    from ..model import Model
    from .transient import simulate

    t_start = time.perf_counter()
    w = np.asarray(frequencies, float)
    if w.ndim != 1 or len(w) < 1 or not np.all(np.isfinite(w)) or np.any(w <= 0.0):
        raise ValueError(f"frequencies must be a sequence of positive finite Omega [rad/s], got {frequencies!r}")
    model, (mean, amp, phase), load_node, load_component = _forcing(model, load, load_factor)
    node = load_node if node is None else node
    component = (1 if load_component is None else load_component) if component is None else component
    chart = _chart(model, state)
    node, component = _watch(chart, node, component)
    periods = _checks.positive_int("periods", periods)
    measure = _checks.positive_int("measure", measure)
    if measure > periods:
        raise ValueError(f"measure must be at most periods = {periods}, got {measure}")
    steps = _checks.positive_int("steps", steps)
    ref = chart.positions(np.zeros(chart.n))[0, node, component]
    st, t = chart.base, 0.0
    theta = phase  # the forcing's angle Omega t + phase at the step's start
    amps = []
    element = isinstance(model, Model)
    mdot = float(model.mass_flow) if mass_flow is None else _checks.finite("mass_flow", mass_flow)
    for om in w:
        T = 2 * np.pi / om
        t_end = t + periods * T
        # this step's carrier om t + p continues the last: om t + p = theta at its start
        p = float(np.mod(theta - om * t, 2 * np.pi))
        if element:
            run = simulate(model, t_end, t_start=t, state=st, n_outputs=periods * steps + 1, step=T / steps,
                           load_factor=Sine(omega=float(om), envelope=amp, phase=p, mean=mean), mass_flow=mass_flow,
                           integrator="generalized_alpha", rho_inf=rho_inf, progress=False)
            keep = run.t >= t_end - measure * T - 1e-12 * t_end
            x, st = run.x[keep, node, component], run.final_state
        else:  # bodies: the flow map from the step's start in its chart (as orbit_guess), its time from 0
            out = _core.flow_map(chart.system(mdot), mdot, np.zeros(chart.n), chart.coordinates(chart.base)[1],
                                 periods * T, periods * steps, False, _options(chart, 1e-10, rho_inf),
                                 load_factor=_table((mean, amp, theta), om))
            x = chart.positions(out["z"][-(measure * steps + 1):])[:, node, component]
            chart = _chart(model, chart.state(out["z"][-1], out["v"]))
            st = chart.base
        amps.append(float(np.abs(x - ref).max()))
        theta = float(np.mod(om * t_end + p, 2 * np.pi))
        t = t_end
    return FrequencySweep(frequency=w, amplitude=np.array(amps), node=node, component=component, final_state=st,
                          stats={"seconds": time.perf_counter() - t_start})
