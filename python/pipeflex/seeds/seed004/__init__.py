"""Seed 004: floating-frame pipe bodies with Craig-Bampton modes and Lagrange-multiplier
joints: the cantilever (Figs. 4-7), the semicircular pipe (Table 1, Figs. 9-10), the
concrete printer (Fig. 12) and the choice of model size."""
from typing import TYPE_CHECKING

from ... import _lazy

# submodules load on first use: a scene does not pay for the studies' imports (scipy)
_LAZY = {
    "model_choice": "pipeflex.seeds.seed004.model_choice",
    "references": "pipeflex.seeds.seed004.references",
    "scenes": "pipeflex.seeds.seed004.scenes",
    "studies": "pipeflex.seeds.seed004.studies",
    "validation": "pipeflex.seeds.seed004.validation",
}
__getattr__, __dir__ = _lazy.attach(__name__, _LAZY)

if TYPE_CHECKING:  # the lazy names, spelt out for editors and type checkers (tests/test_static_api.py)
    from . import model_choice, references, scenes, studies, validation

__all__ = ["model_choice", "references", "scenes", "studies", "validation"]
