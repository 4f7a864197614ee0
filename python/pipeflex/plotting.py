"""Figures of a model's eigenvalues as a parameter varies: now in :mod:`pipeflex.plot`
(this module re-exports them, so old imports keep working)."""
from .plot.roots import eigenvalue_paths, root_locus, root_locus_figure

__all__ = ["eigenvalue_paths", "root_locus", "root_locus_figure"]
