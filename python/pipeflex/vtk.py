"""ParaView export: a result's motion as a VTK time series (``.pvd`` of ``.vtu`` files).

Written through meshio (``apt install python3-meshio`` or ``pip install meshio``), imported
on first use. The centre line is one line cell per element through its two nodes (the
nodes of a floating-frame body in order along it); an ANCF model lies in its plane
z = const as computed. With ``tube=True`` a second series draws each element as a tube
of the pipe's outer radius. Point data (SI): ``displacement`` [m] from the reference
configuration, ``velocity`` [m/s], ``angular_velocity`` [rad/s] and ``rotation`` [rad]
(the rotation vector from the reference orientation), where the result has them; cell
data: ``element`` (the element's index in ``model.elements``, or the body's index) and,
for the pipe elements of a result with node rotations, their section forces
(:data:`SECTION_FORCES`; NaN on ANCF elements and floating-frame bodies). A
floating-frame body's nodes carry ``displacement`` from the first output time and
``angular_velocity``.
"""
from __future__ import annotations

from pathlib import Path
from typing import List, Optional, Union
from xml.sax.saxutils import quoteattr

import numpy as np

from . import _checks

#: The section forces written as cell data, from the element's generalised stresses (its
#: constitutive law, ``_core.pipe_predicted_stresses``) in the element's local axes x
#: (along it), y, z: ``axial_force`` N [N], ``torsion_moment`` T [N m], ``bending_moment_y``
#: and ``bending_moment_z`` M_y, M_z [N m] at the element's midpoint (the mean of its end
#: moments: exact for end loads, as the element's moments are linear along it), and
#: ``shear_force_y``, ``shear_force_z`` V_y, V_z [N] (the element's mean, from the slope of
#: its moments). Signs: the forces and moments on the face whose outward normal is +x.
SECTION_FORCES = ("axial_force", "torsion_moment", "bending_moment_y", "bending_moment_z", "shear_force_y",
                  "shear_force_z")


def _meshio():
    try:
        import meshio
    except ImportError:
        raise ImportError("to_vtk writes VTK files through meshio: apt install python3-meshio "
                          "(or pip install meshio)") from None
    return meshio


def _folder(folder) -> Path:
    p = Path(folder)
    if p.exists() and not p.is_dir():
        raise ValueError(f"folder {str(p)!r} is a file, not a folder: give a folder for the .pvd and .vtu files")
    try:
        p.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ValueError(f"folder {str(p)!r}: cannot make it ({exc.strerror or exc})") from None
    return p


def _element_model(model):
    """The element model of ``model`` (a Model, or a CoupledSystem's ``model``)."""
    # by what it has, not its class: this module sits below the models and results
    for m in (model, getattr(model, "model", None)):
        if m is not None and hasattr(m, "initial_state") and hasattr(m, "n_nodes"):
            return m
    raise TypeError(f"model must be the pipeflex.Model (or CoupledSystem) the result was computed with, "
                    f"got {type(model).__name__}")


def _reference_rotations(model) -> np.ndarray:
    from .state import State

    ref = State.from_core(model.initial_state(), model)
    return np.array([ref.rotation(n) for n in range(model.n_nodes)])


def _rotation_vectors(R: np.ndarray, R0: np.ndarray) -> np.ndarray:
    """Rotation vectors [rad] of R R0^T, (..., 3, 3) -> (..., 3)."""
    from scipy.spatial.transform import Rotation

    rel = R @ np.swapaxes(R0, -1, -2)
    return Rotation.from_matrix(rel.reshape(-1, 3, 3)).as_rotvec().reshape(rel.shape[:-1])


class _Frames:
    """The motion to write: times, points per frame, line cells, point and cell data."""

    def __init__(self, t, points, cells, point_data, element, radii, cell_data=None):
        self.cell_data = cell_data or {}  # name -> (nt, n_cells)
        self.t = np.asarray(t, float)
        self.points = points  # (nt, n_points, 3)
        self.cells = np.asarray(cells, dtype=np.int64).reshape(-1, 2)
        self.point_data = point_data  # name -> (nt, n_points, 3)
        self.element = np.asarray(element, dtype=np.int64)
        self.radii = np.asarray(radii, float)  # per cell [m]


def _element_frames(t, x, R, xd, omega, model, radius) -> _Frames:
    cells = [e.nodes for e in model.elements]
    data = {"displacement": x - model.positions[None]}
    if xd is not None:
        data["velocity"] = xd
    if omega is not None:
        data["angular_velocity"] = omega
    if R is not None:
        data["rotation"] = _rotation_vectors(R, _reference_rotations(model)[None])
    radii = [_radius(e.section, radius, model.length_scale) for e in model.elements]
    forces = None if R is None else _section_forces(model, x, R)
    return _Frames(t, x, cells, data, np.arange(len(cells)), radii, forces)


