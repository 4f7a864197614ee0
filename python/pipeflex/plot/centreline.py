"""Centre lines drawn with the elements' shape functions (no matplotlib here).

Both element types interpolate the centre line with the cubic Hermite functions of
Meijaard & Hakvoort's eq. 9, on the reference arc coordinate xi in [0, 1],

    N = [1 - 3 xi^2 + 2 xi^3,  xi - 2 xi^2 + xi^3,  3 xi^2 - 2 xi^3,  -xi^2 + xi^3],
    r(xi) = N_1 x^p + N_2 t^p + N_3 x^q + N_4 t^q,

with the end positions x and the end tangents t: ``t = l0 e_x`` of the end triads for the
pipe element (``e_x = R E_0 e_1``, R the node rotation, E_0 the end triad as built), and
``t = l r'`` (the slope coordinates times the element length) for the planar ANCF beam of
Berzeri & Shabana. A mode shape adds the linear increments ``dx`` and ``dt = l0 dtheta x e_x``
(``dt = l dr'`` for ANCF), so the drawing of a rigid-body mode is exactly rigid.
"""
from __future__ import annotations

from typing import List, Optional

import numpy as np

from ..state import State


def hermite(xp, tp, xq, tq, xi, *, derivative: bool = False) -> np.ndarray:
    """Points (len(xi), 3) of the cubic Hermite curve with end points ``xp``, ``xq`` [m] and
    end tangents ``tp``, ``tq`` [m] (dr/dxi) at the parameters ``xi`` [-]; with
    ``derivative=True`` the tangent dr/dxi [m] instead."""
    s = np.asarray(xi, dtype=float)[:, None]
    if derivative:
        N = (6 * s**2 - 6 * s, 1 - 4 * s + 3 * s**2, 6 * s - 6 * s**2, -2 * s + 3 * s**2)
    else:
        N = (1 - 3 * s**2 + 2 * s**3, s - 2 * s**2 + s**3, 3 * s**2 - 2 * s**3, -s**2 + s**3)
    return N[0] * np.asarray(xp) + N[1] * np.asarray(tp) + N[2] * np.asarray(xq) + N[3] * np.asarray(tq)


def _as_state(model, state) -> Optional[State]:
    if state is None or isinstance(state, State):
        return state
    return State.from_core(state, model)


def end_triads(model, element: int):
    """(E_p, E_q): the element's end triads [-] as built (columns e_x, e_y, e_z); the chord
    frame for an ANCF element or a model without a builder description."""
    e = model.elements[element]
    desc = getattr(model, "_description", None)
    if e.kind == "pipe" and desc is not None and element < len(desc.get("_elements", ())):
        d = desc["_elements"][element]
        return np.asarray(d["Ep"]), np.asarray(d["Eq"])
    p, q = e.nodes
    chord = model.positions[q] - model.positions[p]
    ex = chord / np.linalg.norm(chord)
    E = np.column_stack([ex, np.zeros(3), np.zeros(3)])
    return E, E


def _reference_slope(model, node, E) -> np.ndarray:
    desc = getattr(model, "_description", None)
    slopes = desc.get("_ancf_nodes", {}) if desc is not None else {}
    return np.asarray(slopes[node], dtype=float) if node in slopes else E[:, 0]


def end_data(model, state=None, *, displacement=None):
    """Per element (x_p, t_p, x_q, t_q) [m]: end positions and end tangents dr/dxi of the
    centre line in ``state`` (default: the reference), plus the linear increments of the
    nodal ``displacement`` (6 n_nodes,) if given."""
    st = _as_state(model, state)
    q = np.asarray(st.q) if st is not None else None
    d = None if displacement is None else np.asarray(displacement, dtype=float)
    out = []
    for k, e in enumerate(model.elements):
        ends = []
        Es = end_triads(model, k)
        for node, E in zip(e.nodes, Es):
            x = model.positions[node].copy() if q is None else q[6 * node:6 * node + 3].copy()
            if e.kind == "ancf":
                t = e.length * (q[6 * node + 3:6 * node + 6] if q is not None else _reference_slope(model, node, E))
                if d is not None:
                    x = x + d[6 * node:6 * node + 3]
                    t = t + e.length * d[6 * node + 3:6 * node + 6]
            else:
                R = np.eye(3) if st is None else st.rotation(node)
                ex = R @ E[:, 0]
                t = e.length * ex
                if d is not None:
                    x = x + d[6 * node:6 * node + 3]
                    t = t + e.length * np.cross(d[6 * node + 3:6 * node + 6], ex)
            ends += [x, t]
        out.append(tuple(ends))
    return out


