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

    @property
    def deviation(self) -> float:
        return (self.ours - self.published) / abs(self.published)

    @property
    def passed(self) -> bool:
        return math.isfinite(self.ours) and abs(self.deviation) <= self.tolerance

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


#: Every group of published numbers, in the order printed.
GROUPS: Dict[str, Callable[[], List[Row]]] = {"table1": table1, "table2": table2, "sprinkler": sprinkler}


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
        lines.append(f"{r.source:44s} {r.quantity:34s} {r.published:14.10g} {r.ours:16.11g} "
                     f"{r.deviation:10.2e} {r.tolerance:7.0e}  {'pass' if r.passed else 'FAIL'}")
    n_fail = sum(not r.passed for r in rows)
    lines.append(f"{len(rows) - n_fail} of {len(rows)} published numbers reproduced within tolerance")
    return "\n".join(lines)


def write_figures(out: Path) -> List[Path]:
    """The seeds' figures reproduced so far: convergence of the critical flows (Tables 1,
    2), the sprinkler's spin-up (Fig. 5) and the Coriolis meter (Figs. 7, 8)."""
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
    return paths
