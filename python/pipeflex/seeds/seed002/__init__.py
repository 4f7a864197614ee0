"""Seed 002 (Berzeri & Shabana): planar ANCF beams, centrifugal stiffening, frequencies of
the rotating cantilever (Tables 2-5), Southwell coefficients and spin-up (Figs. 2-7)."""
from typing import TYPE_CHECKING

from ... import _lazy

# submodules load on first use: a scene does not pay for the studies' imports (scipy)
_LAZY = {
    "references": "pipeflex.seeds.seed002.references",
    "scenes": "pipeflex.seeds.seed002.scenes",
    "studies": "pipeflex.seeds.seed002.studies",
    "tables": "pipeflex.seeds.seed002.tables",
    "validation": "pipeflex.seeds.seed002.validation",
}
__getattr__, __dir__ = _lazy.attach(__name__, _LAZY)

if TYPE_CHECKING:  # the lazy names, spelt out for editors and type checkers (tests/test_static_api.py)
    from . import references, scenes, studies, tables, validation

__all__ = ["references", "scenes", "studies", "tables", "validation"]
