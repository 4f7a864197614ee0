"""What a validation group is: published numbers beside ours (rows) and figures."""
from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Callable, Iterable, List, Tuple


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


def _no_figures():
    return ()


@dataclass(frozen=True)
class Group:
    """A named validation group: ``rows()`` recomputes its published numbers, ``figures()``
    yields (file name, matplotlib figure) pairs of the figures it reproduces."""

    name: str
    description: str
    rows: Callable[[], List[Row]]
    figures: Callable[[], Iterable[Tuple[str, object]]] = _no_figures