def _section_forces(model, x: np.ndarray, R: np.ndarray) -> dict:
    """:data:`SECTION_FORCES` (each (nt, n_elements), NaN but on pipe elements) at the node
    positions x (nt, n_nodes, 3) [m] and rotations R (nt, n_nodes, 3, 3)."""
    from . import _core

    out = np.full((len(SECTION_FORCES), x.shape[0], len(model.elements)), np.nan)
    zero, dq = np.zeros(3), np.zeros(12)
    pipe = 0  # the core numbers the pipe elements among themselves
    for k, e in enumerate(model.elements):
        if e.kind != "pipe":
            continue
        data = model.core.pipe(pipe)
        pipe += 1
        p, q = e.nodes
        for i in range(x.shape[0]):
            # the nodes' frames are their rotations (rotation vectors 0): the element's own triads
            s = _core.pipe_predicted_stresses(data, R[i, p], R[i, q], np.concatenate([x[i, p], zero, x[i, q], zero]),
                                              dq)
            # sigma [N]: axial force, then torsion and the end moments over l0 (conjugate to l0 theta)
            out[:, i, k] = (s[0], data.l0 * s[1], 0.5 * data.l0 * (s[2] + s[3]), 0.5 * data.l0 * (s[4] + s[5]),
                            s[4] - s[5], s[3] - s[2])
    return dict(zip(SECTION_FORCES, out))


def _radius(section, radius, length_scale: float) -> float:
    """The tube's outer radius [m]: ``radius`` if given, else the section's outer diameter
    / 2 where it records one, else 2 % of the model's length scale."""
    if radius is not None:
        return _checks.positive("radius", radius)
    d = getattr(section, "outer_diameter", None)
    return 0.5 * float(d) if d else 0.02 * length_scale


def _body_frames(bodies, radius, times: slice) -> _Frames:
    """The floating-frame bodies' nodes in world coordinates (``node_position``) at the
    output ``times``."""
    points, cells, element = [], [], []
    omega = []
    first = 0
    for j, s in enumerate(bodies.nodes_s):
        n = len(s)
        x = np.stack([bodies.node_position(j, i)[times] for i in range(n)], axis=1)  # (nt, n, 3)
        points.append(x)
        omega.append(np.stack([bodies.node_angular_velocity(j, i)[times] for i in range(n)], axis=1))
        cells += [(first + i, first + i + 1) for i in range(n - 1)]
        element += [j] * (n - 1)
        first += n
    x = np.concatenate(points, axis=1)
    size = float(np.ptp(x[0], axis=0).max()) or 1.0
    r = _checks.positive("radius", radius) if radius is not None else 0.02 * size
    return _Frames(bodies.t[times], x, cells, {"displacement": x - x[:1],
                                               "angular_velocity": np.concatenate(omega, axis=1)},
                   element, np.full(len(cells), r))


def _frames(result, model, radius, every: int = 1) -> List[_Frames]:
    """The result's frames to write: every ``every``-th output time (from the first)."""
    from .state import State

    times = slice(None, None, every)

    if hasattr(result, "t"):  # a TransientResult (duck-typed: the results import this module)
        out = []
        if result.x is not None:
            if model is None:
                raise TypeError("to_vtk: pass the model the result was computed with (model=...): its elements "
                                "connect the nodes")
            m = _element_model(model)
            out.append(_element_frames(*(None if a is None else a[times] for a in
                                         (result.t, result.x, result.R, result.xd, result.omega)), m, radius))
        if result.bodies is not None:
            out.append(_body_frames(result.bodies, radius, times))
        return out
    if hasattr(result, "state"):  # a StaticResult
        if not isinstance(result.state, State):
            raise TypeError("to_vtk of a static result needs an element model's state (a pipeflex.State); a "
                            "system of bodies alone is not supported")
        if model is None:
            raise TypeError("to_vtk: pass the model the result was computed with (model=...)")
        m = _element_model(model)
        st = result.state
        q = np.asarray(st.q).reshape(-1, 6)
        R = np.array([st.rotation(n) for n in range(st.n_nodes)])
        return [_element_frames([0.0], q[None, :, :3], R[None], None, None, m, radius)]
    raise TypeError(f"to_vtk writes a TransientResult or a StaticResult, got {type(result).__name__}")


def _merge(parts: List[_Frames]) -> _Frames:
    if len(parts) == 1:
        return parts[0]
    offsets = np.cumsum([0] + [p.points.shape[1] for p in parts])
    names = set.intersection(*(set(p.point_data) for p in parts))
    nt = len(parts[0].t)
    cell = {k: np.concatenate([p.cell_data.get(k, np.full((nt, len(p.cells)), np.nan)) for p in parts], axis=1)
            for k in sorted(set().union(*(p.cell_data for p in parts)))}  # NaN where a part has none
    return _Frames(parts[0].t, np.concatenate([p.points for p in parts], axis=1),
                   np.concatenate([p.cells + o for p, o in zip(parts, offsets)]),
                   {k: np.concatenate([p.point_data[k] for p in parts], axis=1) for k in sorted(names)},
                   np.concatenate([p.element for p in parts]), np.concatenate([p.radii for p in parts]), cell)


