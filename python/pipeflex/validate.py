"""The main job: recompute the seeds' published numbers and compare.

Each :class:`Row` is one published number: where it comes from, its value, ours, the
relative deviation and the tolerance it must meet (from the digits the source prints).
"""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Callable, Dict, List, Optional

from . import scenes
from .analysis import critical_mass_flow, steady_rotation


@dataclass
class Row:
    source: str         # seed, table, row
    quantity: str       # what and unit
    published: float
    ours: float
    tolerance: float    # relative
    checked: bool = True  # False: shown with its deviation, explained in the docs

    def __post_init__(self):
        # plain Python numbers, so that the rows serialise to JSON whatever computed them
        self.published, self.ours, self.tolerance = float(self.published), float(self.ours), float(self.tolerance)
        self.checked = bool(self.checked)

    @property
    def deviation(self) -> float:
        return (self.ours - self.published) / abs(self.published)

    @property
    def passed(self) -> bool:
        return not self.checked or (math.isfinite(self.ours) and abs(self.deviation) <= self.tolerance)

    def as_dict(self) -> dict:
        return dict(asdict(self), deviation=self.deviation, passed=self.passed)


# Seed 000 (Meijaard & Hakvoort), Table 1: simply supported pipe, EI = 1, L = 1,
# rho_p A_p = 0.75, rho_f A_f = 0.25, k_v = 1; critical mass flow [kg/s].
TABLE1 = {1: 1.732050808, 2: 1.576693278, 4: 1.571198510, 8: 1.570822061, 16: 1.570797945}
TABLE1_EXACT = 1.570796327
# Seed 000, Table 2: cantilever pipe, L = 1 m, EI = 10 N m^2, 8 kg/m, 2 kg/m, k_v = 1.
TABLE2 = {2: 24.962732, 4: 25.054732, 8: 25.008910, 16: 25.005738, 32: 25.005534}
TABLE2_EXTRAPOLATED = 25.005520

# Tolerances: Table 1 prints 10 significant digits, the issue asks for 8 (half a unit of
# the 8th digit); Table 2 within 2e-7, its extrapolation within 2e-6.
TOL_TABLE1 = 5e-8
TOL_TABLE2 = 2e-7
TOL_TABLE2_EXTRAPOLATED = 2e-6


def richardson(coarse: float, fine: float, order: float = 4.0) -> float:
    """Richardson extrapolation of two results on meshes halved in size."""
    return fine + (fine - coarse) / (2**order - 1)


def table1(*, rtol: float = 1e-10) -> List[Row]:
    vals = {n: critical_mass_flow(scenes.simply_supported_pipe(n_elements=n), rtol=rtol).mass_flow
            for n in TABLE1}
    rows = [Row(f"seed 000, Table 1, {n} element{'s' * (n > 1)}", "critical mass flow [kg/s]",
                TABLE1[n], vals[n], TOL_TABLE1) for n in TABLE1]
    rows.append(Row("seed 000, Table 1, infinity (exact pi)", "Richardson 8/16 elements [kg/s]",
                    TABLE1_EXACT, richardson(vals[8], vals[16]), TOL_TABLE1))
    return rows


def table2(*, rtol: float = 1e-10) -> List[Row]:
    vals = {n: critical_mass_flow(scenes.cantilever_pipe(n_elements=n), rtol=rtol).mass_flow for n in TABLE2}
    rows = [Row(f"seed 000, Table 2, {n} elements", "critical mass flow [kg/s]", TABLE2[n], vals[n],
                TOL_TABLE2) for n in TABLE2]
    rows.append(Row("seed 000, Table 2, extrapolated", "Richardson 16/32 elements [kg/s]",
                    TABLE2_EXTRAPOLATED, richardson(vals[16], vals[32]), TOL_TABLE2_EXTRAPOLATED))
    return rows


# Seed 000, section 3.3: final angular velocities [rad/s] of the semicircular rotating
# pipe (R = 0.5 m, 0.5 and 1 kg/m, k_v = 1, mdot = 10 kg/s, 8 curved elements).
SPRINKLER = {10.0: 5.218466, 100.0: 9.009825, 1000.0: 9.882486, "rigid": 10.0}
# The seed prints 7 digits (6 after the point for the flexible pipes); the issue asks for 6
# significant digits. Our EI = 10 value differs by 3e-6 relative (see docs/validation.md).
TOL_SPRINKLER = 5e-6


