"""Seed 004: floating-frame pipe bodies with Craig-Bampton modes and Lagrange-multiplier
joints: the cantilever (Figs. 4-7), the semicircular pipe (Table 1, Figs. 9-10), the
concrete printer (Fig. 12) and the choice of model size."""
from . import model_choice, references, scenes, studies, validation

__all__ = ["model_choice", "references", "scenes", "studies", "validation"]
