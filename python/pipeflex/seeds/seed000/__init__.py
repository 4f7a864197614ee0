"""Seed 000 (Meijaard & Hakvoort): a 3D large-deflection pipe element with internal flow.
Critical flows (Tables 1, 2), the flutter limit cycle (Fig. 3), the sprinkler (sec. 3.3,
Fig. 5) and the Coriolis meter (sec. 4, Figs. 7, 8)."""
from . import coriolis, figures, limit_cycle, references, scenes, validation

__all__ = ["coriolis", "figures", "limit_cycle", "references", "scenes", "validation"]
