"""Joint descriptions and rotation helpers for the multibody systems (van Voorthuizen et al., sec. 6).

The joint equations themselves are evaluated in C++ (``cpp/src/multibody.cpp``). Each
joint constrains a node of one body against a node of another body or the ground:

* ``rigid``: p_a = p_b and no relative rotation (A_a^T A_b = C0, the assembly value),
  equations vee(skew(A_a^T A_b C0^T)) = 0;
* ``hinge``: p_a = p_b and the axis fixed in node b stays normal to two directions
  fixed in node a (rotation about the axis free);
* ``spherical``: p_a = p_b; ``roller``: n . (p_a - p_a0) = 0 for a global direction n.

A node of body j has the position p = r_j + R_j (x_i + Phi_u eta) and the orientation
A = R_j exp(theta~), theta = Phi_theta eta.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Tuple



JOINT_KINDS = ("rigid", "hinge", "spherical", "roller")
JOINT_ROWS = {"rigid": 6, "hinge": 5, "spherical": 3, "roller": 1}


@dataclass(frozen=True)
class Joint:
    """One joint: ``kind``; ``a`` = (body, node); ``b`` = (body, node) or None (ground);
    ``name`` for messages; ``ref`` what it keeps of the assembly configuration."""

    kind: str
    a: Tuple[int, int]
    b: Optional[Tuple[int, int]]
    ref: dict
    name: str

    @property
    def rows(self) -> int:
        return JOINT_ROWS[self.kind]