def sprinkler() -> List[Row]:
    """Direct solution of the steady rotation (relative equilibrium) of each sprinkler."""
    rows = []
    for EI, ref in SPRINKLER.items():
        model = scenes.sprinkler(EI=1.0, rigid=True) if EI == "rigid" else scenes.sprinkler(EI=EI)
        label = "rigid pipe" if EI == "rigid" else f"EI = {EI:g} N m^2"
        rows.append(Row(f"seed 000, sec. 3.3, {label}", "final angular velocity [rad/s]", ref,
                        steady_rotation(model).omega, TOL_SPRINKLER))
    return rows


def seed002_table2() -> List[Row]:
    """Seed 002, Table 2 (10 ANCF elements, not rotating): the transverse entries to all
    printed digits (4 decimals); LONGIT-I against the exact column within 4e-5 (Model A's
    bending matrix also stiffens the axial motion, +2.6e-5)."""
    from . import rotating_tables as rt

    ours = rt.table2()
    names = ("TRANSV-I", "TRANSV-II", "TRANSV-III")
    rows = []
    for N, ref in rt.TABLE2_SIMULATION.items():
        for j, name in enumerate(names):
            rows.append(Row(f"seed 002, Table 2, N = {N}, {name}", "omega/omega0 [-]", ref[j], ours[N][j],
                            0.5e-4 / ref[j] + 1e-12))
        rows.append(Row(f"seed 002, Table 2, N = {N}, LONGIT-I (exact)", "omega/omega0 [-]", rt.TABLE2_EXACT[N][3],
                        ours[N][3], 4e-5))
    return rows


#: Table 4, N = 3, R/L = 3, gamma = 10: printed 122.896; ours 123.147 is smooth in R/L
#: where the printed value is not (tests/test_rotating.py): shown, not checked.
SEED002_MISPRINTS = {(2, (3, 3), 10.0)}


def seed002_tables_3_to_5() -> List[Row]:
    """Seed 002, Tables 3-5 (small-deformation linearisation, 10 elements): gamma <= 10
    within 1e-3; gamma = 20, 50 shown with their deviation (strains of several per cent,
    veering with the longitudinal mode: notebooks/seed002_rotating_tables.ipynb)."""
    from . import rotating_tables as rt

    res = rt.tables_3_to_5()
    rows = []
    for mode, table in rt.TABLES.items():
        for (N, R), ref in table.items():
            for j, g in enumerate(rt.GAMMAS):
                checked = g <= 10.0 and (mode, (N, R), g) not in SEED002_MISPRINTS
                rows.append(Row(f"seed 002, Table {mode + 2}, N={N}, R/L={R}, g={g:g}", f"mode {mode} omega/omega0 [-]",
                                ref[j], float(res.values[mode][(N, R)][j]), 1e-3, checked))
    return rows


#: Every group of published numbers, in the order printed.
# Seed 004 (FFRF). Table 1 prints 3 decimals; the issue asks for the FFRF column within 1%.
TOL_SEED004_TABLE1 = 1e-2


def seed004_fig7() -> List[Row]:
    """Seed 004, Fig. 7 text: n FFRF bodies (51 nodes, Craig-Bampton boundary modes, centre
    node fixed) against seed 000's Table 2. With the centre node fixed a body is exactly
    two Hermite elements, so n bodies reproduce Table 2's 2n elements (checked to the
    Table 2 tolerance); the seed's statement "n bodies = n elements" is shown."""
    from .ffrf_studies import critical_flow_vs_state_size

    d = critical_flow_vs_state_size(bodies=(1, 2, 4, 8, 16), modes=())
    rows = []
    for n, m in zip(d["bodies"], d["bodies_flow"]):
        rows.append(Row(f"seed 004 Fig. 7, {n} bod{'ies' if n > 1 else 'y'} vs s000 T2 {2 * n} el.",
                        "critical mass flow [kg/s]", TABLE2[2 * n], m, TOL_TABLE2))
    for n, m in zip(d["bodies"], d["bodies_flow"]):
        if n in TABLE2:
            rows.append(Row(f"seed 004 Fig. 7, {n} bodies vs s000 T2 {n} el. (text)", "critical mass flow [kg/s]",
                            TABLE2[n], m, TOL_TABLE2, checked=False))
    return rows


