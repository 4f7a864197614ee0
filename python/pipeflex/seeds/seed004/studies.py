"""Seed 004 studies (floating frame of reference): the cantilever's flutter (Figs. 4, 5,
7), the curved pipe (Figs. 9, 10, Table 1), the concrete printer (Fig. 12) and the
accuracy-versus-cost charts. Shared by ``pipeflex validate``, the notebooks, the
benchmarks and the tests; every number is computed by the FFRF bodies of
:mod:`pipeflex.multibody` or the seed-000 element.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Dict, Optional, Sequence

import numpy as np

from ... import _checks
from ..._options import scene_mass_flow
from ...analysis import critical_mass_flow, simulate, static_equilibrium, steady_rotation
from ...errors import ConvergenceError
from ...multibody import simulate as mb_simulate, static_equilibrium as mb_static
from ...sections import PipeSection
from ...signals import cycle_metrics
from ..seed000.limit_cycle import limit_cycle_model
from . import scenes
from .references import TABLE1_FFRF, TABLE1_SPACAR

#: Seed 004, sec. 8.1: the cantilever's flow speed [m/s] and tip force [N].
CANTILEVER_FLOW_SPEED = 15.0
CANTILEVER_TIP_FORCE = 1.5
#: Seed 004, sec. 8.3: concrete flow speeds [m/s] and the simulated time [s].
PRINTER_FLOW_SPEEDS = (0.0, 3.0, 6.0)
PRINTER_DURATION = 0.34


@dataclass
class Trace:
    """A time history: ``t`` [s], ``y`` (the output, unit in ``label``), wall time [s]."""

    label: str
    t: np.ndarray
    y: np.ndarray
    wall_time: float
    size: int  # independent DOF (FFRF: coordinates minus constraint equations)
    failed_at: Optional[float] = None  # time [s] at which the solver failed (the trace stops before)


def ffrf_cantilever_tip(*, n_bodies: int, elements_per_body: int = 20, internal_modes: int = 0,
                        t_end: float = 2.0, step: float = 1e-3, rtol: Optional[float] = None, n_outputs: int = 401,
                        rho_inf: Optional[float] = None, until_failure: bool = False,
                        flow_speed: float = CANTILEVER_FLOW_SPEED) -> Trace:
    """Tip deflection [m] (along the 1.5 N tip force, global z) of the FFRF cantilever of
    sec. 8.1: static deflection without flow, then sdot = ``flow_speed`` [m/s] (the seed's
    15 m/s: mdot = 30 kg/s) from t = 0 on (a sudden start, as seed 000's Fig. 3), to
    ``t_end`` [s] with the fixed ``step`` [s] and ``rho_inf``, or, if ``rtol`` [-] is given,
    with its error-controlled step instead (Fig. 4: rtol 3e-3; Fig. 5: 1.5e-3).

    ``until_failure``: if the integration fails (a diverging model), return the run up to
    0.05 s before the failure, with the failure time in ``Trace.failed_at``, instead of
    raising :class:`~pipeflex.ConvergenceError`.

    ``rho_inf`` (generalised-alpha) defaults to 0.9, and to 0.8 with internal modes: their
    high frequencies, coupled by the FFRF's small-deformation terms at a large deflection
    of each body, turn unstable (2 bodies with 20 modes: Re lambda ~ 3 1/s at 75 rad/s
    when the tip is 0.35 m out) and the run fails at 2.6 s with 0.9."""
    rho = (0.8 if internal_modes else 0.9) if rho_inf is None else rho_inf
    s = scenes.ffrf_cantilever_pipe(n_bodies=n_bodies, elements_per_body=elements_per_body,
                                    internal_modes=internal_modes, tip_force=CANTILEVER_TIP_FORCE)
    sdot = flow_speed
    mdot = s.bodies[0].section.fluid_mass * sdot
    w = time.perf_counter()
    st = mb_static(s, mass_flow=0.0).state
    failed_at = None

    def run(t1):
        if rtol is None:
            return mb_simulate(s, t1, step=step, state=st, mass_flow=mdot, n_outputs=n_outputs, rho_inf=rho)
        return simulate(s, t1, rtol=_checks.positive("rtol", rtol), state=st, mass_flow=mdot, n_outputs=n_outputs,
                        progress=False)

    try:
        res = run(t_end)
    except ConvergenceError as e:
        if not until_failure or e.time is None or e.time - 0.05 <= step:
            raise
        failed_at = e.time
        res = run(failed_at - 0.05)
    wall = time.perf_counter() - w
    label = f"FFRF {n_bodies} bod{'ies' if n_bodies > 1 else 'y'}" + \
            (f", {internal_modes} internal modes" if internal_modes else "")
    return Trace(label, res.t, res.node_position(*s.info["tip"])[:, 2], wall, s.n_dofs, failed_at)


def element_cantilever_tip(*, n_elements: int = 8, t_end: float = 2.0, step: float = 1e-3,
                           rtol: Optional[float] = None, n_outputs: int = 401) -> Trace:
    """The same run with seed 000's element (the seed's Spacar reference, Fig. 4 grey), to
    ``t_end`` [s] with the fixed ``step`` [s], or, if ``rtol`` [-] is given, with its
    error-controlled step instead: tip deflection [m] along the tip force (global y in
    that model)."""
    model, tip = limit_cycle_model(n_elements=n_elements, tip_force=CANTILEVER_TIP_FORCE,
                                   mass_flow=2.0 * CANTILEVER_FLOW_SPEED)
    steps = dict(step=_checks.positive("step", step)) if rtol is None else dict(rtol=_checks.positive("rtol", rtol))
    w = time.perf_counter()
    st = static_equilibrium(model, mass_flow=0.0).state
    res = simulate(model, t_end, integrator="generalized_alpha", state=st, n_outputs=n_outputs, progress=False,
                   **steps)
    return Trace(f"seed-000 element, {n_elements} elements", res.t, res.x[:, tip, 1], time.perf_counter() - w,
                 model.n_dofs)


def cycle_summary(trace: Trace, *, after: float) -> Dict[str, float]:
    """Amplitude [m] and period [s] of a tip trace after ``after`` [s]."""
    amp, period, _ = cycle_metrics(trace.t, trace.y, after=after)
    return {"amplitude": amp, "period": period}


def ffrf_cycle_branch(mass_flows: Sequence[float], *, n_bodies: int, t_end: float = 6.0, settle: float = 3.0,
                      step: float = 1e-3) -> Dict[str, np.ndarray]:
    """The FFRF cantilever's limit cycle at each mass flow [kg/s] by long transients (the
    stable cycles only; the elements' cycles are continued by pipeflex.continue_orbits):
    ``amplitude`` [m] and ``period`` [s] of the tip's motion along the tip force after
    ``settle`` [s] of a ``t_end`` [s] run, and ``mass_flow``."""
    mu_f = scenes.ffrf_cantilever_pipe(n_bodies=1).bodies[0].section.fluid_mass
    amp, period = [], []
    for mdot in mass_flows:
        tr = ffrf_cantilever_tip(n_bodies=n_bodies, t_end=t_end, step=step, n_outputs=int(round(t_end / step)) + 1,
                                 flow_speed=mdot / mu_f)
        c = cycle_summary(tr, after=settle)
        amp.append(c["amplitude"])
        period.append(c["period"])
    return {"mass_flow": np.asarray(mass_flows, float), "amplitude": np.array(amp), "period": np.array(period)}


@dataclass
class OrbitStudy:
    """A flutter branch continued from its Hopf point (``ffrf_orbit_branch``): ``branch``
    (a :class:`~pipeflex.OrbitBranch`) and the tip's point index ``tip`` in the orbits'
    positions; ``reference``: the element model's branch of the same pipe (``mass_flow``
    [kg/s], ``amplitude`` [m] (the tip's lateral half range), ``period`` [s], ``stable``,
    ``max_multiplier``, ``hopf`` (mdot_c, omega_c)), if computed."""

    branch: object
    tip: int
    reference: Optional[Dict[str, np.ndarray]] = None

    @property
    def tip_amplitude(self) -> np.ndarray:
        """Half peak-to-peak of the tip's lateral motion [m], per orbit: the straight pipe's
        orbits are planar, in a plane through its axis that the critical mode picks, so
        the hypotenuse of the y and z half ranges."""
        return lateral_amplitude(self.branch.amplitude[:, self.tip])


def lateral_amplitude(amplitude) -> np.ndarray:
    """hypot of the y and z entries of half peak-to-peak ranges (..., 3) [m]."""
    a = np.asarray(amplitude, float)
    return np.hypot(a[..., 1], a[..., 2])


def element_cantilever_model(*, n_elements: int, tip_force: float = CANTILEVER_TIP_FORCE):
    """The element model of the FFRF cantilever's pipe (the scene's section: seed 000's
    Table 2 pipe with seed 004's tube's EA, GJ and polar rotary inertia), clamped at the
    origin along x, with ``tip_force`` [N] along global z at the free end; returns the
    model and its tip node."""
    from ...model import ModelBuilder

    sec = scenes.ffrf_cantilever_pipe(n_bodies=1, elements_per_body=2).bodies[0].section
    b = ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    nodes = b.add_line(n0, (1.0, 0.0, 0.0), _checks.positive_int("n_elements", n_elements), sec)
    b.clamp(n0)
    b.add_load(nodes[-1], force=(0.0, 0.0, _checks.finite("tip_force", tip_force)))
    return b.build(), nodes[-1]


def ffrf_orbit_branch(*, n_bodies: int, mass_flow_end: Optional[float] = None, max_points: int = 12,
                      steps: int = 128, amplitude: float = 0.01, reference_elements: Optional[int] = None,
                      tip_force: float = 0.0) -> OrbitStudy:
    """The flutter limit cycle of the FFRF cantilever (sec. 8.1: ``n_bodies`` bodies of 20
    elements, boundary modes, ``tip_force`` [N] along z) continued in the mass flow from
    its Hopf point (:func:`pipeflex.critical_mass_flow`) by :func:`pipeflex.continue_orbits`:
    ``max_points`` orbits of ``steps`` steps per period, the first of amplitude about
    ``amplitude`` [m] along the critical mode, up to ``mass_flow_end`` [kg/s] (default the
    Hopf flow + 4 kg/s). With ``reference_elements`` the element model of the same pipe
    (:func:`element_cantilever_model`, that many elements) is continued the same way.

    The tip force is 0 by default (with the seed's 1.5 N and its formulation, the scene's
    ``fluid_lever_arm="reference"``, the loaded bodies report a spurious weakly growing mode
    near zero flow: docs/theory.md). The straight pipe is axisymmetric: its
    orbits are planar, in a plane the critical mode picks, and turning that plane about
    the axis is another orbit (a second multiplier 1)."""
    from ...analysis.periodic import continue_orbits

    def run(model):
        crit = critical_mass_flow(model)
        end = crit.mass_flow + 4.0 if mass_flow_end is None else _checks.finite("mass_flow_end", mass_flow_end)
        return continue_orbits(model, start=crit, mass_flow_end=end, amplitude=amplitude, max_points=max_points,
                               steps=steps)

    s = scenes.ffrf_cantilever_pipe(n_bodies=_checks.positive_int("n_bodies", n_bodies), tip_force=tip_force)
    body, node = s.info["tip"]  # its point in the orbits' positions: the bodies' nodes stacked
    tip = sum(b.n_nodes for b in s.bodies[:body]) + s.bodies[body].node_index(node)
    branch = run(s)
    reference = None
    if reference_elements is not None:
        model, tip_node = element_cantilever_model(n_elements=reference_elements, tip_force=tip_force)
        ref = run(model)
        reference = {"mass_flow": ref.mass_flow, "amplitude": lateral_amplitude(ref.amplitude[:, tip_node]),
                     "period": ref.period, "stable": ref.stable, "max_multiplier": ref.max_multiplier,
                     "hopf": ref.hopf}
    return OrbitStudy(branch=branch, tip=tip, reference=reference)


def ffrf_orbit_figure(studies: Sequence[OrbitStudy], *, labels: Sequence[str]):
    """The tip's lateral amplitude [m], the period [s] and the largest non-trivial Floquet
    multiplier's modulus against the mass flow [kg/s] of continued branches (one colour
    each, ``labels``), with the element model's branch of the first study that has one
    (black); the Hopf points as dots. Returns the figure."""
    import matplotlib.pyplot as plt

    fig, (ax_a, ax_t, ax_m) = plt.subplots(1, 3, figsize=(13, 4), constrained_layout=True)
    curves = [(lab, st.branch.mass_flow, st.tip_amplitude, st.branch.period, st.branch.max_multiplier,
               st.branch.hopf, dict(color=f"C{i}")) for i, (lab, st) in enumerate(zip(labels, studies))]
    ref = next((st.reference for st in studies if st.reference is not None), None)
    if ref is not None:
        curves.append(("elements", ref["mass_flow"], ref["amplitude"], ref["period"], ref["max_multiplier"],
                       ref["hopf"], dict(color="k", ls="--")))
    for label, m, amp, period, mult, (mc, wc), style in curves:
        ax_a.plot(np.r_[mc, m], np.r_[0.0, amp], label=label, **style)
        ax_t.plot(np.r_[mc, m], np.r_[2 * np.pi / wc, period], **style)
        ax_m.plot(m, mult, **style)
        for ax, y in ((ax_a, 0.0), (ax_t, 2 * np.pi / wc)):
            ax.plot(mc, y, "o", color=style["color"], ms=4)
    ax_a.set(xlabel="mass flow [kg/s]", ylabel="tip amplitude (lateral) [m]")
    ax_t.set(xlabel="mass flow [kg/s]", ylabel="period [s]")
    ax_m.set(xlabel="mass flow [kg/s]", ylabel=r"largest non-trivial $|\mu|$ [-]")
    ax_m.axhline(1.0, color="grey", lw=0.8)
    ax_a.legend(fontsize=8)
    return fig


def critical_flow_speed(system) -> float:
    """Critical flow speed sdot_cr [m/s] = mdot_cr / mu_f of a straight FFRF cantilever."""
    return critical_mass_flow(system).mass_flow / system.bodies[0].section.fluid_mass


def eigenvalue_curves(flow_speeds: Sequence[float], *, n_bodies: int = 8, n_modes: int = 4) -> np.ndarray:
    """Seed 004, Fig. 6: the ``n_modes`` lowest bending eigenvalues lambda [1/s] (one of each
    pair of equal bending planes, Im lambda >= 0) of the straight FFRF cantilever
    linearised at rest, per flow speed sdot [m/s], followed branch by branch (nearest
    eigenvalue to the previous speed's). Axial and torsional stiffness are raised 1e6-fold
    so that only bending modes remain in range (they do not couple with bending in the
    straight pipe). Shape (len(flow_speeds), n_modes), complex."""
    from ...analysis import eigenvalues
    from ...multibody import linearize

    n_modes = _checks.positive_int("n_modes", n_modes)
    sec = PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0, EA=1e6 * 2.5e4, GJ=1e6 * 7.69,
                      rotary_inertia=(6.4e-3, 0.0, 0.0))
    system = scenes.ffrf_cantilever_pipe(n_bodies=n_bodies, section=sec)
    out, prev = [], None
    for v in flow_speeds:
        lam = eigenvalues(linearize(system, mass_flow=2.0 * _checks.finite("flow speed", v))).values
        lam = lam[lam.imag >= -1e-9 * np.abs(lam).max()]
        if prev is None:
            lam = lam[np.argsort(lam.imag)]
            keep = [lam[0]]
            for x in lam[1:]:
                if abs(x - keep[-1]) > 1e-6 * abs(x):
                    keep.append(x)
            prev = np.array(keep[:n_modes])
        else:
            prev = np.array([lam[np.argmin(np.abs(lam - p))] for p in prev])
        out.append(prev)
    return np.array(out)


def eigenvalue_figure(flow_speeds, curves, critical_speed: Optional[float] = None):
    """Fig. 6: Im and Re of the lowest eigenvalues against the flow speed (drawn by
    :func:`pipeflex.plot.root_locus`)."""
    from ...plot import root_locus

    axes = root_locus(curves, flow_speeds, panels=("frequency", "growth"), parameter_label="flow speed [m/s]",
                      critical=critical_speed)
    fig = axes[0].figure
    fig.suptitle("seed 004, Fig. 6: eigenvalues of the cantilever against the flow speed", fontsize=10)
    fig.tight_layout()
    return fig


def critical_flow_vs_state_size(*, bodies: Sequence[int] = (1, 2, 4, 8, 16, 32),
                                modes: Sequence[int] = (0, 2, 4, 8, 12, 16, 24),
                                elements_per_body: int = 50) -> Dict[str, np.ndarray]:
    """Seed 004, Fig. 7: critical mass flow [kg/s] against the size of the first-order
    state vector 2 (12 + n_int) n_bodies, refining bodies (no internal modes) or the
    internal modes of one body (``elements_per_body`` elements: 51 nodes as the seed)."""
    out = {}
    for kind, values in (("bodies", bodies), ("modes", modes)):
        sizes, flows = [], []
        for v in values:
            s = scenes.ffrf_cantilever_pipe(n_bodies=v if kind == "bodies" else 1,
                                            internal_modes=0 if kind == "bodies" else v,
                                            elements_per_body=elements_per_body)
            sizes.append(2 * s.n_dofs)
            flows.append(critical_mass_flow(s).mass_flow)
        out[kind] = np.array(values)
        out[kind + "_size"] = np.array(sizes)
        out[kind + "_flow"] = np.array(flows)
    return out


def curved_pipe_run(E: float, *, n_bodies: int = 8, elements_per_body: int = 20, internal_modes: int = 0,
                    t_end: float = 4.0, step: float = 1e-3, rtol: Optional[float] = None, n_outputs: int = 401,
                    rho_inf: float = 0.8):
    """Seed 004, sec. 8.2: the semicircular pipe (Young's modulus ``E`` [Pa]) from rest,
    flow 10 m/s from t = 0, to ``t_end`` [s]: generalised-alpha with the fixed ``step``
    [s] and ``rho_inf`` [-], or, if ``rtol`` [-] is given, with its error-controlled step
    instead (Table 1 and Figs. 9-10: rtol 0.1). Returns (system, result, base angular
    velocity about y [rad/s] per output)."""
    s = scenes.ffrf_curved_pipe(E=E, n_bodies=n_bodies, elements_per_body=elements_per_body,
                                internal_modes=internal_modes)
    if rtol is None:
        res = mb_simulate(s, t_end, step=step, n_outputs=n_outputs, rho_inf=rho_inf)
    else:
        res = simulate(s, _checks.positive("t_end", t_end), rtol=_checks.positive("rtol", rtol),
                       n_outputs=n_outputs, progress=False)
    return s, res, res.node_angular_velocity(*s.info["base"])[:, 1]


def final_angular_velocity(t: np.ndarray, omega: np.ndarray, *, window: float = 0.5) -> float:
    """abs(omega) [rad/s] averaged over the last ``window`` [s] (the oscillations about the
    steady rotation average out)."""
    window = _checks.positive("window", window)
    t, omega = np.asarray(t, dtype=float), np.asarray(omega, dtype=float)
    if t.ndim != 1 or t.shape != omega.shape or t.size == 0:
        raise ValueError(f"t and omega must be equal-length 1-D arrays, got shapes {t.shape} and {omega.shape}")
    sel = t >= t[-1] - window
    return float(np.abs(np.mean(omega[sel])))


def element_curved_model(E: float, *, n_elements: int = 8, mass_flow: Optional[float] = None,
                         flow_speed: Optional[float] = None):
    """Seed 000's curved elements for the tube of seed 004, sec. 8.2: semicircle of radius
    0.5 m from a hinge at the origin (about global z, in the x-y plane), OD 36.80 mm, ID
    35.68 mm, 7870 kg/m^3, Young's modulus ``E`` [Pa], G = E / 2.6, finite EA, polar rotary
    inertia; water at ``flow_speed`` sdot [m/s] (default 10 m/s) or, instead, ``mass_flow``
    mdot [kg/s] = mu_f sdot, as :func:`~pipeflex.scenes.ffrf_curved_pipe`. Returns a
    :class:`~pipeflex.Model`."""
    import dataclasses

    from ...model import ModelBuilder

    E = _checks.positive("E", E)
    sec = scenes._tube(outer_diameter=0.0368, inner_diameter=0.03568, E=E, G=E / 2.6, density=7870.0,
                       fluid_density=1000.0)
    b = ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    b.add_arc(n0, center=(0.5, 0.0, 0.0), angle=-np.pi, normal=(0.0, 0.0, 1.0),
              n_elements=_checks.positive_int("n_elements", n_elements),
              section=dataclasses.replace(sec, rotary_inertia=(sec.rotary_inertia[0], 0.0, 0.0)))
    b.hinge(n0, (0.0, 0.0, 1.0))
    return b.build(mass_flow=scene_mass_flow(mass_flow, flow_speed, sec.fluid_mass, default=sec.fluid_mass * 10.0))


def element_curved_pipe(E: float, *, n_elements: int = 8) -> float:
    """Steady angular velocity [rad/s] of :func:`element_curved_model` by the direct
    steady-rotation solver."""
    return float(steady_rotation(element_curved_model(E, n_elements=n_elements)).omega)


def element_curved_run(E: float, *, n_elements: int = 8, t_end: float = 4.0, step: float = 1e-3,
                       rtol: Optional[float] = None, n_outputs: int = 401, rho_inf: float = 0.9):
    """The run of :func:`curved_pipe_run` with seed 000's elements
    (:func:`element_curved_model`, generalised-alpha to ``t_end`` [s], from rest, flow from
    t = 0) with the fixed ``step`` [s] and ``rho_inf`` [-], or, if ``rtol`` [-] is given,
    with its error-controlled step instead (Fig. 10: rtol 1e-2). Returns (times [s],
    angular velocity about the hinge axis at the base [rad/s])."""
    m = element_curved_model(E, n_elements=n_elements)
    steps = dict(step=_checks.positive("step", step), rho_inf=rho_inf) if rtol is None else \
        dict(rtol=_checks.positive("rtol", rtol))
    r = simulate(m, _checks.positive("t_end", t_end), integrator="generalized_alpha", n_outputs=n_outputs,
                 progress=False, work=False, **steps)
    return r.t, r.omega[:, 0, 2]


def printer_run(flow_speed: float, *, step: float = 2e-4, rtol: Optional[float] = None,
                t_end: float = PRINTER_DURATION, n_outputs: Optional[int] = None, junction_forces: bool = True):
    """Seed 004, sec. 8.3: static equilibrium under gravity and M_A(0) = -5000 N m (with the
    flow of ``flow_speed`` [m/s] running), then the driven motion to ``t_end`` [s] with the
    fixed ``step`` [s], or, if ``rtol`` [-] is given, with its error-controlled step instead
    (Fig. 12: rtol 1e-2). Returns (system, result, nozzle path (n, 3) [m]).
    ``n_outputs``: evenly spaced output times; default every ``step`` (one per fixed step),
    so that the path is drawn from computed points themselves (every 0.2 ms: a smooth curve).
    ``junction_forces=False``: without the flow's kink forces (the seed's formulation)."""
    s = scenes.concrete_printer(flow_speed=flow_speed, junction_forces=junction_forces)
    st = mb_static(s, load_steps=4).state
    if n_outputs is None:
        n_outputs = int(round(_checks.positive("t_end", t_end) / _checks.positive("step", step))) + 1
    if rtol is None:
        res = mb_simulate(s, t_end, step=step, state=st, n_outputs=n_outputs, rho_inf=0.8)
    else:
        res = simulate(s, _checks.positive("t_end", t_end), state=st, rtol=_checks.positive("rtol", rtol),
                       n_outputs=n_outputs, progress=False)
    return s, res, res.node_position(*s.info["nozzle"])


def nozzle_shift(paths: Dict[float, np.ndarray]) -> Dict[float, float]:
    """Largest distance [m] between the nozzle path with flow and the one without (the
    entry 0.0 of ``paths``: flow speed [m/s] -> (n, 3) path [m])."""
    if 0.0 not in paths:
        raise ValueError(f"paths needs the run without flow (key 0.0), got keys {sorted(paths)}")
    ref = paths[0.0]
    return {v: float(np.linalg.norm(p - ref, axis=1).max()) for v, p in paths.items() if v != 0.0}


# -- figures ---------------------------------------------------------------------------

def _figure(figsize=(7, 4)):
    import matplotlib.pyplot as plt

    return plt.subplots(figsize=figsize)


def tip_figure(traces: Sequence[Trace], reference: Optional[Trace], title: str):
    """Figs. 4, 5: tip deflection against time (:func:`pipeflex.plot.time_history`); the
    seed-000 reference in grey."""
    from ...plot import time_history

    fig, ax = _figure()
    runs = ([reference] if reference is not None else []) + list(traces)
    styles = ([dict(color="0.6", lw=2.5)] if reference is not None else []) + [dict(lw=1)] * len(traces)
    time_history([r.t for r in runs], [r.y for r in runs], quantity="tip deflection", unit="m",
                 labels=[r.label for r in runs], styles=styles, ax=ax, title=title)
    return fig


def fig7_figure(data: Dict[str, np.ndarray], table2: Dict[int, float]):
    """Fig. 7: critical mass flow against the state size (:func:`pipeflex.plot.parameter_curves`);
    filled squares: bodies, open squares: internal modes (the seed's filled and unfilled
    markers); open circles (the published style): seed 000's Table 2."""
    from ...plot import parameter_curves, published_points
    from ...plot.curves import readable_log_ticks

    fig, ax = _figure()
    n = np.array(sorted(table2))
    parameter_curves([data["bodies_size"], data["modes_size"]], [data["bodies_flow"], data["modes_flow"]],
                     xlabel="size of the state vector [-]", ylabel=r"critical mass flow $\dot m_{cr}$ [kg/s]",
                     labels=["n bodies, boundary modes", "1 body, internal modes"],
                     styles=["ks-", dict(color="k", marker="s", ls="--", mfc="none")],
                     xscale="log", ax=ax, title="seed 004, Fig. 7: critical flow vs state size", legend=False)
    published_points(2 * 6 * n, [table2[k] for k in n], ax=ax, color="tab:red", ms=10,
                     label="published: seed 000 Table 2 (n elements)")
    readable_log_ticks(ax)   # the state sizes span 1.5 decades: label 20, 30, 50, 100, ...
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def curved_figures(runs: Dict[float, tuple], element_runs: Optional[Dict[float, tuple]] = None):
    """Figs. 9 (base angular velocity, :func:`pipeflex.plot.time_history`) and 10 (final
    shapes, :func:`pipeflex.plot.paths`) from :func:`curved_pipe_run`; ``element_runs`` (per
    E, the (t, omega) of :func:`element_curved_run`) adds seed 000's transient in grey, as
    the seed draws Spacar's. Fig. 9 also shows the seed's Table 1 (its final angular
    velocities, floating frame and Spacar) as open circles at the last time, in the colour
    of the computed curve each belongs to, and an inset of the last 1.5 s where they can
    be told apart."""
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    from ...plot import STYLES, paths, published_points, time_history

    fig9, axes = plt.subplots(1, len(runs), figsize=(11, 3.8), sharey=True)
    fig10, ax10 = _figure((6, 4.5))
    shapes, labels = [], []
    for k, (ax, (E, (s, res, w))) in enumerate(zip(np.atleast_1d(axes), runs.items())):
        ts, ys, names, styles = [], [], [], []
        if element_runs and E in element_runs:
            te, we = element_runs[E]
            ts.append(te), ys.append(np.abs(we)), names.append("seed-000 element, 8 el.")
            styles.append(dict(color="0.6", lw=2.5))
        ts.append(res.t), ys.append(np.abs(w)), names.append("FFRF"), styles.append(dict(color="k", lw=1))
        time_history(ts, ys, quantity=r"$|\omega_y|$ at the base", unit="rad/s", labels=names, styles=styles,
                     ax=ax, title=f"$E$ = {E / 1e9:g} GPa", legend=False)
        t_last = float(res.t[-1])
        table1 = ((TABLE1_SPACAR[E], "0.6"), (TABLE1_FFRF[E], "k"))
        inset = ax.inset_axes([0.42, 0.08, 0.54, 0.32])  # below the final values
        window = t_last - 1.5
        for t_i, y_i, st in zip(ts, ys, styles):
            sel = np.asarray(t_i) >= window
            inset.plot(np.asarray(t_i)[sel], np.asarray(y_i)[sel], **st)
        for value, colour in table1:
            for a in (ax, inset):
                published_points([t_last], [value], ax=a, color=colour)
        shown = np.concatenate([np.asarray(y_i)[np.asarray(t_i) >= window] for t_i, y_i in zip(ts, ys)]
                               + [np.array([v for v, _ in table1])])
        pad = 0.25 * max(float(np.ptp(shown)), 1e-3)
        inset.set_ylim(shown.min() - pad, shown.max() + pad)
        inset.set_xlim(window, t_last + 0.1)
        inset.tick_params(labelsize=7)
        inset.grid(lw=0.3)
        inset.set_title(f"last 1.5 s (Table 1: {TABLE1_FFRF[E]:.3f}, {TABLE1_SPACAR[E]:.3f} rad/s)", fontsize=7)
        if k == 0:
            handles, _ = ax.get_legend_handles_labels()
            handles += [Line2D([], [], **dict(STYLES["published"], color="k"), label="published: Table 1, FFRF"),
                        Line2D([], [], **dict(STYLES["published"], color="0.6"), label="published: Table 1, Spacar")]
            ax.legend(handles=handles, fontsize=7, loc="upper right")
        else:
            ax.set_ylabel("")
        shapes.append(np.vstack(s.centre_line(res.state(len(res.t) - 1))))
        labels.append(f"$E$ = {E / 1e9:g} GPa")
    fig9.suptitle("seed 004, Fig. 9: angular velocity about y at the base", fontsize=10)
    fig9.tight_layout()
    s0 = next(iter(runs.values()))[0]
    shapes.append(np.vstack(s0.centre_line(s0.initial_state())))
    labels.append("initial")
    paths(shapes, plane="xz", labels=labels, styles=[dict(marker=".", ms=2)] * (len(shapes) - 1)
          + [dict(ls=":", color="0.5")], ax=ax10, title="seed 004, Fig. 10: deformed shapes at the last step")
    return fig9, fig10


def printer_figure(paths: Dict[float, np.ndarray], *, t_end: float = PRINTER_DURATION):
    """Fig. 12: left, the nozzle's trajectories in the x-y plane for the flow speeds, to
    scale (equal axes; :func:`pipeflex.plot.paths`); right, the distance [mm] of each
    trajectory with flow from the one without (the entry 0.0 of ``paths``) against time,
    the outputs taken evenly spaced over [0, ``t_end``] [s] (as :func:`printer_run` gives
    them). ``paths``: flow speed [m/s] -> (n, 3) nozzle path [m]."""
    import matplotlib.pyplot as plt

    from ...plot import parameter_curves, paths as draw_paths

    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(9, 5), gridspec_kw={"width_ratios": [1, 1.6]})
    colours = [f"C{k}" for k in range(len(paths))]
    draw_paths(list(paths.values()), plane="xy", labels=[f"{v:g} m/s" for v in paths], equal=True, ax=ax,
               styles=[dict(color=c, lw=1.2) for c in colours], legend_title="concrete flow",
               title="trajectories to scale (equal axes)")
    ax.set_aspect("equal", adjustable="datalim")  # equal scales; the panel keeps its size
    if 0.0 in paths:
        ref = paths[0.0]
        keys = [v for v in paths if v != 0.0 and len(paths[v]) == len(ref)]
        t = np.linspace(0.0, _checks.positive("t_end", t_end), len(ref))
        parameter_curves(t, [1e3 * np.linalg.norm(paths[v] - ref, axis=1) for v in keys], xlabel="time $t$ [s]",
                         ylabel="distance from the path without flow [mm]", labels=[f"{v:g} m/s" for v in keys],
                         styles=[dict(color=colours[list(paths).index(v)], lw=1.2) for v in keys], ax=ax2,
                         title="the flow's effect", legend_title="concrete flow")
    else:
        ax2.set_visible(False)
    fig.suptitle("seed 004, Fig. 12: nozzle D in the x-y plane, 0-0.34 s", fontsize=10)
    fig.tight_layout()
    return fig


def timed(fn, *args, **kwargs):
    """(result, wall time [s]) of one call."""
    w = time.perf_counter()
    out = fn(*args, **kwargs)
    return out, time.perf_counter() - w


def cheapest(costs: Sequence[float], errors: Sequence[float], labels: Sequence[str], *, tolerance: float):
    """The label of the cheapest model whose error is within ``tolerance`` (None if none)."""
    tol = _checks.positive("tolerance", tolerance)
    if not len(costs) == len(errors) == len(labels):
        raise ValueError(f"costs, errors and labels must have equal lengths, got {len(costs)}, {len(errors)}, "
                         f"{len(labels)}")
    ok = [(c, lab) for c, e, lab in zip(costs, errors, labels) if e <= tol]
    return min(ok)[1] if ok else None