def centre_line(model, state=None, *, displacement=None, n_points: int = 17) -> List[np.ndarray]:
    """The centre line of each element (a list of (n_points, 3) arrays [m], in the order of
    ``model.elements``) in ``state`` (a :class:`~pipeflex.state.State` or core state;
    default the reference configuration), drawn with the shape functions; plus the linear
    increments of a nodal ``displacement`` (6 n_nodes,), e.g. ``mode_displacement(...)``
    times a scale."""
    xi = np.linspace(0.0, 1.0, int(n_points))
    return [hermite(*ends, xi) for ends in end_data(model, state, displacement=displacement)]


def centre_line_from_frames(model, x, R, *, n_points: int = 17) -> List[np.ndarray]:
    """Centre lines from node positions ``x`` (n_nodes, 3) [m] and rotation matrices ``R``
    (n_nodes, 3, 3) [-], e.g. one output time of a :class:`~pipeflex.TransientResult`. An
    ANCF node's tangent is ``l R e_1`` (its slope's direction; the axial strain, of order
    1e-3 and less, is not in ``R``)."""
    xi = np.linspace(0.0, 1.0, int(n_points))
    out = []
    for k, e in enumerate(model.elements):
        (p, qn), (Ep, Eq) = e.nodes, end_triads(model, k)
        if e.kind == "ancf":
            tp, tq = e.length * R[p][:, 0], e.length * R[qn][:, 0]
        else:
            tp, tq = e.length * R[p] @ Ep[:, 0], e.length * R[qn] @ Eq[:, 0]
        out.append(hermite(x[p], tp, x[qn], tq, xi))
    return out


def mode_displacement(model, mode) -> np.ndarray:
    """Real nodal displacements (6 n_nodes,) of a mode shape ``mode``: reduced coordinates
    (n_dofs,), e.g. a column of ``EigenResult.vectors``, ``CriticalFlow.mode`` or
    ``Campbell.modes[i, b]``; or nodal (6 n_nodes,). A complex mode is turned to the phase
    of largest real nodal translations, then the largest nodal translation is scaled to 1
    (sign: that translation's largest component positive)."""
    v = np.asarray(mode)
    if v.ndim != 1:
        raise ValueError(f"mode must be a 1-D vector, got shape {v.shape}")
    if len(v) == model.n_dofs:
        d = model.basis @ v
    elif len(v) == 6 * model.n_nodes:
        d = v.copy()
    else:
        raise ValueError(f"mode has {len(v)} entries; the model has {model.n_dofs} reduced coordinates "
                         f"({6 * model.n_nodes} nodal)")
    u = d.reshape(-1, 6)[:, :3]
    if np.iscomplexobj(d):
        s = np.sum(u.ravel() ** 2)
        phase = np.exp(-0.5j * np.angle(s)) if abs(s) > 0 else 1.0
        d = (d * phase).real
        u = d.reshape(-1, 6)[:, :3]
    norms = np.linalg.norm(u, axis=1)
    big = int(np.argmax(norms))
    if norms[big] == 0:
        raise ValueError("the mode has no nodal translation")
    c = u[big][np.argmax(np.abs(u[big]))]
    return d / (norms[big] * np.sign(c))


def model_size(model) -> float:
    """Largest extent [m] of the reference node positions (the total length for a model on one point)."""
    ext = float(np.ptp(model.positions, axis=0).max())
    return ext if ext > 0 else float(model.total_length)