def seed004_table1() -> List[Row]:
    """Seed 004, Table 1: final angular velocity of the semicircular pipe (8 bodies x 20
    elements, boundary modes), averaged over the last 0.5 s of a 4 s run: the FFRF column
    within 1% (checked); the Spacar column (seed 000's element) shown."""
    from .ffrf_studies import TABLE1_FFRF, TABLE1_SPACAR, curved_pipe_run, final_angular_velocity

    rows = []
    for E, ref in TABLE1_FFRF.items():
        _, res, w = curved_pipe_run(E, n_outputs=401)
        ours = final_angular_velocity(res.t, w)
        rows.append(Row(f"seed 004, Table 1, FFRF, E = {E / 1e9:g} GPa", "final angular velocity [rad/s]", ref, ours,
                        TOL_SEED004_TABLE1))
        rows.append(Row(f"seed 004, Table 1, Spacar, E = {E / 1e9:g} GPa", "final angular velocity [rad/s]",
                        TABLE1_SPACAR[E], ours, TOL_SEED004_TABLE1, checked=False))
    return rows


GROUPS: Dict[str, Callable[[], List[Row]]] = {"table1": table1, "table2": table2, "sprinkler": sprinkler,
                                              "seed002_table2": seed002_table2,
                                              "seed002_tables3to5": seed002_tables_3_to_5,
                                              "seed004_fig7": seed004_fig7, "seed004_table1": seed004_table1}


def run(groups: Optional[List[str]] = None) -> List[Row]:
    """Recompute the selected groups (default all)."""
    rows: List[Row] = []
    for name in groups or list(GROUPS):
        if name not in GROUPS:
            raise ValueError(f"unknown validation group {name!r}; choose from {sorted(GROUPS)}")
        rows.extend(GROUPS[name]())
    return rows


def format_rows(rows: List[Row]) -> str:
    head = f"{'source':44s} {'quantity':34s} {'published':>14s} {'ours':>16s} {'rel. dev.':>10s} {'tol':>7s}  result"
    lines = [head, "-" * len(head)]
    for r in rows:
        status = "shown" if not r.checked else "pass" if r.passed else "FAIL"
        lines.append(f"{r.source:44s} {r.quantity:34s} {r.published:14.10g} {r.ours:16.11g} "
                     f"{r.deviation:10.2e} {r.tolerance:7.0e}  {status}")
    checked = [r for r in rows if r.checked]
    n_fail = sum(not r.passed for r in checked)
    lines.append(f"{len(checked) - n_fail} of {len(checked)} checked published numbers reproduced within tolerance; "
                 f"{len(rows) - len(checked)} more shown with their deviation (explained in docs/validation.md)")
    return "\n".join(lines)


