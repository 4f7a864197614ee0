"""Seed 002 (Berzeri & Shabana): planar ANCF beams, centrifugal stiffening, frequencies of
the rotating cantilever (Tables 2-5), Southwell coefficients and spin-up (Figs. 2-7)."""
from . import references, scenes, studies, tables, validation

__all__ = ["references", "scenes", "studies", "tables", "validation"]
