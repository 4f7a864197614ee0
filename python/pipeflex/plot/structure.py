"""A drawing of a model: centre line, supports, hinges, hub, loads, point masses, flow."""
from __future__ import annotations

from typing import Optional

import numpy as np

from ..state import State
from . import _axes
from .centreline import centre_line, end_data, hermite, model_size

#: Marker of each support kind (clamp, pin, hinge, hub, partial).
SUPPORT_MARKERS = {"clamp": "s", "pin": "^", "hinge": "o", "hub": "H", "partial": "v"}


def supports(model) -> dict:
    """node -> (kind, axis): kind "clamp", "pin", "hinge" (axis: the free rotation axis [-]),
    "hub" (axis: the hub axis) or "partial" (some coordinates fixed), from the builder's
    constraints. ANCF nodes: the planar rows (z, z') do not count; position and slope
    direction fixed is a clamp, position only a pin."""
    desc = getattr(model, "_description", None) or {}
    rows_of = desc.get("_constraints", {})
    ancf = set(model.ancf_nodes)
    hub = set(model.hub.nodes) if model.hub is not None else set()
    out = {}
    for node, rows in rows_of.items():
        C = np.array(rows, dtype=float).reshape(-1, 6)
        if node in ancf:
            C = np.array([r for r in C if not (np.allclose(r, np.eye(6)[2]) or np.allclose(r, np.eye(6)[5]))])
            C = C.reshape(-1, 6)
            if not len(C) and node not in hub:
                continue  # only the planar rows: no support
            npos = np.linalg.matrix_rank(C[:, :3]) if len(C) else 0
            nrot = np.linalg.matrix_rank(C[:, 3:]) if len(C) else 0
            kind = "clamp" if (npos, nrot) == (2, 1) else "pin" if (npos, nrot) == (2, 0) else "partial"
            axis = None
        else:
            npos = np.linalg.matrix_rank(C[:, :3])
            nrot = np.linalg.matrix_rank(C[:, 3:])
            axis = None
            if (npos, nrot) == (3, 3):
                kind = "clamp"
            elif (npos, nrot) == (3, 0):
                kind = "pin"
            elif (npos, nrot) == (3, 2):
                kind = "hinge"
                axis = np.linalg.svd(C[:, 3:])[2][-1]
            else:
                kind = "partial"
        if node in hub:
            kind, axis = "hub", model.hub.axis
        out[int(node)] = (kind, axis)
    return out


def _shows(ax, direction, plane) -> bool:
    """Does a segment along ``direction`` show on the axes (not end-on in a 2D projection)?"""
    if _axes.is_3d(ax):
        return True
    i, j = _axes.plane_of(ax, plane)
    return float(np.hypot(direction[i], direction[j])) > 1e-9