def write_figures(out: Path) -> List[Path]:
    """The seeds' figures reproduced so far: convergence of the critical flows (Tables 1,
    2), the sprinkler's spin-up (Fig. 5), the Coriolis meter (Figs. 7, 8), seed 002's
    Table 3 and Fig. 6, seed 004's Figs. 4, 6, 7, 9, 10, 12."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from . import coriolis
    from .analysis import simulate
    from .plotting import convergence_figure

    out.mkdir(parents=True, exist_ok=True)
    paths = []

    def save(fig, name):
        path = out / name
        fig.savefig(path, dpi=120)
        plt.close(fig)
        paths.append(path)

    save(convergence_figure(), "critical_flow_convergence.png")
    fig, ax = plt.subplots(figsize=(7, 4))
    for label, model in (("EI = 10", scenes.sprinkler(EI=10.0)), ("EI = 100", scenes.sprinkler(EI=100.0)),
                         ("EI = 1000", scenes.sprinkler(EI=1000.0)), ("rigid", scenes.sprinkler(EI=1.0, rigid=True))):
        r = simulate(model, 1.0, integrator="generalized_alpha", step=1e-3, n_outputs=201, progress=False)
        ax.plot(r.t, r.omega[:, 0, 2], label=label)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("angular velocity [rad/s]")
    ax.set_title("seed 000, Fig. 5: semicircular rotating pipe")
    ax.legend()
    ax.grid(lw=0.3)
    save(fig, "sprinkler_fig5.png")
    f7 = coriolis.frequency_curve(flows_scaled=np.linspace(0.0, 0.4, 21))
    save(coriolis.frequency_figure(f7, labels=["water, b = 3a"]), "coriolis_fig7.png")
    flows = np.linspace(0.0, 0.02, 6)
    water = coriolis.time_lag_curve(flows_scaled=flows, fluid_density=coriolis.WATER)
    kerosene = coriolis.time_lag_curve(flows_scaled=flows, fluid_density=coriolis.KEROSENE,
                                       mass_flow0=water.scales.mass_flow0)
    save(coriolis.time_lag_figure(water, kerosene, labels=["water", "kerosene"]), "coriolis_fig8.png")
    save(_seed002_table3_figure(), "seed002_table3.png")
    save(_seed002_spin_up_figure(), "seed002_fig6.png")
    for name, fig in _seed004_figures():
        save(fig, name)
    return paths


def _seed004_figures():
    """Seed 004: Figs. 4-7, 9, 10 and 12 (FFRF bodies; seed-000 element in grey)."""
    import numpy as np

    from . import ffrf_studies as fs

    element = fs.element_cantilever_tip(n_elements=8, t_end=2.0)
    traces = [fs.ffrf_cantilever_tip(n_bodies=n, t_end=2.0) for n in (2, 4, 8)]
    fig4 = fs.tip_figure(traces, element, "seed 004, Fig. 4: tip deflection, flow 15 m/s (1 body diverges: see docs)")
    yield "seed004_fig4.png", fig4
    traces = [fs.ffrf_cantilever_tip(n_bodies=n, internal_modes=m, t_end=2.0, until_failure=True)
              for n, m in ((1, 0), (1, 20), (2, 20))]
    fig5 = fs.tip_figure(traces, element, "seed 004, Fig. 5: internal modes, flow 15 m/s (1 body diverges)")
    fig5.axes[0].set_ylim(-0.6, 0.6)
    yield "seed004_fig5.png", fig5
    s8 = scenes.ffrf_cantilever_pipe(n_bodies=8)
    speeds = np.linspace(0.0, 15.0, 61)
    yield "seed004_fig6.png", fs.eigenvalue_figure(speeds, fs.eigenvalue_curves(speeds),
                                                   fs.critical_flow_speed(s8))
    yield "seed004_fig7.png", fs.fig7_figure(fs.critical_flow_vs_state_size(bodies=(1, 2, 4, 8, 16, 32),
                                                                            modes=(0, 4, 8, 12, 16, 24)), TABLE2)
    fig9, fig10 = fs.curved_figures({E: fs.curved_pipe_run(E, t_end=4.0) for E in fs.TABLE1_FFRF},
                                    {E: fs.element_curved_run(E, rho_inf=0.8) for E in fs.TABLE1_FFRF})
    yield "seed004_fig9.png", fig9
    yield "seed004_fig10.png", fig10
    yield "seed004_fig12.png", fs.printer_figure({v: fs.printer_run(v)[2] for v in fs.PRINTER_FLOW_SPEEDS})


def _seed002_table3_figure():
    import matplotlib.pyplot as plt
    import numpy as np

    from . import rotating_tables as rt
    from .analysis.rotating import rotating_frequencies

    fig, ax = plt.subplots(figsize=(7, 4.5))
    g = np.linspace(0.0, 50.0, 101)
    for R in (0, 1, 3, 5):
        m = scenes.rotating_cantilever(hub_radius_ratio=R, slenderness=rt.SLENDERNESS)
        line, = ax.plot(g, rotating_frequencies(m, gamma=g, n_modes=1).transverse[:, 0], label=f"R/L = {R}")
        ax.plot(rt.GAMMAS, rt.TABLE3[(0, R)], "o", color=line.get_color(), mfc="none")
    ax.set_xlabel("gamma = Omega / omega0")
    ax.set_ylabel("omega1 / omega0")
    ax.set_title("seed 002, Table 3 (N = 0): lines ours, circles published")
    ax.legend()
    ax.grid(lw=0.3)
    return fig


def _seed002_spin_up_figure():
    import matplotlib.pyplot as plt

    from . import rotating_studies as rs
    from .errors import ConvergenceError

    fig, ax = plt.subplots(figsize=(7, 4))
    for n, model in ((2, "A"), (1, "0"), (2, "0"), (10, "0")):
        try:
            t, y = rs.spin_up(n_elements=n, model=model, omega=10.0, t_end=20.0)
            ax.plot(t, y, label=f"Model {model}, {n} element{'s' * (n > 1)}")
        except ConvergenceError as e:
            import re

            when = re.search(r"t = ([0-9.eE+-]+) s", str(e))
            ax.plot([], [], label=f"Model {model}, {n} element{'s' * (n > 1)}: diverged"
                                  + (f" at t = {float(when.group(1)):.2f} s" if when else ""))
    ax.set_ylim(-1.5, 1.5)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("tip deflection [m]")
    ax.set_title("seed 002, Fig. 6: spin-up to 10 rad/s (ref. 21 beam)")
    ax.legend(fontsize=8)
    ax.grid(lw=0.3)
    return fig
