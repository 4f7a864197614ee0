"""Seed 002 (Berzeri & Shabana), rotating cantilever: recomputation of the published
Tables 2-5 from the ANCF model with the library's rotating-frame linearisation (the
printed values are in :mod:`pipeflex.seeds.seed002.references`)."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, Tuple

import numpy as np

from ...analysis.rotating import rotating_frequencies
from . import scenes
from .references import GAMMAS, HUB_RADIUS_RATIOS, SLENDERNESS, TABLES, TIP_MASS_RATIOS



@dataclass
class TableResult:
    """Our values of Tables 3-5: ``values[mode][(N, R)]`` (8 gammas), and Table 2."""

    values: Dict[int, Dict[Tuple[int, int], np.ndarray]]
    longitudinal: Dict[Tuple[int, int], np.ndarray]
    max_strain: Dict[Tuple[int, int], np.ndarray]
    linearization: str


def table2(*, n_elements: int = 10) -> Dict[int, np.ndarray]:
    """Non-rotating frequencies (TRANSV-I..III, LONGIT-I) / omega0 for N = 0..4."""
    out = {}
    for N in TIP_MASS_RATIOS:
        m = scenes.rotating_cantilever(n_elements=n_elements, tip_mass_ratio=N, slenderness=SLENDERNESS)
        r = rotating_frequencies(m, gamma=0.0, n_modes=3)
        out[N] = np.concatenate([r.transverse[0], r.longitudinal[0, :1]])
    return out


def tables_3_to_5(*, n_elements: int = 10, linearization: str = "small_deformation",
                  gammas=GAMMAS) -> TableResult:
    """All entries of Tables 3-5 (30 configurations x 8 gammas x 3 modes)."""
    values = {1: {}, 2: {}, 3: {}}
    longitudinal, strain = {}, {}
    for N in TIP_MASS_RATIOS:
        for R in HUB_RADIUS_RATIOS:
            m = scenes.rotating_cantilever(n_elements=n_elements, tip_mass_ratio=N, hub_radius_ratio=R,
                                           slenderness=SLENDERNESS)
            r = rotating_frequencies(m, gamma=list(gammas), linearization=linearization, n_modes=3)
            for mode in (1, 2, 3):
                values[mode][(N, R)] = r.transverse[:, mode - 1]
            longitudinal[(N, R)] = r.longitudinal[:, 0]
            strain[(N, R)] = r.max_strain
    return TableResult(values, longitudinal, strain, linearization)


def deviations(result: TableResult) -> Dict[int, Dict[Tuple[int, int], np.ndarray]]:
    """Relative deviation (ours - published) / published of every entry."""
    return {mode: {k: (result.values[mode][k] - np.array(ref)) / np.array(ref) for k, ref in TABLES[mode].items()}
            for mode in (1, 2, 3)}


def table3_figure(*, hub_radius_ratios=(0, 1, 3, 5), gammas=None):
    """Table 3 (N = 0): our first frequency against gamma (lines) and the printed values
    (circles), drawn by :func:`pipeflex.plot.comparison`. Returns the figure."""
    import matplotlib.pyplot as plt

    from ...plot import comparison
    from .references import TABLE3

    fig, ax = plt.subplots(figsize=(7, 4.5))
    g = np.linspace(0.0, 50.0, 101) if gammas is None else np.asarray(gammas, dtype=float)
    ours = [rotating_frequencies(scenes.rotating_cantilever(hub_radius_ratio=R, slenderness=SLENDERNESS), gamma=g,
                                 n_modes=1).transverse[:, 0] for R in hub_radius_ratios]
    comparison(g, ours, [TABLE3[(0, R)] for R in hub_radius_ratios], x_published=np.asarray(GAMMAS, dtype=float),
               labels=[f"$R/L$ = {R}" for R in hub_radius_ratios], xlabel=r"$\gamma = \Omega/\omega_0$ [-]",
               ylabel=r"first frequency $\omega_1/\omega_0$ [-]", published_label="circles: published",
               title="seed 002, Table 3 ($N$ = 0): lines ours, circles published", ax=ax)
    fig.tight_layout()
    return fig
