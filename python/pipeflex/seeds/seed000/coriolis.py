"""The Coriolis mass-flow rate meter of seed 000, section 4 (Figs. 6-8).

The meter is :func:`pipeflex.scenes.coriolis_meter`: a U-shaped tube in the global xy
plane, clamped at the ends of its two straight legs, vibrating mainly out of its plane
(global z). Its "first mode" here is the lowest mode whose motion is mainly out of the
plane: the swinging of the U about an axis perpendicular to the legs (global y), with
a flow-induced twist about an axis parallel to the legs superimposed on it (seed 000).

At every flow the equations are linearised about the static equilibrium under that
flow (:func:`pipeflex.static_equilibrium`), so the normal force that supplies the
fluid's centripetal acceleration is included; ``about_equilibrium=False`` linearises
about the undeformed shape instead, which neglects that normal force, as the
reference [9] of the seed did.

Scales (seed 000, Fig. 7): ``omega0 = sqrt(EI / (rho_p A_p + rho_f A_f)) / a^2`` [rad/s]
and ``mdot0 = sqrt(rho_f A_f EI) / a`` [kg/s], with a the radius of the arc.

Time lag (Fig. 8): with the first mode's out-of-plane displacement at the sensors
``w_k = |w_k| exp(i phi_k)`` (k = 1: S1, inlet end of the arc; k = 2: S2, outlet end)
and eigenvalue ``lambda = i omega``, the motion is ``|w_k| cos(omega t + phi_k)``.
The time lag is ``dt = (phi_2 - phi_1) / omega = t_1 - t_2`` [s]: the time by which the
zero crossing at the inlet sensor S1 comes after the corresponding one at the outlet
sensor S2. It is positive for a positive mass flow (the inlet side lags).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Sequence, Tuple

import numpy as np

from ... import _checks
from ...analysis import TransientResult, eigenvalues, linearize, simulate, static_equilibrium
from ...model import Model
from ...sections import PipeSection
from ... import sensor
from ...time_functions import Sine
from . import scenes

#: Seed 000, section 4: radius a [m] of the arc.
RADIUS = 0.150
#: Fluid densities rho_f [kg/m^3] of the seed.
WATER = 1000.0
KEROSENE = 780.0
#: Leg lengths b [m] of Fig. 7 (b = 3a) and Fig. 8.
LEG_FIG7 = 3 * RADIUS
LEG_FIG8 = 0.495


@dataclass(frozen=True)
class Scales:
    """Scales of Fig. 7 of seed 000.

    Attributes:
        omega0: omega0 [rad/s] = sqrt(EI / (rho_p A_p + rho_f A_f)) / a^2.
        mass_flow0: mdot0 [kg/s] = sqrt(rho_f A_f EI) / a.
        EI: EI [N m^2] bending stiffness of the tube.
        mass_per_length: rho_p A_p + rho_f A_f [kg/m].
        fluid_mass: rho_f A_f [kg/m].
        radius: a [m].
    """

    omega0: float
    mass_flow0: float
    EI: float
    mass_per_length: float
    fluid_mass: float
    radius: float


def scales(section: PipeSection, radius: float = RADIUS) -> Scales:
    """omega0 [rad/s] and mdot0 [kg/s] of a tube ``section`` and arc ``radius`` a [m].

    ``section`` may also be a meter :class:`~pipeflex.Model` (its first element's section).
    """
    if isinstance(section, Model):
        section = section.elements[0].section
    if not isinstance(section, PipeSection):
        raise ValueError("section must be a pipeflex.PipeSection or a meter Model")
    a = _checks.positive("radius", radius)
    if section.fluid_mass <= 0.0:
        raise ValueError("the section carries no fluid (fluid_mass = 0): mdot0 is zero")
    m = section.pipe_mass + section.fluid_mass
    return Scales(omega0=float(np.sqrt(section.EI / m) / a**2),
                  mass_flow0=float(np.sqrt(section.fluid_mass * section.EI) / a),
                  EI=section.EI, mass_per_length=m, fluid_mass=section.fluid_mass, radius=a)


def sensors(model: Model) -> Tuple[int, int]:
    """Node indices (S1, S2) of the sensors: the inlet and outlet ends of the arc.

    They are the nodes where a straight element meets a curved one (a curved element's
    reference length exceeds its chord), in flow order. For
    :func:`pipeflex.scenes.coriolis_meter` they are ``elements_per_leg`` and
    ``elements_per_leg + arc_elements``.
    """
    curved = [e.length > np.linalg.norm(model.positions[e.nodes[1]] - model.positions[e.nodes[0]]) * (1 + 1e-9)
              for e in model.elements]
    if not any(curved) or all(curved):
        raise ValueError("the model has no junction of straight and curved elements (not a meter)")
    first = next(i for i, c in enumerate(curved) if c)
    last = max(i for i, c in enumerate(curved) if c)
    return model.elements[first].nodes[0], model.elements[last].nodes[1]


def arc_length(model: Model) -> np.ndarray:
    """Distance s [m] of every node from the inlet along the pipe (elements in flow order)."""
    s = np.full(model.n_nodes, np.nan)
    s[model.elements[0].nodes[0]] = 0.0
    for e in model.elements:
        p, q = e.nodes
        s[q] = s[p] + e.length
    return s


@dataclass
class MeterMode:
    """The first (out-of-plane) mode of the meter at one mass flow.

    Attributes:
        mass_flow: mdot [kg/s].
        eigenvalue: lambda [1/s] (purely imaginary up to round-off).
        omega: Im lambda [rad/s].
        shape: (n_nodes, 6) complex nodal mode [ux, uy, uz, rx, ry, rz] [m, rad], scaled so
            that the largest out-of-plane displacement is 1 (real, phase 0).
        sensors: node indices (S1, S2).
        phase_difference: phi_2 - phi_1 [rad] of the out-of-plane displacement, in (-pi, pi].
        time_lag: dt = (phi_2 - phi_1) / omega [s] (see the module docstring).
    """

    mass_flow: float
    eigenvalue: complex
    omega: float
    shape: np.ndarray
    sensors: Tuple[int, int]
    phase_difference: float
    time_lag: float

    @property
    def out_of_plane(self) -> np.ndarray:
        """Complex out-of-plane (global z) displacement of every node [-]."""
        return self.shape[:, 2]


def first_mode(model: Model, *, mass_flow: float, about_equilibrium: bool = True) -> MeterMode:
    """The lowest mode with mainly out-of-plane (global z) motion at ``mass_flow``.

    Args:
        model: a meter (:func:`pipeflex.scenes.coriolis_meter`), in the xy plane.
        mass_flow: mdot [kg/s].
        about_equilibrium: linearise about the static equilibrium under the flow (default);
            ``False``: about the undeformed shape (the flow's normal force neglected).
    """
    mdot = _checks.finite("mass_flow", mass_flow)
    state = static_equilibrium(model, mass_flow=mdot).state if about_equilibrium else None
    eig = eigenvalues(linearize(model, state, mass_flow=mdot), vectors=True)
    basis = model.basis
    for k in np.nonzero(eig.values.imag > 0)[0]:
        x = (basis @ eig.vectors[:, k]).reshape(-1, 6)
        t = np.abs(x[:, :3]) ** 2
        if t[:, 2].sum() > 0.5 * t.sum():
            break
    else:
        raise ValueError("no oscillating out-of-plane mode found")
    lam = complex(eig.values[k])
    i_max = int(np.argmax(np.abs(x[:, 2])))
    x = x / x[i_max, 2]
    s1, s2 = sensors(model)
    dphi = float(np.angle(x[s2, 2] / x[s1, 2]))
    return MeterMode(mass_flow=mdot, eigenvalue=lam, omega=lam.imag, shape=x, sensors=(s1, s2),
                     phase_difference=dphi, time_lag=dphi / lam.imag)


def time_lag(model: Model, *, mass_flow: float) -> float:
    """Time lag dt [s] between the zero crossings at S1 and S2 (module docstring) at
    ``mass_flow`` mdot [kg/s], from the complex first mode about the static equilibrium."""
    return first_mode(model, mass_flow=mass_flow).time_lag


def _flows(flows_scaled) -> np.ndarray:
    f = np.atleast_1d(np.asarray(flows_scaled, dtype=float))
    if f.ndim != 1 or len(f) == 0 or not np.all(np.isfinite(f)):
        raise ValueError("flows_scaled must be a non-empty 1D array of finite numbers")
    return f


@dataclass
class FrequencyCurve:
    """First natural frequency versus mass flow (Fig. 7 of seed 000).

    Attributes:
        flows_scaled: mdot / mdot0 [-]. mass_flow: mdot [kg/s].
        omega: first natural angular frequency [rad/s]. omega_scaled: omega / omega0 [-].
        scales: the :class:`Scales` used.
        leg_length: b [m]. fluid_density: rho_f [kg/m^3].
        about_equilibrium: linearised about the static equilibrium (normal force included).
    """

    flows_scaled: np.ndarray
    mass_flow: np.ndarray
    omega: np.ndarray
    omega_scaled: np.ndarray
    scales: Scales
    leg_length: float
    fluid_density: float
    about_equilibrium: bool


def frequency_curve(*, leg_length: float = LEG_FIG7, flows_scaled: Sequence[float],
                    fluid_density: float = WATER, radius: float = RADIUS,
                    about_equilibrium: bool = True, **meter_options) -> FrequencyCurve:
    """omega/omega0 of the first (out-of-plane) mode for each mdot/mdot0 (Fig. 7).

    Args:
        leg_length: b [m] (Fig. 7: 3a). flows_scaled: mdot/mdot0 [-] values.
        fluid_density: rho_f [kg/m^3]. radius: a [m].
        about_equilibrium: see :func:`first_mode`.
        meter_options: further keywords of :func:`pipeflex.scenes.coriolis_meter`.
    """
    f = _flows(flows_scaled)
    model = scenes.coriolis_meter(leg_length=leg_length, fluid_density=fluid_density, radius=radius,
                                  **meter_options)
    sc = scales(model, radius)
    mdot = f * sc.mass_flow0
    om = np.array([first_mode(model, mass_flow=m, about_equilibrium=about_equilibrium).omega for m in mdot])
    return FrequencyCurve(f, mdot, om, om / sc.omega0, sc, float(leg_length), float(fluid_density),
                          bool(about_equilibrium))


@dataclass
class TimeLagCurve:
    """Time lag between the sensors versus mass flow (Fig. 8 of seed 000), with its
    least-squares line dt = sensitivity * mdot + intercept.

    Attributes:
        flows_scaled: mdot / mdot0 [-] (mdot0 as given to :func:`time_lag_curve`).
        mass_flow: mdot [kg/s].
        time_lag: dt [s] (module docstring). omega: first natural frequency [rad/s].
        sensitivity: slope d(dt)/d(mdot) [s/(kg/s)] of the fit.
        intercept: [s] of the fit.
        nonlinearity: max abs(dt - fit) / max abs(dt) [-].
        scales: the :class:`Scales` used. leg_length: b [m]. fluid_density: rho_f [kg/m^3].
    """

    flows_scaled: np.ndarray
    mass_flow: np.ndarray
    time_lag: np.ndarray
    omega: np.ndarray
    sensitivity: float
    intercept: float
    nonlinearity: float
    scales: Scales
    leg_length: float
    fluid_density: float


def time_lag_curve(*, leg_length: float = LEG_FIG8, flows_scaled: Sequence[float],
                   fluid_density: float = WATER, radius: float = RADIUS, mass_flow0: Optional[float] = None,
                   **meter_options) -> TimeLagCurve:
    """Time lag dt [s] between S1 and S2 for each mdot/mdot0 and its linear fit (Fig. 8).

    Args:
        leg_length: b [m] (Fig. 8: 0.495). flows_scaled: mdot/mdot0 [-] values (at least 2
            distinct ones for the fit). fluid_density: rho_f [kg/m^3]. radius: a [m].
        mass_flow0: mdot0 [kg/s] that ``flows_scaled`` refers to; default that of this
            fluid, sqrt(rho_f A_f EI)/a. Give one common value (e.g. water's) to compare
            fluids at equal mass flows, as Fig. 8 does.
        meter_options: further keywords of :func:`pipeflex.scenes.coriolis_meter`.
    """
    f = _flows(flows_scaled)
    if len(np.unique(f)) < 2:
        raise ValueError("flows_scaled needs at least two distinct values for the linear fit")
    model = scenes.coriolis_meter(leg_length=leg_length, fluid_density=fluid_density, radius=radius,
                                  **meter_options)
    sc = scales(model, radius)
    mdot = f * (sc.mass_flow0 if mass_flow0 is None else _checks.positive("mass_flow0", mass_flow0))
    modes = [first_mode(model, mass_flow=m) for m in mdot]
    dt = np.array([m.time_lag for m in modes])
    slope, icpt = np.polyfit(mdot, dt, 1)
    peak = np.max(np.abs(dt))
    nonlin = float(np.max(np.abs(dt - (slope * mdot + icpt))) / peak) if peak > 0 else 0.0
    return TimeLagCurve(f, mdot, dt, np.array([m.omega for m in modes]), float(slope), float(icpt), nonlin,
                        sc, float(leg_length), float(fluid_density))


def sensitivity(*, leg_length: float = LEG_FIG8, fluid_density: float = WATER,
                flows_scaled: Sequence[float] = (0.0, 0.005, 0.01, 0.015, 0.02), **options) -> float:
    """Time lag per unit mass flow d(dt)/d(mdot) [s/(kg/s)]: the slope of the linear fit
    of :func:`time_lag_curve` over ``flows_scaled`` (mdot/mdot0 [-])."""
    return time_lag_curve(leg_length=leg_length, fluid_density=fluid_density, flows_scaled=flows_scaled,
                          **options).sensitivity


# -- figures (matplotlib is imported only here) ---------------------------------------
@dataclass
class DrivenMeter:
    """A meter driven at its first frequency, its sensor signals processed as a meter would.

    Attributes:
        mass_flow: mdot [kg/s]. omega: drive frequency [rad/s] (the first mode's).
        time_lag: mean (t_S1 - t_S2) [s] of paired upward zero crossings of the sensors'
            out-of-plane displacements over the last measured periods (crossing sensors:
            located inside the integrator's steps, ``result.sensors["S1"]``, ``["S2"]``).
        time_lag_mode: the same from the complex mode (:func:`first_mode`) [s].
        crossings: number of crossing pairs averaged.
        result: the transient.
    """

    mass_flow: float
    omega: float
    time_lag: float
    time_lag_mode: float
    crossings: int
    result: TransientResult


def driven_time_lag(*, leg_length: float = LEG_FIG8, fluid_density: float = WATER, flow_scaled: float = 0.01,
                    periods: int = 40, ramp_periods: int = 10, measure_periods: int = 10,
                    steps_per_period: int = 200, force: float = 1.0) -> DrivenMeter:
    """Transient check of Fig. 8: drive the meter at the arc's apex with
    F(t) = force * ramp(t) * sin(omega_1 t) at the first mode's frequency omega_1 (the ramp
    rises linearly over ``ramp_periods``), integrate ``periods`` periods with
    generalised-alpha (``steps_per_period`` steps per period) from the static equilibrium
    under the flow, and measure the time lag between the sensors' zero crossings over
    the last ``measure_periods`` periods.

    Args:
        leg_length: b [m]. fluid_density: rho_f [kg/m^3].
        flow_scaled: mdot/mdot0 [-] (mdot0 of this fluid). force: drive amplitude [N].
    """
    meter = scenes.coriolis_meter(leg_length=leg_length, fluid_density=fluid_density)
    mdot = _checks.finite("flow_scaled", flow_scaled) * scales(_section(meter)).mass_flow0
    mode = first_mode(meter, mass_flow=mdot)
    driven = scenes.coriolis_meter(leg_length=leg_length, fluid_density=fluid_density, mass_flow=mdot,
                                   drive_force=_checks.positive("force", force))
    start = static_equilibrium(meter, mass_flow=mdot).state
    period = 2 * np.pi / mode.omega
    n = _checks.positive_int("periods", periods)
    t_end = n * period
    ramp = ([0.0, ramp_periods * period], [0.0, 1.0])
    times = np.linspace(0.0, t_end, n * _checks.positive_int("steps_per_period", steps_per_period) + 1)
    s1, s2 = mode.sensors
    # upward crossings of the sensors' rest positions, located inside the steps (pipeflex.sensor)
    ups = [sensor.crossing(sensor.node_position(s, "z"), float(start.q[6 * s + 2]), "up", name=f"S{k}")
           for k, s in ((1, s1), (2, s2))]
    res = simulate(driven, t_end, integrator="generalized_alpha", state=start, times=times, mass_flow=mdot,
                   load_factor=Sine(omega=mode.omega, envelope=ramp), step=period / steps_per_period,
                   rho_inf=0.9, progress=False, sensors=ups)
    after = t_end - measure_periods * period
    c1, c2 = (c[c >= after] for c in (res.sensors["S1"][0], res.sensors["S2"][0]))
    pairs = [(a, c2[np.argmin(np.abs(c2 - a))]) for a in c1] if len(c2) else []
    if not pairs:
        raise ValueError("the sensor signals have no zero crossings in the measured periods")
    lag = float(np.mean([a - b for a, b in pairs]))
    return DrivenMeter(mdot, mode.omega, lag, mode.time_lag, len(pairs), res)


def _section(model: Model) -> PipeSection:
    return model.elements[0].section


def geometry_figure(model: Model):
    """Plan view of the meter (Fig. 6 of seed 000) by :func:`pipeflex.plot.model`: centre
    line, nodes, clamped ends, flow direction; the sensors and the inlet and outlet marked."""
    import matplotlib.pyplot as plt

    from ...plot import model as draw_model

    fig, ax = plt.subplots(figsize=(6, 3))
    draw_model(model, ax=ax, plane="xy", show_flow=False, legend=False)
    x = model.positions
    s1, s2 = sensors(model)
    centre = x.mean(axis=0)
    for n, name in ((s1, "S1 (inlet side)"), (s2, "S2 (outlet side)")):
        # a sensor is a position, not a value: a filled diamond, its name outside the U
        ax.plot(*x[n, :2], "D", ms=7, color="C3", zorder=5)
        below = x[n, 1] < centre[1]
        ax.annotate(name, x[n, :2], textcoords="offset points", xytext=(0, -10 if below else 10), ha="center",
                    va="top" if below else "bottom", color="C3")
    ends = (model.elements[0].nodes[0], model.elements[-1].nodes[1])
    for e in (model.elements[0], model.elements[-1]):
        p, q = e.nodes
        mid = 0.5 * (x[p] + x[q])
        ax.annotate("", mid[:2] + 0.06 * (x[q, :2] - x[p, :2]) / np.linalg.norm(x[q] - x[p]), mid[:2],
                    arrowprops=dict(arrowstyle="->", color="C0", lw=1.5))
    # inlet and outlet beside the clamps, on the side away from the tube
    for n, name in ((ends[0], "inlet"), (ends[1], "outlet")):
        ax.annotate(name, x[n, :2], textcoords="offset points", xytext=(-12, 0), ha="right", va="center",
                    color="C0")
    ax.set_title("U-tube in the $xy$ plane; vibration along $z$", fontsize=10)
    ax.margins(0.15)
    fig.tight_layout()
    return fig


def frequency_figure(*curves: FrequencyCurve, labels: Sequence[str] = ()):
    """omega/omega0 versus mdot/mdot0 (Fig. 7 of seed 000) for one or more curves
    (:func:`pipeflex.plot.parameter_curves`; dashed: about the undeformed shape)."""
    import matplotlib.pyplot as plt

    from ...plot import parameter_curves

    fig, ax = plt.subplots(figsize=(6, 4))
    parameter_curves([c.flows_scaled for c in curves], [c.omega_scaled for c in curves],
                     xlabel=r"mass flow $\dot m/\dot m_0$ [-]", ylabel=r"first frequency $\omega/\omega_0$ [-]",
                     labels=list(labels) or None, styles=["-" if c.about_equilibrium else "--" for c in curves],
                     ax=ax)
    fig.tight_layout()
    return fig


def time_lag_figure(*curves: TimeLagCurve, labels: Sequence[str] = ()):
    """Time lag [us] versus mdot/mdot0 (Fig. 8 of seed 000): the computed points (filled
    markers, :data:`pipeflex.plot.STYLES` ["computed points"]) and their fitted lines
    (:func:`pipeflex.plot.parameter_curves`). The curves of different fluids nearly
    coincide, so each has its own marker, line style and width (the first widest, drawn
    below), so that every one stays visible."""
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    from ...plot import STYLES, parameter_curves

    fig, ax = plt.subplots(figsize=(6, 4))
    names = [labels[i] if i < len(labels) else f"$\\rho_f$ = {c.fluid_density:g} kg/m$^3$"
             for i, c in enumerate(curves)]
    x = [c.flows_scaled for c in curves]
    ylabel = r"time lag $\Delta t = t_{S1} - t_{S2}$ [$\mu$s]"
    xlabel = r"mass flow $\dot m/\dot m_0$ [-]"
    markers, dashes = ("s", "^", "D", "v"), ("-", "--", ":", "-.")
    n = len(curves)
    # first curve widest and largest at the bottom, later ones narrower on top
    lines = [dict(color=f"C{i}", ls=dashes[i % 4], lw=2.6 - 1.6 * i / max(n - 1, 1), zorder=2 + i) for i in range(n)]
    points = [dict(STYLES["computed points"], ls="none", color=f"C{i}", marker=markers[i % 4],
                   ms=8 - 3.5 * i / max(n - 1, 1), zorder=2.5 + i) for i in range(n)]
    parameter_curves(x, [c.time_lag for c in curves], scale=1e6, xlabel=xlabel, ylabel=ylabel, styles=points,
                     ax=ax, legend=False)
    parameter_curves(x, [c.sensitivity * c.mass_flow + c.intercept for c in curves], scale=1e6, xlabel=xlabel,
                     ylabel=ylabel, styles=lines, ax=ax, legend=False)
    handles = [Line2D([], [], **dict(ln, marker=pt["marker"], ms=pt["ms"]),
                      label=f"{name}: {1e6 * c.sensitivity:.5f} $\\mu$s/(kg/s)")
               for ln, pt, name, c in zip(lines, points, names, curves)]
    ax.legend(handles=handles, fontsize=8, title="computed points, fitted lines", title_fontsize=8)
    c = curves[0]
    nz = np.nonzero(c.flows_scaled)[0]
    if len(nz) and all(np.allclose(d.mass_flow[d.flows_scaled != 0] / d.flows_scaled[d.flows_scaled != 0],
                                   c.mass_flow[nz[0]] / c.flows_scaled[nz[0]]) for d in curves):
        md0 = c.mass_flow[nz[0]] / c.flows_scaled[nz[0]]  # common mdot0: show mdot [kg/s] on top
        top = ax.secondary_xaxis("top", functions=(lambda f: f * md0, lambda m: m / md0))
        top.set_xlabel(r"mass flow $\dot m$ [kg/s]")
    fig.tight_layout()
    return fig


def mode_figure(model: Model, mode: MeterMode):
    """Out-of-plane amplitude abs(w) and phase arg(w) [mrad] of a complex mode along the pipe
    (:func:`pipeflex.plot.parameter_curves`)."""
    import matplotlib.pyplot as plt

    from ...plot import parameter_curves

    s = arc_length(model)
    w = mode.out_of_plane
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(6, 5), sharex=True)
    parameter_curves(s, np.abs(w), xlabel="", ylabel=r"amplitude $|w|$ [-]", styles=[dict(marker="o", ms=3)],
                     ax=ax1, title=f"first mode at $\\dot m$ = {mode.mass_flow:.3g} kg/s, "
                                   f"$\\omega$ = {mode.omega:.5g} rad/s")
    moving = np.abs(w) > 1e-12
    parameter_curves(s[moving], np.angle(w[moving]), scale=1e3, xlabel="arc length from the inlet $s$ [m]",
                     ylabel=r"phase $\arg w$ [mrad]", styles=[dict(marker="o", ms=3)], ax=ax2)
    for ax in (ax1, ax2):
        for n in mode.sensors:
            ax.axvline(s[n], color="C3", lw=0.8, ls=":")
    for n, name in zip(mode.sensors, ("S1", "S2")):
        ax1.text(s[n], 0.05, " " + name, color="C3")
    fig.tight_layout()
    return fig