def model(model, state=None, *, ax=None, plane: Optional[str] = None, n_points: int = 17,
          show_supports: bool = True, show_loads: bool = True, show_flow: bool = True,
          show_nodes: bool = True, color: str = "k", legend: bool = True, label: Optional[str] = None):
    """Draw a model: each element's centre line with its shape functions (cubic Hermite in
    end positions and end tangents), the nodes, supports (clamp, pin, hinge with its axis,
    rotating hub with its axis, partial), nodal forces and moments (arrows, longest 0.2 of
    the model's size; follower loads turned with their node), point masses and the flow
    direction (an arrow at the middle of each element that carries fluid, for a positive
    mass flow).

    Args:
        model: a :class:`~pipeflex.Model`.
        state: a :class:`~pipeflex.state.State` (or core state) to draw; default the
            reference configuration.
        ax: 3D axes, or 2D axes to draw the projection on ``plane``; default new 3D axes
            (new 2D axes if ``plane`` is given).
        plane: "xy", "xz" or "yz" for 2D axes.
        n_points: points per element.
        show_supports, show_loads, show_flow, show_nodes: what to draw.
        color: colour of the centre line. legend: add a legend. label: the centre line's.

    Returns:
        The axes.
    """
    ax = _axes.space_axes(ax, plane=plane)
    st = state if state is None or isinstance(state, State) else State.from_core(state, model)
    lines = centre_line(model, st, n_points=n_points)
    for k, pts in enumerate(lines):
        ax.plot(*_axes.coords(ax, pts, plane), "-", color=color, lw=2,
                label=(label or "centre line") if k == 0 else None)
    x = model.positions if st is None else np.asarray(st.q).reshape(-1, 6)[:, :3]
    size = model_size(model)
    drawn = [np.vstack(lines)]
    if show_nodes:
        ax.plot(*_axes.coords(ax, x, plane), ".", color=color, ms=5, label="nodes")
    if show_supports:
        first = set()
        for node, (kind, axis) in sorted(supports(model).items()):
            ax.plot(*_axes.coords(ax, x[node], plane), SUPPORT_MARKERS[kind], ms=10,
                    mfc="none" if kind == "partial" else "0.6",
                    mec="k", label=None if kind in first else kind)
            first.add(kind)
            if axis is not None and _shows(ax, axis, plane):
                c = model.hub.center if kind == "hub" else x[node]
                seg = np.array([c - 0.15 * size * axis, c + 0.15 * size * axis])
                ax.plot(*_axes.coords(ax, seg, plane), "-." if kind == "hub" else "-", color="0.3", lw=1,
                        label=None if f"{kind} axis" in first else f"{kind} axis")
                first.add(f"{kind} axis")
                drawn.append(seg)
    desc = getattr(model, "_description", None) or {}
    if show_loads:
        loads = desc.get("_loads", [])
        vecs = []
        for ld in loads:
            R = np.eye(3) if st is None or st.ancf[ld["node"]] else st.rotation(ld["node"])
            vecs.append((ld["node"], "force", np.asarray(ld["f"]) + R @ np.asarray(ld["ff"])))
            vecs.append((ld["node"], "moment", np.asarray(ld["m"]) + R @ np.asarray(ld["fm"])))
        for what, col in (("force", "C3"), ("moment", "C4")):
            sel = [(n, v) for n, w, v in vecs if w == what and np.linalg.norm(v) > 0]
            if not sel:
                continue
            big = max(np.linalg.norm(v) for _, v in sel)
            base = np.array([x[n] for n, _ in sel])
            vec = np.array([0.2 * size * v / big for _, v in sel])
            unit = "N" if what == "force" else "N m"
            _axes.arrows(ax, base, vec, plane, color=col, label=f"{what} (largest {big:.3g} {unit})")
            drawn.append(base + vec)
        masses = desc.get("_masses", [])
        if masses:
            pm = np.array([x[m["node"]] for m in masses])
            ax.plot(*_axes.coords(ax, pm, plane), "o", color="C0", ms=9, label="point mass")
    if show_flow:
        ends = end_data(model, st)
        base, vec = [], []
        for e, (xp, tp, xq, tq) in zip(model.elements, ends):
            if e.kind != "pipe" or e.flow_factor == 0 or e.section.fluid_mass <= 0:
                continue
            mid = hermite(xp, tp, xq, tq, [0.5])[0]
            t = hermite(xp, tp, xq, tq, [0.5], derivative=True)[0]
            base.append(mid)
            vec.append(np.sign(e.flow_factor) * min(0.6 * e.length, 0.08 * size) * t / np.linalg.norm(t))
        if base:
            base, vec = np.array(base), np.array(vec)
            _axes.arrows(ax, base - 0.5 * vec, vec, plane, color="C0", label="flow ($\\dot m > 0$)")
    _axes.label_space(ax, plane)
    _axes.equal_scale(ax, np.vstack(drawn), plane)
    if legend:
        ax.legend(fontsize=8, loc="best")
    return ax
