"""The main job: recompute the seeds' published numbers, compare, draw the figures.

Each :class:`~pipeflex.seeds.checks.Row` is one published number: where it comes from,
its value, ours, the relative deviation and the tolerance it must meet (from the digits
the source prints). Groups (:data:`GROUPS`) name what ``pipeflex validate --only`` runs.
"""
from __future__ import annotations

from pathlib import Path
from typing import Dict, Iterable, List, Optional

from . import seed000, seed002, seed004
from .checks import Group, Row

#: Every validation group by name, in the order printed.
GROUPS: Dict[str, Group] = {g.name: g for s in (seed000, seed002, seed004) for g in s.validation.GROUPS}


def _selected(groups: Optional[Iterable[str]]) -> List[Group]:
    names = list(GROUPS) if groups is None else list(groups)
    unknown = [n for n in names if n not in GROUPS]
    if unknown:
        raise ValueError(f"unknown validation group(s) {', '.join(map(repr, unknown))}; "
                         f"choose from {', '.join(GROUPS)}")
    return [GROUPS[n] for n in names]


def run(groups: Optional[Iterable[str]] = None) -> List[Row]:
    """Recompute the published numbers of the selected groups (default all).

    Raises:
        ValueError: naming an unknown group and listing the known ones.
    """
    return [row for g in _selected(groups) for row in g.rows()]


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


def write_figures(out: Path, groups: Optional[Iterable[str]] = None) -> List[Path]:
    """Draw the figures of the selected groups (default all) into the folder ``out``
    (created if missing); a figure shared by two groups is drawn once. Returns the paths."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    selected = _selected(groups)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    paths: List[Path] = []
    for g in selected:
        for name, fig in g.figures():
            path = out / name
            if path not in paths:
                fig.savefig(path, dpi=120)
                paths.append(path)
            plt.close(fig)
    return paths
