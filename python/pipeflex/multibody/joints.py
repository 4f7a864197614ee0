"""Joints between floating-frame bodies, enforced with Lagrange multipliers (seed 004, sec. 6).

Each joint gives equations c(q) = 0 between a node of one body and a node of another
body or the ground, and their Jacobian with respect to the body coordinates
[dr, dpi, deta] (dr, dpi global: a rotation increment R <- exp(dpi~) R).

A node of body j at state q has the position p = r_j + R_j (x_i + Phi_u eta) and the
orientation A = R_j exp(theta~), theta = Phi_theta eta (nodal small rotations, applied as
a rotation vector). Variations: dp = dr - (p - r)~ dpi + R Phi_u deta and the spatial
rotation d alpha = dpi + R T(theta) Phi_theta deta (T: left Jacobian of exp).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Tuple

import numpy as np

from .body import _skew

JOINT_KINDS = ("rigid", "hinge", "spherical", "roller")


def rotation_exp(phi: np.ndarray) -> np.ndarray:
    """exp(phi~) [-] of a rotation vector phi [rad] (Rodrigues)."""
    t2 = float(phi @ phi)
    W = _skew(phi)
    if t2 < 1e-8:
        a, b = 1.0 - t2 / 6.0, 0.5 - t2 / 24.0
    else:
        t = np.sqrt(t2)
        a, b = np.sin(t) / t, (1.0 - np.cos(t)) / t2
    return np.eye(3) + a * W + b * (W @ W)


def left_jacobian(phi: np.ndarray) -> np.ndarray:
    """T(phi) with exp((phi + dphi)~) = exp((T dphi)~) exp(phi~) to first order."""
    t2 = float(phi @ phi)
    W = _skew(phi)
    if t2 < 1e-8:
        a, b = 0.5 - t2 / 24.0, 1.0 / 6.0 - t2 / 120.0
    else:
        t = np.sqrt(t2)
        a, b = (1.0 - np.cos(t)) / t2, (t - np.sin(t)) / (t2 * t)
    return np.eye(3) + a * W + b * (W @ W)


def rotation_log(R: np.ndarray) -> np.ndarray:
    """Rotation vector [rad] of a rotation matrix (angle < pi)."""
    c = np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0)
    t = np.arccos(c)
    v = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    return 0.5 * v if t < 1e-8 else t / (2.0 * np.sin(t)) * v


def node_kinematics(body, r, R, eta, node: int):
    """(p, A, Jp, Ja): position [m], orientation, and the 3 x n variation maps of a node."""
    Pu, Pt, x = body.node_rows(node)
    y = R @ (x + Pu @ eta)
    th = Pt @ eta
    A = R @ rotation_exp(th)
    n = body.n_coordinates
    Jp = np.zeros((3, n))
    Jp[:, :3] = np.eye(3)
    Jp[:, 3:6] = -_skew(y)
    Jp[:, 6:] = R @ Pu
    Ja = np.zeros((3, n))
    Ja[:, 3:6] = np.eye(3)
    Ja[:, 6:] = R @ left_jacobian(th) @ Pt
    return r + y, A, Jp, Ja


def _vee_skew(D: np.ndarray) -> np.ndarray:
    return 0.5 * np.array([D[2, 1] - D[1, 2], D[0, 2] - D[2, 0], D[1, 0] - D[0, 1]])


_E = [_skew(e) for e in np.eye(3)]


@dataclass(frozen=True)
class Joint:
    """One joint. ``a`` = (body, node); ``b`` = (body, node) or None for the ground.

    ``ref`` holds what the joint keeps from the assembly configuration: the ground
    point and orientation, the relative orientation, the hinge axis in each node frame.
    """

    kind: str
    a: Tuple[int, int]
    b: Optional[Tuple[int, int]]
    ref: dict
    name: str

    @property
    def rows(self) -> int:
        return {"rigid": 6, "hinge": 5, "spherical": 3, "roller": 1}[self.kind]

    def evaluate(self, kin):
        """(c, Ja_block, Jb_block): equations and Jacobian blocks (rows x n_body) for
        the bodies of a and b (None for the ground). ``kin(body, node)`` gives the node
        kinematics."""
        pa, Aa, Jpa, Jaa = kin(*self.a)
        if self.b is None:
            pb, Ab, Jpb, Jab = self.ref["p"], self.ref["A"], None, None
        else:
            pb, Ab, Jpb, Jab = kin(*self.b)
        k = self.kind
        if k == "roller":
            n = self.ref["direction"]
            return np.array([n @ (pa - self.ref["p0"])]), n[None, :] @ Jpa, None
        rows_a, rows_b, c = [Jpa], [None if Jpb is None else -Jpb], [pa - pb]
        if k == "rigid":
            D = Aa.T @ Ab @ self.ref["C0"].T
            JD = np.column_stack([_vee_skew(Ek @ D) for Ek in _E]) @ Aa.T
            c.append(_vee_skew(D))
            rows_a.append(-JD @ Jaa)
            rows_b.append(None if Jab is None else JD @ Jab)
        elif k == "hinge":
            axb = Ab @ self.ref["axis_b"]
            for e in self.ref["perp_a"]:
                ea = Aa @ e
                c.append(np.array([ea @ axb]))
                rows_a.append(np.cross(ea, axb)[None, :] @ Jaa)
                rows_b.append(None if Jab is None else np.cross(axb, ea)[None, :] @ Jab)
        cvec = np.concatenate(c)
        Ja = np.vstack(rows_a)
        Jb = None if self.b is None else np.vstack(rows_b)
        return cvec, Ja, Jb
