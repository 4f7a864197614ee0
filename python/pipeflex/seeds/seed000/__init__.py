"""Seed 000 (Meijaard & Hakvoort): a 3D large-deflection pipe element with internal flow.
Critical flows (Tables 1, 2), the flutter limit cycle (Fig. 3), the sprinkler (sec. 3.3,
Fig. 5) and the Coriolis meter (sec. 4, Figs. 7, 8)."""
from typing import TYPE_CHECKING

from ... import _lazy

# submodules load on first use: a scene does not pay for the studies' imports (scipy)
_LAZY = {
    "coriolis": "pipeflex.seeds.seed000.coriolis",
    "figures": "pipeflex.seeds.seed000.figures",
    "limit_cycle": "pipeflex.seeds.seed000.limit_cycle",
    "references": "pipeflex.seeds.seed000.references",
    "scenes": "pipeflex.seeds.seed000.scenes",
    "validation": "pipeflex.seeds.seed000.validation",
}
__getattr__, __dir__ = _lazy.attach(__name__, _LAZY)

if TYPE_CHECKING:  # the lazy names, spelt out for editors and type checkers (tests/test_static_api.py)
    from . import coriolis, figures, limit_cycle, references, scenes, validation

__all__ = ["coriolis", "figures", "limit_cycle", "references", "scenes", "validation"]