def _ring_basis(axis: np.ndarray) -> np.ndarray:
    """Two unit vectors (n, 2, 3) normal to each row of ``axis`` (n, 3) and to each other."""
    a = axis / np.linalg.norm(axis, axis=1)[:, None]
    helper = np.zeros_like(a)
    helper[np.arange(len(a)), np.argmin(np.abs(a), axis=1)] = 1.0  # the global axis least along a
    u = np.cross(a, helper)
    u /= np.linalg.norm(u, axis=1)[:, None]
    return np.stack([u, np.cross(a, u)], axis=1)


def _tube(points: np.ndarray, f: _Frames, n_sides: int):
    """A tube's points (n_cells * 2 * n_sides, 3), quads and each point's source point."""
    p, q = f.cells[:, 0], f.cells[:, 1]
    B = _ring_basis(points[q] - points[p])
    a = 2 * np.pi * np.arange(n_sides) / n_sides
    ring = (np.cos(a)[None, :, None] * B[:, None, 0] + np.sin(a)[None, :, None] * B[:, None, 1])
    ring = ring * f.radii[:, None, None]
    pts = np.concatenate([points[p][:, None] + ring, points[q][:, None] + ring], axis=1).reshape(-1, 3)
    source = np.concatenate([np.repeat(p[:, None], n_sides, 1), np.repeat(q[:, None], n_sides, 1)], axis=1).ravel()
    k = np.arange(n_sides)
    base = (2 * n_sides * np.arange(len(p)))[:, None]
    quads = np.stack([base + k, base + (k + 1) % n_sides, base + n_sides + (k + 1) % n_sides, base + n_sides + k],
                     axis=2).reshape(-1, 4)
    return pts, quads, source


def _write_pvd(path: Path, t: np.ndarray, files: List[str]) -> None:
    rows = "\n".join(f'    <DataSet timestep="{float(ti)!r}" group="" part="0" file={quoteattr(name)}/>'
                     for ti, name in zip(t, files))
    path.write_text('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">\n'
                    f"  <Collection>\n{rows}\n  </Collection>\n</VTKFile>\n", encoding="utf-8")


def write_vtk(result, folder: Union[str, Path], model=None, *, name: str = "pipeflex", tube: bool = False,
              radius: Optional[float] = None, n_sides: int = 16, every: int = 1) -> List[Path]:
    """Write ``result`` for ParaView: ``folder/<name>.pvd`` listing ``<name>_<k>.vtu`` at each
    output time (the centre line), and with ``tube=True`` also ``<name>_tube.pvd`` (the
    tube surface). Open the .pvd in ParaView. Returns the .pvd paths.

    Args:
        result: a :class:`~pipeflex.TransientResult` (element model, bodies or coupled
            system) or a :class:`~pipeflex.StaticResult` of an element model (one frame at
            t = 0).
        folder: the folder [-], made if missing; a file there is an error.
        model: the :class:`~pipeflex.Model` (or :class:`~pipeflex.CoupledSystem`) the
            result was computed with: its elements connect the nodes. Not needed for
            bodies alone.
        name: the files' stem [-].
        tube: also write the tube surface.
        radius: r [m] > 0, the tube's outer radius; default the section's outer diameter / 2
            where the section records one, else 2 % of the model's length scale.
        n_sides: [-] >= 3, facets around the tube.
        every: [-] >= 1, write every ``every``-th output time.
    """
    meshio = _meshio()
    out = _folder(folder)
    if not isinstance(name, str) or not name or "/" in name or "\\" in name:
        raise ValueError(f"name must be a file stem without a folder, got {name!r}")
    every = _checks.positive_int("every", every)
    n_sides = _checks.positive_int("n_sides", n_sides)
    if n_sides < 3:
        raise ValueError(f"n_sides must be >= 3 (facets around the tube), got {n_sides}")
    f = _merge(_frames(result, model, radius, every))
    if len(f.t) == 0:
        raise ValueError("the result has no output times")
    width = max(4, len(str(every * (len(f.t) - 1))))
    lines, tubes = [], []
    for k in range(len(f.t)):  # files numbered by the output time's index in the result
        pts = np.asarray(f.points[k], float)
        data = {key: np.asarray(v[k], float) for key, v in f.point_data.items()}
        file = f"{name}_{every * k:0{width}d}.vtu"
        cell = {"element": [f.element], **{key: [np.asarray(v[k], float)] for key, v in f.cell_data.items()}}
        meshio.write(out / file, meshio.Mesh(pts, [("line", f.cells)], point_data=data, cell_data=cell))
        lines.append(file)
        if tube:
            tp, quads, source = _tube(pts, f, n_sides)
            file = f"{name}_tube_{every * k:0{width}d}.vtu"
            meshio.write(out / file, meshio.Mesh(tp, [("quad", quads)],
                                                 point_data={key: v[source] for key, v in data.items()},
                                                 cell_data={key: [np.repeat(v[0], n_sides)]
                                                            for key, v in cell.items()}))
            tubes.append(file)
    paths = [out / f"{name}.pvd"]
    _write_pvd(paths[0], f.t, lines)
    if tube:
        paths.append(out / f"{name}_tube.pvd")
        _write_pvd(paths[1], f.t, tubes)
    return paths
