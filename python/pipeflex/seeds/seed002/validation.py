"""Seed 002's validation groups: Table 2 (non-rotating), Tables 3-5 (rotating), and the
spin-up of Fig. 6."""
from __future__ import annotations

from typing import List

import numpy as np

from ...analysis.rotating import rotating_frequencies
from ...errors import ConvergenceError
from ..checks import Group, Row
from . import scenes, studies, tables
from .references import GAMMAS, MISPRINTS, SLENDERNESS, TABLE2_EXACT, TABLE2_SIMULATION, TABLE3, TABLES


def table2() -> List[Row]:
    """Table 2 (10 ANCF elements, not rotating): the transverse entries to all printed
    digits (4 decimals); LONGIT-I against the exact column within 4e-5 (Model A's bending
    matrix also stiffens the axial motion, +2.6e-5)."""
    ours = tables.table2()
    names = ("TRANSV-I", "TRANSV-II", "TRANSV-III")
    rows = []
    for N, ref in TABLE2_SIMULATION.items():
        for j, name in enumerate(names):
            rows.append(Row(f"seed 002, Table 2, N = {N}, {name}", "omega/omega0 [-]", ref[j], ours[N][j],
                            0.5e-4 / ref[j] + 1e-12))
        rows.append(Row(f"seed 002, Table 2, N = {N}, LONGIT-I (exact)", "omega/omega0 [-]", TABLE2_EXACT[N][3],
                        ours[N][3], 4e-5))
    return rows


def tables_3_to_5() -> List[Row]:
    """Tables 3-5 (small-deformation linearisation, 10 elements): gamma <= 10 within 1e-3;
    gamma = 20, 50 shown with their deviation (strains of several per cent, veering with
    the longitudinal mode: notebooks/seed002_rotating_tables.ipynb)."""
    res = tables.tables_3_to_5()
    rows = []
    for mode, table in TABLES.items():
        for (N, R), ref in table.items():
            for j, g in enumerate(GAMMAS):
                checked = g <= 10.0 and (mode, (N, R), g) not in MISPRINTS
                rows.append(Row(f"seed 002, Table {mode + 2}, N={N}, R/L={R}, g={g:g}", f"mode {mode} omega/omega0 [-]",
                                ref[j], float(res.values[mode][(N, R)][j]), 1e-3, checked))
    return rows


def table3_figure():
    """Table 3 (N = 0): our first frequency against gamma, the printed values as circles."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.5))
    g = np.linspace(0.0, 50.0, 101)
    for R in (0, 1, 3, 5):
        m = scenes.rotating_cantilever(hub_radius_ratio=R, slenderness=SLENDERNESS)
        line, = ax.plot(g, rotating_frequencies(m, gamma=g, n_modes=1).transverse[:, 0], label=f"R/L = {R}")
        ax.plot(GAMMAS, TABLE3[(0, R)], "o", color=line.get_color(), mfc="none")
    ax.set_xlabel("gamma = Omega / omega0")
    ax.set_ylabel("omega1 / omega0")
    ax.set_title("seed 002, Table 3 (N = 0): lines ours, circles published")
    ax.legend()
    ax.grid(lw=0.3)
    return fig


def spin_up_figure():
    """Fig. 6: spin-up to 10 rad/s of the ref. 21 beam, Models A and 0."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4))
    for n, model in ((2, "A"), (1, "0"), (2, "0"), (10, "0")):
        label = f"Model {model}, {n} element{'s' * (n > 1)}"
        try:
            t, y = studies.spin_up(n_elements=n, elastic=model, omega=10.0, t_end=20.0)
            ax.plot(t, y, label=label)
        except ConvergenceError as e:
            ax.plot([], [], label=f"{label}: diverged" + (f" at t = {e.time:.2f} s" if e.time is not None else ""))
    ax.set_ylim(-1.5, 1.5)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("tip deflection [m]")
    ax.set_title("seed 002, Fig. 6: spin-up to 10 rad/s (ref. 21 beam)")
    ax.legend(fontsize=8)
    ax.grid(lw=0.3)
    return fig


GROUPS = (
    Group("seed002_table2", "seed 002, Table 2: frequencies of the non-rotating beam", table2),
    Group("seed002_tables3to5", "seed 002, Tables 3-5: frequencies of the rotating beam", tables_3_to_5,
          lambda: [("seed002_table3.png", table3_figure()),
                   ("seed002_figs11_12.png", studies.mode_shape_figure())]),
    Group("seed002_spin_up", "seed 002, Fig. 6: spin-up (figure only)", lambda: [],
          lambda: [("seed002_fig6.png", spin_up_figure())]),
)
