"""Model building: nodes, pipe/beam elements, supports, loads.

A :class:`ModelBuilder` collects the description; :meth:`ModelBuilder.build` checks it
and returns an immutable :class:`Model`. Analyses are free functions of a model and a
state (see :mod:`pipeflex.analysis`). Conventions (DOF order, signs, units) are in
``docs/conventions.md``: every node has six coordinates: a frame node (pipe/beam
element of Meijaard & Hakvoort) ``[x, y, z, phi_x, phi_y, phi_z]``, position in m and a spatial
rotation vector in rad; an ANCF node (planar beam of Berzeri & Shabana) ``[x, y, z, x', y', z']``,
position in m and the slope dr/dx [-] (z and z' are fixed: the element is planar).
"""
from __future__ import annotations

import copy
import functools
from itertools import chain
from dataclasses import dataclass
from typing import Iterable, List, Optional, Sequence, Tuple

import numpy as np

from . import _checks, _core
from .rotation import skew
from .sections import PipeSection, refuse_unsupported, require_section
from .time_functions import time_function as as_time_table

COMPONENTS = ("ux", "uy", "uz", "rx", "ry", "rz")
ANCF_COMPONENTS = ("ux", "uy", "uz", "dx", "dy", "dz")  # position, slope dr/dx
ELASTIC_MODELS = ("A", "0")
_IDENTITY = np.eye(6)  # the basis of every free node, one read-only array for all of them
_IDENTITY.flags.writeable = False
_NEXT, _LAST = np.array([1, 2, 0]), np.array([2, 0, 1])  # (a x b)_i = a[_NEXT[i]] b[_LAST[i]] - a[_LAST[i]] b[_NEXT[i]]

#: The element state (a ``_core.State``) of each core system built by a model's ``_system``,
#: which the analyses update in place: read back by ``_state_of`` (the system object does not
#: expose it). Weak: an entry goes with its system.


def _triads(tangents: np.ndarray, up: Optional[np.ndarray], where=lambda k: "") -> np.ndarray:
    """Orthonormal triads (n, 3, 3), each [e_x, e_y, e_z] (columns): e_x along a row of
    ``tangents`` (n, 3), e_z towards ``up`` (default global z, global y for a vertical
    e_x). Component by component, in the order of the scalar formulas: a line's triads
    are those of its elements one by one to round-off (a few ulps). ``where(k)`` names element k in
    the message if ``up`` is parallel to its axis."""
    T = np.asarray(tangents, dtype=float)
    T2 = T * T
    EX = T / np.sqrt(T2[:, 0] + T2[:, 1] + T2[:, 2])[:, None]
    if up is None:
        U = np.zeros_like(EX)
        vertical = np.abs(EX[:, 2]) >= 0.9
        U[:, 1], U[:, 2] = vertical, ~vertical
    else:
        U = np.broadcast_to(np.asarray(up, dtype=float), EX.shape)
    D = U * EX
    EZ = U - (D[:, 0] + D[:, 1] + D[:, 2])[:, None] * EX
    Z2 = EZ * EZ
    n = np.sqrt(Z2[:, 0] + Z2[:, 1] + Z2[:, 2])
    if not (n >= 1e-9).all():
        k = np.flatnonzero(~(n >= 1e-9))[0]
        raise ValueError(f"up vector {U[k]} is parallel to the element axis {EX[k]}{where(k)}")
    EZ = EZ / n[:, None]
    E = np.empty((len(T), 3, 3))
    E[:, :, 0], E[:, :, 2] = EX, EZ
    E[:, :, 1] = EZ[:, _NEXT] * EX[:, _LAST] - EZ[:, _LAST] * EX[:, _NEXT]  # e_z x e_x
    return E


def _triad(tangent: np.ndarray, up: Optional[np.ndarray]) -> np.ndarray:
    """The triad (3 x 3) of :func:`_triads` for one ``tangent``."""
    return _triads(np.asarray(tangent, dtype=float).reshape(1, 3), up)[0]


def _squares(x: np.ndarray) -> np.ndarray:
    """x**2 by libm's pow, as Python's and numpy's scalar ``x**2`` (an array's ``x**2`` is
    x*x, which differs from pow in the last bit for ~0.1 % of x): the element data stay
    those of the scalar formulas (to the last bit where numpy's array and scalar paths
    agree, which depends on the CPU and numpy)."""
    return np.power(x, 2.0)


def _snapshot(description: dict) -> dict:
    """A copy of the builder's state that later builder calls cannot change: its lists
    and the records in them are copied, the arrays and sections they hold are never
    modified in place (a deep copy cost ~0.2 ms per element)."""
    out = {}
    for key, value in description.items():
        if isinstance(value, list):
            out[key] = [dict(v) if isinstance(v, dict) else v for v in value]
        elif isinstance(value, (set, dict)):
            out[key] = copy.copy(value)
        else:
            out[key] = value
    return out


def _strain_free_lengths(chords: np.ndarray, lc: np.ndarray, Ep: np.ndarray, Eq: np.ndarray,
                         where=lambda k: "") -> np.ndarray:
    """l0 with eps_1 = 0 (eq. 1) for end triads Ep, Eq (n, 3, 3; columns e_x, e_y, e_z),
    chords (n, 3) and their lengths lc (n): eps_1 = l - l0 + l0 c with
    c = (2c3^2 + c3 c4 + 2c4^2 + 2c5^2 + c5 c6 + 2c6^2)/30, where c_k = eps_bar_k / l0
    depend on the directions only. ``where(k)`` names element k in the message."""
    el = (chords / lc[:, None])[:, :, None]
    P, Q = el * Ep, el * Eq
    P, Q = P[:, 0] + P[:, 1] + P[:, 2], Q[:, 0] + Q[:, 1] + Q[:, 2]  # el . e_x, e_y, e_z, summed x, y, z
    c3, c4 = -P[:, 2], Q[:, 2]
    c5, c6 = P[:, 1], -Q[:, 1]
    c = (2 * _squares(c3) + c3 * c4 + 2 * _squares(c4) + 2 * _squares(c5) + c5 * c6 + 2 * _squares(c6)) / 30.0
    if (c >= 1.0).any():
        raise ValueError(f"element end tangents turn too far from the chord for one "
                         f"element{where(np.flatnonzero(c >= 1.0)[0])}")
    return lc / (1.0 - c)


@dataclass(frozen=True)
class ElementInfo:
    """What the builder recorded of an element (for plotting and post-processing).

    ``kind`` is ``"pipe"`` (3D pipe element with flow) or ``"ancf"`` (planar ANCF beam of
    Berzeri & Shabana, whose elastic force model ``elastic`` is ``"A"`` or ``"0"``)."""

    nodes: Tuple[int, int]
    section: PipeSection
    length: float
    flow_factor: float
    kind: str = "pipe"
    elastic: Optional[str] = None


@dataclass(frozen=True)
class SpringInfo:
    """What the builder recorded of a spring-damper (massless, linear).

    ``kind`` is ``"axial"`` (between ``nodes`` = (a, b), along the line between them:
    ``stiffness`` k [N/m] and ``damping`` c [N s/m] numbers, unstressed at the nodes'
    reference distance), ``"ground"`` (from ``nodes`` = (node,) to the fixed ``anchor``
    [m], the node's reference position if None) or ``"bushing"`` (between ``nodes`` =
    (a, b), unstressed at their reference offset and orientations); a ground spring and a
    bushing have ``stiffness`` (kx, ky, kz) [N/m] and ``damping`` (cx, cy, cz) [N s/m]
    along the global axes, ``rotational_stiffness`` k_phi (3) [N m/rad] and
    ``rotational_damping`` c_phi (3) [N m s/rad] about them, tuples (None for an axial
    spring)."""

    kind: str
    nodes: Tuple[int, ...]
    stiffness: object
    damping: object
    anchor: Optional[Tuple[float, float, float]] = None
    rotational_stiffness: Optional[Tuple[float, float, float]] = None
    rotational_damping: Optional[Tuple[float, float, float]] = None


@dataclass(frozen=True)
class HubInfo:
    """A rigid hub turning the ``nodes`` about ``axis`` through ``center`` [m]: angle
    theta(t) of Berzeri & Shabana's eq. 13 with final rate ``omega`` [rad/s] reached after
    ``spin_up_time`` [s] (0: constant omega from t = 0)."""

    nodes: Tuple[int, ...]
    axis: np.ndarray
    center: np.ndarray
    omega: float
    spin_up_time: float


class ModelBuilder:
    """Collects nodes, elements, supports and loads; :meth:`build` returns a :class:`Model`.

    Example::

        b = ModelBuilder()
        n0 = b.add_node((0, 0, 0)); n1 = b.add_node((1, 0, 0))
        b.add_pipe(n0, n1, PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0))
        b.clamp(n0)
        model = b.build(mass_flow=5.0)
    """

    def __init__(self) -> None:
        self._positions: List[np.ndarray] = []
        self._elements: List[dict] = []
        self._constraints: dict = {}
        self._loads: List[dict] = []
        self._masses: List[dict] = []
        self._gravity = np.zeros(3)
        self._ancf_nodes: dict = {}  # node -> reference slope
        self._ancf: List[dict] = []
        self._springs: List[dict] = []
        self._distributed: List[dict] = []  # add_distributed_load
        self._hub: Optional[HubInfo] = None
        # the public calls that made the description, (method, args, kwargs): what
        # pipeflex.save_model writes; _depth > 0 inside a recorded call
        self._recipe: List[tuple] = []
        self._depth = 0
        self._rayleigh = (0.0, 0.0)  # (alpha [1/s], beta [s]) of rayleigh_damping

    # -- nodes and elements -------------------------------------------------------
    def add_node(self, position: Sequence[float]) -> int:
        """Add a node at ``position`` [m]; returns its index."""
        self._positions.append(_checks.vector3("position", position))
        return len(self._positions) - 1

    def _node(self, name: str, i) -> int:
        if isinstance(i, bool) or not isinstance(i, (int, np.integer)) or not 0 <= i < len(self._positions):
            raise ValueError(f"{name} refers to node {i!r}, but the model has nodes 0..{len(self._positions) - 1}")
        return int(i)

    def add_ancf_node(self, position: Sequence[float], slope: Sequence[float] = (1.0, 0.0, 0.0)) -> int:
        """Add an ANCF node at ``position`` [m] with the unit reference ``slope`` dr/dx [-]
        in the x-y plane (z and z' are fixed at build)."""
        x = _checks.vector3("position", position)
        d = _checks.unit_vector("slope", slope)
        if abs(d[2]) > 1e-12:
            raise ValueError("slope must lie in the x-y plane (ANCF elements are planar)")
        self._positions.append(x)
        self._ancf_nodes[len(self._positions) - 1] = d
        return len(self._positions) - 1

    def add_ancf_beam(self, start, end: Sequence[float], n_elements: int, section: PipeSection, *,
                      elastic: str = "A") -> List[int]:
        """A straight planar ANCF beam (Berzeri & Shabana) from ``start`` (an ANCF node index, or a
        point [m]) to the point ``end`` [m] in ``n_elements`` equal elements; returns the
        node indices (start first).

        Args:
            section: ``EA`` [N] axial stiffness, ``EIz`` [N m^2] in-plane bending
                stiffness (bending about z; the section's EI unless EIz is given: ``EI``,
                the out-of-plane ``E I_y``, is otherwise unused), ``pipe_mass`` [kg/m]
                rho A, the damping ``eta_axial``, ``eta_bending`` [s] and ``c_ext``
                [N s/m^2], the foundation ``k_found`` [N/m^2]; ``fluid_mass`` must be 0
                (no flow in ANCF elements) and ``kv``, ``GAy``, ``GAz``, ``rotary_inertia``, ``GJ``, ``eta_torsion`` at their
                defaults (refused by name otherwise: the element has none of them).
            elastic: elastic force model, ``"A"`` (continuum strain, captures centrifugal
                stiffening) or ``"0"`` (linear strain in a local element frame).
        """
        if elastic not in ELASTIC_MODELS:
            raise ValueError(f"elastic must be one of {ELASTIC_MODELS}, got {elastic!r}")
        section = require_section(section)
        if section.fluid_mass != 0.0:
            raise ValueError("ANCF beams carry no fluid: section.fluid_mass must be 0")
        refuse_unsupported(section, {"kv": "the ANCF beam carries no fluid",
                                     "GAy": "the ANCF beam is rigid in shear (Euler-Bernoulli)",
                                     "GAz": "the ANCF beam is rigid in shear (Euler-Bernoulli)",
                                     "rotary_inertia": "the ANCF beam has no rotary inertia of the cross-section",
                                     "GJ": "the planar ANCF beam has no torsion",
                                     "eta_torsion": "the planar ANCF beam has no torsion"}, "add_ancf_beam")
        n = _checks.element_count("n_elements", n_elements, self._n_elements())
        x1 = _checks.vector3("end", end)
        if isinstance(start, (int, np.integer)) and not isinstance(start, bool):
            first = self._node("start", start)
            if first not in self._ancf_nodes:
                raise ValueError(f"start node {first} is not an ANCF node")
            x0 = self._positions[first]
        else:
            x0 = _checks.vector3("start", start)
            first = None
        chord = x1 - x0
        L = float(np.linalg.norm(chord))
        if L <= 0.0:
            raise ValueError("the beam has zero length: start and end coincide")
        if abs(chord[2]) > 1e-12 * L:
            raise ValueError("an ANCF beam must lie in a plane z = const")
        d = chord / L
        if first is None:
            first = self.add_ancf_node(x0, d)
        elif not np.allclose(self._ancf_nodes[first], d, atol=1e-12):
            raise ValueError(f"start node {first} has slope {self._ancf_nodes[first]}, not along the beam {d}")
        nodes = [first]
        for k in range(1, n + 1):
            nodes.append(self.add_ancf_node(x0 + chord * k / n, d))
            self._ancf.append(dict(p=nodes[-2], q=nodes[-1], section=section, l=L / n, elastic=elastic))
        return nodes

    def rotating_hub(self, node: int, *, omega: float, spin_up_time: float = 0.0,
                     center: Sequence[float] = (0.0, 0.0, 0.0), axis: Sequence[float] = (0.0, 0.0, 1.0)) -> None:
        """Clamp ``node`` to a rigid hub turning about ``axis`` through ``center`` [m].

        The angle is prescribed: theta(t) of Berzeri & Shabana's eq. 13, a smooth spin-up from rest
        to ``omega`` [rad/s] over ``spin_up_time`` T [s], then theta = omega (t - T/2); with
        T = 0 the hub turns at constant omega from t = 0 (the model's initial state is
        then at rest: start such runs from a steady state). Rotating-frame analyses
        (:func:`pipeflex.rotating_frequencies`) use the hub's axis and centre.
        """
        node = self._node("node", node)
        omega = _checks.finite("omega", omega)
        T = _checks.non_negative("spin_up_time", spin_up_time)
        if self._hub is not None and node not in self._hub.nodes:
            nodes = self._hub.nodes + (node,)
            if not (np.allclose(self._hub.axis, axis) and np.allclose(self._hub.center, center)
                    and self._hub.omega == omega and self._hub.spin_up_time == T):
                raise ValueError("all hub nodes must share one axis, centre and angle law")
        else:
            nodes = (node,)
        self.clamp(node)
        self._hub = HubInfo(nodes, _checks.unit_vector("axis", axis), _checks.vector3("center", center), omega, T)

    def add_pipe(self, p: int, q: int, section: PipeSection, *, up: Optional[Sequence[float]] = None,
                 tangent_p: Optional[Sequence[float]] = None, tangent_q: Optional[Sequence[float]] = None,
                 length: Optional[float] = None, flow_factor: float = 1.0,
                 fluid_end_terms: bool = True) -> int:
        """Add a two-node pipe/beam element from node ``p`` (inlet) to node ``q`` (outlet).

        Args:
            p, q: node indices; the fluid flows from p to q.
            section: cross-section and masses (:class:`PipeSection`).
            up: vector [-] that fixes the local z axis (projected normal to the element
                axis); default global z (global y for a vertical element).
            tangent_p, tangent_q: centre-line tangents at the ends of an initially curved
                element (default: the chord). The element is stress-free as built.
            length: l0 [m] reference length. Default: the chord for a straight element;
                for a curved one the length at which the axial strain eps_1 of eq. 1
                vanishes in the stress-free shape (Meijaard & Hakvoort: sigma_1 has no eps_1^0, "an
                initial elongation can be taken into account by modifying l0"); for a
                circular arc of angle t this is the chord / (1 - sin^2(t/2)/6), shorter than
                the arc by about 17 (t/2)^4 / 360 relative (7e-5 for t = pi/8).
            flow_factor: [-] this element's mass flow as a multiple of the model's
                (1: in series with the flow, 0: no flow, -1: reversed).
            fluid_end_terms: keep the split-off end terms of eqs. 19-20 of Meijaard & Hakvoort
                (default). ``False`` gives the paper's split form, to which the kink
                forces of eqs. 21-22 (:meth:`add_load`) must then be added by hand.
        """
        p = self._node("p", p)
        q = self._node("q", q)
        _checks.element_count("the element count", 1, self._n_elements())
        return self._add_pipes(np.array([p]), np.array([q]), section, up=up, tangent_p=tangent_p,
                               tangent_q=tangent_q, length=length, flow_factor=flow_factor,
                               fluid_end_terms=fluid_end_terms)[0]

    def _add_pipes(self, p: np.ndarray, q: np.ndarray, section: PipeSection, *,
                   up: Optional[Sequence[float]] = None, tangent_p: Optional[Sequence[float]] = None,
                   tangent_q: Optional[Sequence[float]] = None, length: Optional[float] = None,
                   flow_factor: float = 1.0, fluid_end_terms: bool = True) -> List[int]:
        """Pipe elements from nodes ``p`` to ``q`` (arrays of n node indices in range), all
        with the options of :meth:`add_pipe` (``tangent_p``, ``tangent_q`` may also be
        (n, 3) arrays, a tangent per element): every rule checked once for all of them
        (naming the first element that breaks it), their triads and lengths as arrays.
        Nothing is added unless all pass. Returns the element indices."""
        def where(k):
            return f" (element {p[k]}->{q[k]})"

        if (p == q).any():
            raise ValueError(f"a pipe element needs two different nodes, got p = q = {p[p == q][0]}")
        if self._ancf_nodes:
            ancf = [i for i in np.column_stack((p, q)).ravel().tolist() if i in self._ancf_nodes]
            if ancf:
                raise ValueError(f"node {ancf[0]} is an ANCF node; pipe elements need frame nodes (add_node)")
        section = require_section(section)
        x = self._positions
        chords = np.array([x[i] for i in q.tolist()]) - np.array([x[i] for i in p.tolist()])
        lc = _checks.row_norms(chords)
        if not (lc > 0.0).all():
            k = np.flatnonzero(~(lc > 0.0))[0]
            raise ValueError(f"element {p[k]}->{q[k]} has zero length: nodes {p[k]} and {q[k]} coincide")
        up_v = None if up is None else _checks.unit_vector("up", up)
        straight = tangent_p is None and tangent_q is None

        def tangents(name, t):  # one for all elements or, as an (n, 3) array, one each
            if isinstance(t, np.ndarray) and t.ndim == 2:
                return _checks.unit_vectors(name, t)
            return np.repeat(_checks.unit_vector(name, t)[None, :], len(p), axis=0)

        tp = chords if tangent_p is None else tangents("tangent_p", tangent_p)
        tq = chords if tangent_q is None else tangents("tangent_q", tangent_q)
        Ep = _triads(tp, up_v, where)
        Eq = Ep if straight else _triads(tq, up_v, where)  # straight: one triad
        if length is not None:
            l0 = np.full(len(p), _checks.positive("length", length))
        elif straight:
            l0 = lc  # a straight element: eps_1 of eq. 1 vanishes at the chord
        else:
            l0 = _strain_free_lengths(chords, lc, Ep, Eq, where)
        if (l0 < lc * (1 - 1e-12)).any():
            k = np.flatnonzero(l0 < lc * (1 - 1e-12))[0]
            raise ValueError(f"length l0 = {l0[k]} must not be shorter than the chord {lc[k]}{where(k)}")
        ff = _checks.finite("flow_factor", flow_factor)
        end_terms = bool(fluid_end_terms)
        first = len(self._elements)
        self._elements.extend([{"p": a, "q": b, "section": section, "l0": l, "Ep": E, "Eq": F, "flow_factor": ff,
                                "fluid_end_terms": end_terms}
                               for a, b, l, E, F in zip(p.tolist(), q.tolist(), l0.tolist(), Ep, Eq)])
        return list(range(first, len(self._elements)))

    def add_line(self, start: int, end: Sequence[float], n_elements: int, section: PipeSection,
                 **options) -> List[int]:
        """A straight pipe from node ``start`` to the point ``end`` [m] in ``n_elements``
        equal elements; returns the node indices along it (``start`` first). ``options``
        are those of :meth:`add_pipe`, for every element."""
        start = self._node("start", start)
        n = _checks.element_count("n_elements", n_elements, self._n_elements())
        x0, x1 = self._positions[start], _checks.vector3("end", end)
        return self._add_chain(start, x0 + (x1 - x0) * np.arange(1, n + 1)[:, None] / n, section, **options)

    def _add_chain(self, start: int, X: np.ndarray, section: PipeSection, **options) -> List[int]:
        """New nodes at the rows of ``X`` (n, 3) [m] and pipe elements from ``start`` through
        them in order (:meth:`_add_pipes`); all or nothing. Returns the node indices
        (``start`` first)."""
        first = len(self._positions)
        bad = np.flatnonzero(~np.all(np.isfinite(X), axis=1))
        if bad.size:
            raise ValueError(f"position must be finite, got {X[bad[0]]} (new node {first + bad[0]})")
        nodes = [start] + list(range(first, first + len(X)))
        self._positions.extend(X)
        try:
            self._add_pipes(np.array(nodes[:-1]), np.array(nodes[1:]), section, **options)
        except BaseException:
            del self._positions[first:]
            raise
        return nodes

    def add_arc(self, start: int, *, center: Sequence[float], angle: float, normal: Sequence[float],
                n_elements: int, section: PipeSection, **options) -> List[int]:
        """A circular arc of curved elements from node ``start`` about ``center`` [m],
        turning by ``angle`` [rad] about the unit ``normal`` (right-hand rule). The local z
        axes are set along the normal; ``|angle| <= 2 pi`` (one turn at most). Returns the node
        indices (``start`` first)."""
        start = self._node("start", start)
        n = _checks.element_count("n_elements", n_elements, self._n_elements())
        c = _checks.vector3("center", center)
        k = _checks.unit_vector("normal", normal)
        angle = _checks.finite("angle", angle)
        if not abs(angle) <= 2 * np.pi:  # a planar arc of more than a full turn would overlap itself
            raise ValueError(f"angle must be in [-2 pi, 2 pi] rad (at most a full circle), got {angle:g} rad")
        r0 = self._positions[start] - c
        if abs(np.dot(r0, k)) > 1e-9 * max(1.0, np.linalg.norm(r0)):
            raise ValueError("the start node must lie in the plane through center normal to `normal`")
        R = float(np.linalg.norm(r0))
        if R <= 0 or angle == 0:
            raise ValueError("arc radius and angle must be non-zero")
        dth = angle / n
        if abs(dth) > np.pi * (1 + 1e-12):  # found by the fuzz run: a 2 pi element has a chord of 1e-16 m
            raise ValueError(f"angle / n_elements must be at most pi rad (half a circle per curved element; beyond, "
                             f"its ends close up), got angle = {angle:g} rad in n_elements = {n}: use at least "
                             f"{int(np.ceil(abs(angle) / np.pi - 1e-12))} elements")

        K = skew(k)

        def rot(th):  # about the unit normal k by th: Rodrigues' formula
            return np.eye(3) + np.sin(th) * K + (1 - np.cos(th)) * K @ K

        r = np.array([rot(dth * i) @ r0 for i in range(n + 1)])  # from the centre to node i of the arc
        t = np.sign(angle) * np.cross(k, r)  # the tangents at the nodes
        return self._add_chain(start, c + r[1:], section, up=k, tangent_p=t[:-1], tangent_q=t[1:], **options)

    def _n_elements(self) -> int:
        return len(self._elements) + len(self._ancf)

    # -- spring-dampers -------------------------------------------------------------
    def add_spring(self, node_a: int, node_b: int, *, stiffness: float, damping: float = 0.0) -> int:
        """A linear axial spring-damper between the positions of two nodes (frame or ANCF),
        massless, unstressed at their reference distance L0: axial force
        T = k (l - L0) + c dl/dt along the line between them (tension positive), with l the
        nodes' distance and dl/dt = e . (v_b - v_a) its rate (e the unit vector from a to b).
        It holds no rotation. Returns its index among the springs (both kinds).

        Args:
            node_a, node_b: the two nodes [-]; they must not coincide in the reference
                configuration (a spring of zero length has no axis: ValueError; to hold a
                node at a point use :meth:`add_ground_spring`).
            stiffness: k [N/m] >= 0.
            damping: c [N s/m] >= 0, a dashpot in parallel.
        """
        a = self._node("node_a", node_a)
        b = self._node("node_b", node_b)
        k = _checks.non_negative("stiffness", stiffness)
        c = _checks.non_negative("damping", damping)
        if a == b:
            raise ValueError(f"node_a and node_b are both node {a}: a spring needs two nodes "
                             f"(to hold a node at a point use add_ground_spring)")
        if not np.linalg.norm(self._positions[b] - self._positions[a]) > 0.0:
            raise ValueError(f"nodes {a} and {b} coincide: an axial spring of zero length has no axis (its force "
                             f"direction is undefined); use add_ground_spring at one of them, or move them apart")
        self._springs.append(dict(kind="axial", nodes=(a, b), k=k, c=c))
        return len(self._springs) - 1

    def add_ground_spring(self, node: int, *, stiffness: Sequence[float] = (0.0, 0.0, 0.0),
                          damping: Sequence[float] = (0.0, 0.0, 0.0),
                          anchor: Optional[Sequence[float]] = None,
                          rotational_stiffness: Sequence[float] = (0.0, 0.0, 0.0),
                          rotational_damping: Sequence[float] = (0.0, 0.0, 0.0)) -> int:
        """A linear spring-damper from a node (frame or ANCF node) to the ground, massless:
        force -K (x - X) - C v on the node with K = diag(kx, ky, kz) and C = diag(cx, cy, cz)
        along the global axes. At a frame node it may also hold the rotation: moment
        -T(psi)^-T K_phi psi - C_phi w, with psi the rotation vector of the node's rotation
        from its reference orientation (exact for any ``|psi| < pi``: the elastic energy is
        psi^T K_phi psi / 2; a rotation of pi raises an error), w its angular velocity and
        K_phi, C_phi diagonal about the global axes. Counts as a support of its part of the
        structure. Returns its index among the springs.

        Args:
            node: the node [-].
            stiffness: (kx, ky, kz) [N/m] >= 0 each.
            damping: (cx, cy, cz) [N s/m] >= 0 each.
            anchor: X [m], the point where the spring is unstressed; default the node's
                reference position.
            rotational_stiffness: k_phi (3) [N m/rad] >= 0 each, about the global axes
                (frame nodes only).
            rotational_damping: c_phi (3) [N m s/rad] >= 0 each, about the global axes
                (frame nodes only).
        """
        node = self._node("node", node)
        k, c, kr, cr = (self._non_negative3(name, v, unit) for name, v, unit in
                        (("stiffness", stiffness, "N/m"), ("damping", damping, "N s/m"),
                         ("rotational_stiffness", rotational_stiffness, "N m/rad"),
                         ("rotational_damping", rotational_damping, "N m s/rad")))
        x = None if anchor is None else _checks.vector3("anchor", anchor)
        if not (k.any() or c.any() or kr.any() or cr.any()):
            raise ValueError("a ground spring needs a stiffness or a damping > 0 in some direction, "
                             "got all zero")
        if (kr.any() or cr.any()) and node in self._ancf_nodes:
            raise ValueError(f"node {node} is an ANCF node: it has no rotation, so rotational_stiffness and "
                             f"rotational_damping must be 0 there")
        self._springs.append(dict(kind="ground", nodes=(node,), k=k, c=c, anchor=x, k_phi=kr, c_phi=cr))
        return len(self._springs) - 1

    def add_bushing(self, node_a: int, node_b: int, *, stiffness: Sequence[float] = (0.0, 0.0, 0.0),
                    damping: Sequence[float] = (0.0, 0.0, 0.0),
                    rotational_stiffness: Sequence[float] = (0.0, 0.0, 0.0),
                    rotational_damping: Sequence[float] = (0.0, 0.0, 0.0)) -> int:
        """A linear 6-DOF spring-damper (bushing) between two nodes, massless: a flexible
        coupling, a rubber-lined clamp, an elastic hinge between two lines at a shared
        position. The nodes may coincide. Force on node b
        -K (x_b - x_a - d0) - C (v_b - v_a), its opposite on node a, with d0 the nodes'
        reference offset X_b - X_a and K = diag(kx, ky, kz), C = diag(cx, cy, cz) along the
        GLOBAL axes (they do not turn with the nodes; no moment from the offset). Between two
        frame nodes it may also hold their relative rotation: moment on node b
        -T(psi)^-T K_phi psi - C_phi (w_b - w_a), its opposite on node a, with psi the
        rotation vector of R_b R_a^T (R the nodes' rotations from their reference
        orientations; psi = 0 under any equal rotation of both), exact for ``|psi| < pi``
        (elastic energy psi^T K_phi psi / 2; a relative rotation of pi raises an error),
        w the angular velocities and K_phi, C_phi diagonal about the global axes. Returns
        its index among the springs (all kinds).

        Args:
            node_a, node_b: the two nodes [-] (two different nodes; they may coincide in
                space).
            stiffness: (kx, ky, kz) [N/m] >= 0 each.
            damping: (cx, cy, cz) [N s/m] >= 0 each.
            rotational_stiffness: k_phi (3) [N m/rad] >= 0 each, about the global axes
                (frame nodes only).
            rotational_damping: c_phi (3) [N m s/rad] >= 0 each, about the global axes
                (frame nodes only).
        """
        a = self._node("node_a", node_a)
        b = self._node("node_b", node_b)
        k, c, kr, cr = (self._non_negative3(name, v, unit) for name, v, unit in
                        (("stiffness", stiffness, "N/m"), ("damping", damping, "N s/m"),
                         ("rotational_stiffness", rotational_stiffness, "N m/rad"),
                         ("rotational_damping", rotational_damping, "N m s/rad")))
        if a == b:
            raise ValueError(f"node_a and node_b are both node {a}: a bushing joins two nodes "
                             f"(to hold a node to the ground use add_ground_spring)")
        if not (k.any() or c.any() or kr.any() or cr.any()):
            raise ValueError("a bushing needs a stiffness or a damping > 0 in some direction, got all zero")
        if kr.any() or cr.any():
            for n in (a, b):
                if n in self._ancf_nodes:
                    raise ValueError(f"node {n} is an ANCF node: it has no rotation, so rotational_stiffness and "
                                     f"rotational_damping must be 0 for a bushing there")
        self._springs.append(dict(kind="bushing", nodes=(a, b), k=k, c=c, k_phi=kr, c_phi=cr))
        return len(self._springs) - 1

    @staticmethod
    def _non_negative3(name: str, value, unit: str) -> np.ndarray:
        """Three finite numbers >= 0 (kx, ky, kz or cx, cy, cz), else ValueError naming them."""
        try:
            shape = np.shape(value) if not isinstance(value, (str, bytes)) else ()
        except ValueError:  # ragged
            shape = ()
        if shape != (3,):
            raise ValueError(f"{name} must be 3 numbers along the global x, y, z [{unit}], got {value!r}")
        return np.array([_checks.non_negative(f"{name}[{i}]", v) for i, v in enumerate(value)])

    # -- supports -------------------------------------------------------------------
    def _constrain(self, node: int, rows: Iterable[np.ndarray]) -> None:
        self._constraints.setdefault(node, []).extend(np.asarray(r, float) for r in rows)

    def fix(self, node: int, components: Iterable[str]) -> None:
        """Fix coordinates of a node by name: any of ``ux uy uz rx ry rz`` (frame node) or
        ``ux uy uz dx dy dz`` (ANCF node: position and slope components); one name or a
        sequence of names."""
        node = self._node("node", node)
        names = ANCF_COMPONENTS if node in self._ancf_nodes else COMPONENTS
        if isinstance(components, str):  # fix(n, "ux"): one name, not its letters
            components = (components,)
        comps = list(components)
        for c in comps:
            if c not in names:
                raise ValueError(f"unknown component {c!r} for node {node}; use one of {names}")
        self._constrain(node, [np.eye(6)[names.index(c)] for c in comps])

    def clamp(self, node: int) -> None:
        """Fix position and orientation of a node. At an ANCF node the slope's direction
        is fixed but not its length: the axial strain at the clamp stays free (Berzeri & Shabana,
        eq. 18: five free coordinates for one clamped element)."""
        node = self._node("node", node)
        if node not in self._ancf_nodes:
            self.fix(node, COMPONENTS)
            return
        d = self._ancf_nodes[node]
        self.fix(node, ("ux", "uy", "uz", "dz"))
        self._constrain(node, [np.array([0, 0, 0, -d[1], d[0], 0.0])])

    def pin(self, node: int) -> None:
        """Fix the position of a node; its rotation stays free."""
        self.fix(node, ("ux", "uy", "uz"))

    def hinge(self, node: int, axis: Sequence[float]) -> None:
        """Fix the position; allow rotation only about the fixed global ``axis``."""
        node = self._node("node", node)
        a = _checks.unit_vector("axis", axis)
        self.pin(node)
        perp = np.linalg.svd(a.reshape(1, 3))[2][1:]
        self._constrain(node, [np.concatenate([np.zeros(3), r]) for r in perp])

    def axial_support(self, node: int, direction: Sequence[float]) -> None:
        """Prevent the node from moving along the global ``direction``."""
        node = self._node("node", node)
        d = _checks.unit_vector("direction", direction)
        self._constrain(node, [np.concatenate([d, np.zeros(3)])])

    def fix_rotation(self, node: int, axis: Sequence[float]) -> None:
        """Prevent rotation of the node about the global ``axis``."""
        node = self._node("node", node)
        a = _checks.unit_vector("axis", axis)
        self._constrain(node, [np.concatenate([np.zeros(3), a])])

    # -- loads and masses -------------------------------------------------------------
    def add_load(self, node: int, *, force: Sequence[float] = (0.0, 0.0, 0.0),
                 moment: Sequence[float] = (0.0, 0.0, 0.0), follower: bool = False,
                 time_function=None) -> None:
        """Nodal force [N] and moment [N m]; dead (global axes) or, with ``follower=True``,
        given in the node's frame and turning with it (the frame is the global one in the
        reference configuration).

        Args:
            node: the node [-].
            force: F (3) [N].
            moment: M (3) [N m].
            follower: whether F and M are given in the node's frame and turn with it.
            time_function: s(t) [-] of this load alone, evaluated in the compiled core
                (no Python call): a number, a table (times [s], values), a :class:`Sine`
                or a :class:`Pulse` (an impulse ``F * pulse.integral`` [N s]). The load
                is ``s(t) lambda(t) (F, M)`` with lambda the analysis' load factor
                (``simulate(load_factor=)``, default 1); statics take s(0). None: s = 1.
        """
        node = self._node("node", node)
        f = _checks.vector3("force", force)
        m = _checks.vector3("moment", moment)
        if time_function is not None:
            as_time_table("time_function", time_function)  # checked now, converted by build (pickles)
        z = np.zeros(3)
        self._loads.append(dict(node=node, f=z if follower else f, m=z if follower else m,
                                ff=f if follower else z, fm=m if follower else z, tf=_frozen(time_function)))

    def add_distributed_load(self, elements: Optional[Sequence[int]] = None, *,
                             line: Optional[Sequence[int]] = None, force_per_length: Sequence[float],
                             time_function=None) -> None:
        """A distributed dead load q [N/m] in global axes on pipe or ANCF elements, per unit
        of their reference length: consistent (Hermite-weighted) like gravity, which
        carries it (the elements' gravity term with g raised by q / mu, mu their mass per
        length), so it is exact for large displacements and in every tangent. Its total
        on an element is q l0; a cantilever under it bends like under its weight with
        q = mu g. It counts in the transients' load work, like the nodal loads.

        Args:
            elements: pipe elements, as :meth:`add_pipe` and :meth:`add_pipes` number them.
            line: or the nodes of a chain (:meth:`add_line`, :meth:`add_arc`,
                :meth:`add_ancf_beam` return them): the pipe or ANCF element between each
                two consecutive nodes. Give one of ``elements`` and ``line``.
            force_per_length: q (3) [N/m].
            time_function: s(t) [-] of this load alone (as :meth:`add_load`'s: a number, a
                table (times [s], values), a :class:`Sine`); the load is
                ``s(t) lambda(t) q``, lambda the analysis' load factor; statics take s(0).
                None: s = 1.

        Model files hold it under ``distributed_loads`` (docs/model_files.md).
        """
        q = _checks.vector3("force_per_length", force_per_length)
        if (elements is None) == (line is None):
            raise ValueError("give one of elements (pipe element indices) and line (the nodes of a chain)")
        targets = []
        if elements is not None:
            if isinstance(elements, (int, np.integer)) and not isinstance(elements, bool):
                elements = [elements]
            for e in elements:
                if isinstance(e, bool) or not isinstance(e, (int, np.integer)) or not 0 <= e < len(self._elements):
                    raise ValueError(f"elements refers to pipe element {e!r}, but the model has pipe elements "
                                     f"0..{len(self._elements) - 1}")
                targets.append(("pipe", int(e)))
        else:
            nodes = [self._node("line", n) for n in line]
            if len(nodes) < 2:
                raise ValueError(f"line must hold at least 2 nodes (a chain of elements), got {len(nodes)}")
            ends = {}
            for kind, els in (("pipe", self._elements), ("ancf", self._ancf)):
                for k, e in enumerate(els):
                    ends.setdefault(frozenset((e["p"], e["q"])), (kind, k))
            for a, b in zip(nodes[:-1], nodes[1:]):
                if frozenset((a, b)) not in ends:
                    raise ValueError(f"line: no pipe or ANCF element joins nodes {a} and {b}")
                targets.append(ends[frozenset((a, b))])
        if time_function is not None:
            as_time_table("time_function", time_function)  # checked now, converted by build (pickles)
        self._distributed.append(dict(targets=targets, q=q, tf=_frozen(time_function)))

    def add_load_function(self, node: int, fn, *, name: Optional[str] = None) -> None:
        """A nodal load computed by a Python function of time and the node's motion.

        ``fn(t, position, velocity) -> (force, moment)``: t [s], the node's position (3)
        [m] and velocity (3) [m/s] (ANCF node: of its position r), returning force (3) [N]
        and moment (3) [N m] in global axes (an ANCF node takes no moment). The load is
        scaled by the analysis' load factor (default 1); static analyses call fn at
        t = 0. Exceptions raised by fn stop the analysis with a RuntimeError naming the
        load, the time and fn's message; a return that is not two finite 3-vectors is a
        ValueError naming the load.

        Its tangent stiffness and damping are central differences of fn in position and
        velocity (12 more calls per Jacobian; exact up to rounding for linear springs and
        dashpots), so Newton converges as for the built-in loads.

        Cost: one Python call per residual evaluation, taking the GIL (parallel runs of
        such models wait for each other in fn). A 10-element cantilever over 1 s called
        a trivial fn about 30,000 times with IDA (0.24 s -> 0.28 s) and 3,200 times with
        the generalised-alpha method (12 ms -> 16 ms): about 1.3 us per call plus fn's
        own time. Prefer :meth:`add_load` with ``time_function=`` when the load does not
        depend on the motion. A model with a load function cannot be saved to a model
        file, nor pickled unless fn can be.

        Args:
            node: the node [-].
            fn: the callable.
            name: its name in error messages (default fn's ``__name__``).
        """
        node = self._node("node", node)
        if not callable(fn):
            raise TypeError(f"fn must be callable fn(t, position, velocity) -> (force, moment), got {fn!r}")
        label = f"load function {name or getattr(fn, '__name__', type(fn).__name__)!s} at node {node}"
        z = np.zeros(3)
        self._loads.append(dict(node=node, f=z, m=z, ff=z, fm=z, tf=None, fn=fn, label=label))

    def add_point_mass(self, node: int, mass: float, inertia: Sequence[float] = (0.0, 0.0, 0.0)) -> None:
        """Concentrated mass [kg] and principal rotary inertia [kg m^2] (node frame).

        Args:
            node: the node [-].
            mass: m [kg] >= 0.
            inertia: (I_x, I_y, I_z) [kg m^2] >= 0, the principal moments of inertia about
                the node frame's axes (three numbers, not a 3 x 3 tensor).
        """
        node = self._node("node", node)
        mass = _checks.non_negative("mass", mass)
        try:
            shape = np.shape(inertia) if not isinstance(inertia, (str, bytes)) else ()
        except ValueError:  # ragged
            shape = ()
        if shape != (3,):  # else the core's binding refuses it as 'incompatible function arguments'
            raise ValueError(f"inertia must be 3 principal moments (I_x, I_y, I_z) [kg m^2] about the node frame's "
                             f"axes, got {inertia!r}" + (" (a 3 x 3 tensor: pass its diagonal in the principal axes)"
                                                         if shape == (3, 3) else ""))
        self._masses.append(dict(node=node, mass=mass,
                                 inertia=np.array([_checks.non_negative(f"inertia[{i}]", x)
                                                   for i, x in enumerate(inertia)])))

    def reservoir_inlet(self, node: int) -> None:
        """Mark ``node`` as an inlet fed from a still reservoir (Meijaard & Hakvoort, end of sec. 2.2).

        The fluid there is accelerated by suction from rest, not by the pipe: the inlet
        end term of the element that starts at ``node`` (in the flow direction) is
        cancelled by the additional force of eq. 22 with opposite sign.
        """
        node = self._node("node", node)
        found = False
        for e in self._elements:
            inlet = e["p"] if e["flow_factor"] >= 0 else e["q"]
            if inlet == node:
                e.setdefault("reservoir", set()).add(node)
                found = True
        if not found:
            raise ValueError(f"node {node} is not the inlet of any flow-carrying element")

    def rayleigh_damping(self, *, alpha: float = 0.0, beta: float = 0.0) -> None:
        """Rayleigh damping ``alpha M + beta K`` of every element (pipe and ANCF), added to
        the damping of their sections; a later call replaces the earlier one.

        Args:
            alpha: alpha [1/s] mass-proportional part. ``M`` is the centre line's consistent
                mass (pipe and fluid, Hermite-interpolated as the inertia): each element gets
                the external viscous damping ``c_ext = alpha (pipe_mass + fluid_mass)``. The
                sections' rotary inertia, point masses and springs are not damped; a
                rigid-body motion is (as by any mass-proportional damping).
            beta: beta [s] stiffness-proportional part. ``K`` is each element's own elastic
                stiffness at its stress-free reference: the Kelvin-Voigt times
                ``eta_bending = eta_torsion = eta_axial = beta`` (in motion the damping
                follows the current configuration's material stiffness, which leaves rigid
                motions undamped; no geometric stiffness, no flow terms).

        A mode of angular frequency omega [rad/s] of an undamped model then has the damping
        ratio ``alpha / (2 omega) + beta omega / 2`` (exactly at the stress-free reference
        without point masses or rotary inertia).
        """
        self._rayleigh = (_checks.non_negative("alpha", alpha), _checks.non_negative("beta", beta))

    def set_gravity(self, g: Sequence[float]) -> None:
        """Gravitational acceleration vector g [m/s^2], e.g. ``(0, 0, -9.81)``."""
        self._gravity = _checks.gravity("gravity", g)

    # -- build -------------------------------------------------------------------------
    def build(self, *, mass_flow: float = 0.0, floating: bool = False) -> "Model":
        """Check the description and return an immutable :class:`Model`.

        Args:
            mass_flow: mdot [kg/s] prescribed mass flow (analyses may override it).
            floating: allow a model without supports, to be held by the couplings of a
                :class:`~pipeflex.CoupledSystem` (alone it would drift: the element
                analyses refuse its rigid-body motion as a mechanism).
        """
        mdot = _checks.finite("mass_flow", mass_flow)
        if not self._elements and not self._ancf and not self._springs:
            raise ValueError("the model has no elements")
        grounded = {s["nodes"][0] for s in self._springs if s["kind"] == "ground"}  # tied to the ground
        if not self._constraints and not grounded and not floating:
            raise ValueError("the model has no supports: add clamp/pin/hinge/fix or a ground spring so it cannot "
                             "drift (or build it with floating=True to join it to bodies in a "
                             "pipeflex.CoupledSystem)")
        for n in self._ancf_nodes:  # planar: z and z' fixed
            rows = self._constraints.get(n, [])
            for k in (2, 5):
                if not any(np.allclose(r, np.eye(6)[k]) for r in rows):
                    self._constrain(n, [np.eye(6)[k]])
        for m in self._masses:
            if m["node"] in self._ancf_nodes and np.any(m["inertia"] != 0):
                raise ValueError(f"point mass at ANCF node {m['node']}: rotary inertia must be 0")
        for ld in self._loads:
            if ld["node"] in self._ancf_nodes and (np.any(ld["m"] != 0) or np.any(ld["ff"] != 0) or np.any(ld["fm"] != 0)):
                raise ValueError(f"load at ANCF node {ld['node']}: only dead forces are supported (no moments, "
                                 f"no follower loads)")
        els = self._elements + self._ancf
        used = {e["p"] for e in els} | {e["q"] for e in els} | {n for s in self._springs for n in s["nodes"]}
        loose = sorted(set(range(len(self._positions))) - used)
        if loose:
            raise ValueError(f"nodes {loose} are not connected to any element or spring")
        if not floating:
            self._check_parts_supported(els)
        for e in self._elements:
            if mdot != 0.0 and e["flow_factor"] != 0.0 and e["section"].fluid_mass <= 0.0:
                raise ValueError(f"element {e['p']}->{e['q']} carries a mass flow but its fluid_mass is 0")
        known = {}  # nodes with the same constraint rows share one basis (e.g. all planar ANCF nodes)
        bases = [self._basis(i, known) for i in range(len(self._positions))]
        positions = np.array(self._positions)
        pipes = self._pipe_arrays()  # both cores copy them
        core = self._make_core(positions, bases, self._hub, pipes)
        # the same model without supports (planar ANCF nodes keep z, z' fixed), for
        # analyses that need the unconstrained matrices (rotating frame)
        planar = np.eye(6)[:, [0, 1, 3, 4]]
        free_bases = [planar if i in self._ancf_nodes else _IDENTITY for i in range(len(self._positions))]
        free_core = self._make_core(positions, free_bases, None, pipes)
        infos = [ElementInfo((e["p"], e["q"]), e["section"], e["l0"], e["flow_factor"]) for e in self._elements]
        infos += [ElementInfo((e["p"], e["q"]), e["section"], e["l"], 0.0, kind="ancf", elastic=e["elastic"])
                  for e in self._ancf]
        def numbers(x):  # hashable, comparable
            return None if x is None else float(x) if np.isscalar(x) else tuple(map(float, x))

        springs = tuple(SpringInfo(s["kind"], s["nodes"], numbers(s["k"]), numbers(s["c"]), numbers(s.get("anchor")),
                                   numbers(s.get("k_phi")), numbers(s.get("c_phi")))
                        for s in self._springs)
        model = Model(core, positions, tuple(infos), bases, mdot, self._gravity.copy(),
                      hub=self._hub, ancf_nodes=tuple(sorted(self._ancf_nodes)),
                      free=(free_core, free_bases), springs=springs,
                      description=_snapshot({**vars(self), "_floating": bool(floating)}))
        return model

    def _check_parts_supported(self, els) -> None:
        """Every connected part of the structure needs a support, as the whole model does:
        an unsupported part drifts (a mechanism whose round-off eigenvalues would decide
        a stability answer)."""
        pairs = [(e["p"], e["q"]) for e in els] + [s["nodes"] for s in self._springs if len(s["nodes"]) == 2]
        count, part = _parts(len(self._positions), np.array([p for p, _ in pairs], dtype=np.int64),
                             np.array([q for _, q in pairs], dtype=np.int64))
        supported = {part[i] for i in self._constraints}
        supported |= {part[s["nodes"][0]] for s in self._springs if s["kind"] == "ground"}
        for k in range(count):
            if k not in supported:
                nodes = np.flatnonzero(part == k)
                raise ValueError(f"nodes {nodes[0]}..{nodes[-1]} ({len(nodes)} nodes) form a part with no supports, "
                                 f"not connected to a supported node: add clamp/pin/hinge/fix on it so it cannot "
                                 f"drift")

    def _make_core(self, positions, bases, hub, pipes):
        core = _core.Model()
        start = 0  # frame nodes in runs between the ANCF nodes
        for i in sorted(self._ancf_nodes):
            core.add_nodes(positions[start:i])
            core.add_ancf_node(positions[i], self._ancf_nodes[i])
            start = i + 1
        core.add_nodes(positions[start:])
        core.add_pipes(**pipes)
        for e in self._ancf:
            d = _core.AncfElementData()
            sec = e["section"]
            d.l, d.EA, d.EI, d.mass, d.elastic = e["l"], sec.EA, sec.EIz, sec.pipe_mass, e["elastic"]
            alpha, beta = getattr(self, "_rayleigh", (0.0, 0.0))
            d.eta_axial, d.eta_bending = sec.eta_axial + beta, sec.eta_bending + beta
            d.c_ext = sec.c_ext + alpha * sec.pipe_mass
            d.k_found = sec.k_found
            core.add_ancf(e["p"], e["q"], d)
        if hub is not None:
            core.set_hub(list(hub.nodes), hub.axis, hub.center, hub.omega, hub.spin_up_time)
        for ld in self._loads:
            if ld.get("fn") is not None:
                core.add_load_function(ld["node"], ld["fn"], ld["label"])
            else:
                tf = ld.get("tf")
                core.add_load(ld["node"], ld["f"], ld["m"], ld["ff"], ld["fm"],
                              None if tf is None else as_time_table("time_function", tf))
        for s in self._springs:  # in the core's registry after the pipe and ANCF elements
            if s["kind"] == "axial":
                core.add_spring(*s["nodes"], s["k"], s["c"])
            elif s["kind"] == "bushing":
                core.add_bushing(*s["nodes"], s["k"], s["c"], s["k_phi"], s["c_phi"])
            else:
                core.add_ground_spring(s["nodes"][0], s["k"], s["c"], s.get("anchor"), s["k_phi"], s["c_phi"])
        for m in self._masses:
            core.add_mass(m["node"], m["mass"], m["inertia"])
        for d in getattr(self, "_distributed", ()):  # registry: the pipe elements, then the ANCF ones
            tf = None if d["tf"] is None else as_time_table("time_function", d["tf"])
            for kind, k in d["targets"]:
                core.add_distributed_load(k if kind == "pipe" else len(self._elements) + k, d["q"], tf)
        core.set_shared_bases(*_distinct(bases))
        core.finalize()
        return core

    def _basis(self, node: int, known: dict) -> np.ndarray:
        rows = self._constraints.get(node, [])
        if not rows:
            return _IDENTITY
        key = tuple(tuple(float(c) for c in r) for r in rows)
        if key not in known:
            known[key] = self._constrained_basis(np.array(rows))
        return known[key]

    @staticmethod
    def _constrained_basis(C: np.ndarray) -> np.ndarray:
        """An orthonormal basis (6 x k) of the increments allowed by the rows of C."""
        unit = np.all(np.isclose(np.abs(C), 0) | np.isclose(np.abs(C), 1), axis=1) & (np.count_nonzero(C, axis=1) == 1)
        if np.all(unit):  # plain fixed components: keep the coordinate axes as the basis
            fixed = set(np.argmax(np.abs(C), axis=1))
            return np.eye(6)[:, [i for i in range(6) if i not in fixed]]
        _, s, vt = np.linalg.svd(C)
        rank = int(np.sum(s > 1e-10 * s[0]))
        T = vt[rank:].T
        T[np.abs(T) < 1e-15] = 0.0
        return T

    def _pipe_arrays(self) -> dict:
        """The pipe elements' data (_core.PipeElementData) field by field, a row per
        element: the arguments of _core.Model.add_pipes."""
        els = self._elements
        sections, k = _distinct([e["section"] for e in els])  # a line's elements share one section
        table = np.array([[s.EA, s.GJ, s.EI, s.EIz, s.pipe_mass, s.fluid_mass, s.kv, *s.rotary_inertia]
                          for s in sections], dtype=float).reshape(-1, 10)[k]
        EA, GJ, EI, EIz = table[:, :4].T
        l0 = np.array([e["l0"] for e in els], dtype=float)
        # eq. 7: Phi_z = 12 E I_y / (G A k_z l0^2), Phi_y = 12 E I_z / (G A k_y l0^2); 0: rigid in shear
        shear = np.array([[s.GAz is not None, s.GAy is not None] for s in sections], dtype=bool).reshape(-1, 2)[k]
        GA = np.array([[1.0 if s.GAz is None else s.GAz, 1.0 if s.GAy is None else s.GAy] for s in sections],
                      dtype=float).reshape(-1, 2)[k]
        l0sq = _squares(l0) if shear.any() else l0
        Phi_z = np.where(shear[:, 0], 12.0 * EI / (GA[:, 0] * l0sq), 0.0)
        Phi_y = np.where(shear[:, 1], 12.0 * EIz / (GA[:, 1] * l0sq), 0.0)
        ends = [e["fluid_end_terms"] for e in els]
        reservoir = [e.get("reservoir", ()) for e in els]
        optional = {}  # damping and foundation arrays, only where a section has them
        alpha, beta = getattr(self, "_rayleigh", (0.0, 0.0))
        if alpha != 0.0 or beta != 0.0 or any(s.damped for s in sections):  # else none: the kernels skip it
            optional = dict(eta=np.array([[s.eta_axial + beta, s.eta_torsion + beta, s.eta_bending + beta]
                                         for s in sections], dtype=float).reshape(-1, 3)[k],
                           c_ext=np.array([s.c_ext + alpha * (s.pipe_mass + s.fluid_mass) for s in sections],
                                          dtype=float)[k])
        if any(s.k_found != 0.0 for s in sections):  # else none: the kernels skip it
            optional["k_found"] = np.array([s.k_found for s in sections], dtype=float)[k]
        return dict(p=np.array([e["p"] for e in els], dtype=np.int32),
                    q=np.array([e["q"] for e in els], dtype=np.int32),
                    l0=l0, EA=EA, GJ=GJ, EIy=EI, EIz=EIz, Phi_y=Phi_y, Phi_z=Phi_z,
                    offset_p=np.array([e["Ep"] for e in els], dtype=float).reshape(-1, 3, 3),
                    offset_q=np.array([e["Eq"] for e in els], dtype=float).reshape(-1, 3, 3),
                    pipe_mass=table[:, 4], fluid_mass=table[:, 5], kv=table[:, 6], rotary_inertia=table[:, 7:10],
                    flow_factor=np.array([e["flow_factor"] for e in els], dtype=float),
                    end_terms_p=np.array([x and e["p"] not in r for x, e, r in zip(ends, els, reservoir)], dtype=bool),
                    end_terms_q=np.array([x and e["q"] not in r for x, e, r in zip(ends, els, reservoir)], dtype=bool),
                    **optional)


def _frozen(value):
    """A copy of a builder argument that the caller's later changes cannot reach
    (arrays copied, sequences as tuples); sections and numbers as they are."""
    if isinstance(value, np.ndarray):
        return value.copy()
    if isinstance(value, (list, tuple)):
        return tuple(_frozen(v) for v in value)
    return value


def _recorded(method):
    """``method`` of :class:`ModelBuilder` that appends its call to the builder's recipe
    when it succeeds; calls made by another recorded method (clamp by rotating_hub) are
    part of that one and not recorded."""
    @functools.wraps(method)
    def call(self, *args, **kwargs):
        outer = self._depth == 0
        self._depth += 1
        try:
            out = method(self, *args, **kwargs)
        finally:
            self._depth -= 1
        if outer:
            self._recipe.append((method.__name__, tuple(map(_frozen, args)),
                                 {k: _frozen(v) for k, v in kwargs.items()}))
        return out

    return call


# every public builder method but build, also those added later (one rule, no list to keep up)
for _name, _method in list(vars(ModelBuilder).items()):
    if not _name.startswith("_") and _name != "build" and callable(_method) and not isinstance(_method, staticmethod):
        setattr(ModelBuilder, _name, _recorded(_method))
del _name, _method


def _distinct(objects: list) -> Tuple[list, np.ndarray]:
    """The distinct objects (by identity) of a list, in the order of first use, and each
    entry's index among them: e.g. the nodal bases (the builder hands one array to all
    nodes with the same supports) or the elements' sections (one per line)."""
    ids = list(map(id, objects))
    index = {i: k for k, i in enumerate(dict.fromkeys(ids))}
    by_id = dict(zip(ids, objects))
    return [by_id[i] for i in index], np.fromiter(map(index.__getitem__, ids), dtype=np.int64, count=len(ids))


def _parts(n: int, p: np.ndarray, q: np.ndarray) -> Tuple[int, np.ndarray]:
    """The connected parts of an undirected graph of ``n`` nodes with edges p[k]-q[k]:
    their count and each node's part, numbered in the order of the parts' first nodes (as
    scipy's connected_components; building a model needs no scipy, whose sparse package
    imports in about 30 ms). Array by array: each round hooks every edge's larger root on
    its smaller one, then jumps pointers to the roots (a part's root is its first node);
    the rounds and jumps are logarithmic in the part's size."""
    root = np.arange(n)
    while True:
        a, b = root[p], root[q]
        if np.array_equal(a, b):
            break
        np.minimum.at(root, np.maximum(a, b), np.minimum(a, b))
        while True:
            up = root[root]
            if np.array_equal(up, root):
                break
            root = up
    first, part = np.unique(root, return_inverse=True)
    return len(first), part.astype(np.int64)


def _rebuild_model(description: dict, mass_flow: float, free: bool) -> "Model":
    """A model built again from :meth:`Model.__reduce__`'s description."""
    b = ModelBuilder()
    vars(b).update(copy.deepcopy(description))
    model = b.build(mass_flow=mass_flow, floating=description.get("_floating", False))
    return model.free_model() if free else model


class Model:
    """An immutable model: the compiled core model plus what Python needs to know.

    Pickling and :func:`copy.deepcopy` rebuild the model from a copy of the builder's
    description (the compiled core is not picklable); ``mass_flow`` and ``info`` are kept.

    Attributes:
        n_nodes, n_dofs: number of nodes and of free (reduced) coordinates.
        positions: (n_nodes, 3) reference node positions [m].
        elements: per-element :class:`ElementInfo` (pipe elements first, then ANCF).
        mass_flow: default prescribed mass flow mdot [kg/s].
        gravity: g [m/s^2].
        hub: the rotating hub (:class:`HubInfo`) or None.
        ancf_nodes: indices of the ANCF nodes.
        springs: per-spring :class:`SpringInfo` (axial, ground and bushing spring-dampers).
        info: free-form description a scene attaches (e.g. reference frequencies).
    """

    def __init__(self, core, positions, elements, bases, mass_flow, gravity, *, hub=None, ancf_nodes=(),
                 free=None, description=None, is_free=False, springs=()):
        self._description = description
        self.springs = springs
        self._is_free = is_free
        self._core = core
        self.positions = positions
        self.positions.flags.writeable = False
        self.elements = elements
        self.mass_flow = mass_flow
        self.gravity = gravity
        self.gravity.flags.writeable = False
        self.n_nodes = core.n_nodes
        self.n_dofs = core.n_dofs
        self.hub = hub
        self.ancf_nodes = ancf_nodes
        self.info: dict = {}
        self._free = free
        # (core State, System on it) pairs for _linearization: each keeps its tangent's CSC
        # pattern across calls (not pickled: __reduce__ rebuilds the model)
        self._linear_systems: list = []
        first_dof = np.asarray(core.first_dof, dtype=np.int64)  # one conversion: each access copies it
        ancf = np.zeros(len(bases), dtype=bool)
        ancf[list(ancf_nodes)] = True
        # each distinct basis (most nodes share the identity) read once: its entries column by
        # column (j, then i) and each column's one component (-1: combined), then placed for
        # all its nodes at once
        distinct, kind = _distinct(bases)
        rows, cols, vals, owner, width, names = [], [], [], [], [], {}
        for g, T in enumerate(distinct):
            nodes = np.flatnonzero(kind == g)
            j, i = np.nonzero(T.T)
            single = np.count_nonzero(T, axis=0) == 1
            component = [int(i[j == c][0]) if single[c] else -1 for c in range(T.shape[1])]
            for planar, comps in ((False, COMPONENTS), (True, ANCF_COMPONENTS)):
                names[g, planar] = [comps[k] if k >= 0 else "combined" for k in component]
            rows.append((6 * nodes[:, None] + i).ravel())
            cols.append((first_dof[nodes][:, None] + j).ravel())
            vals.append(np.broadcast_to(T[i, j], (len(nodes), len(i))).ravel())
            owner.append(np.repeat(nodes, len(i)))
            width.append(T.shape[1])
        order = np.argsort(np.concatenate(owner), kind="stable") if owner else np.zeros(0, np.int64)  # node by node
        # the triplets of `basis` (CSR on first use), kept as arrays: 24 bytes an entry
        self._basis_matrix = (np.concatenate(vals).astype(float)[order] if vals else np.zeros(0),
                              (np.concatenate(rows).astype(np.int64)[order] if rows else np.zeros(0, np.int64),
                               np.concatenate(cols).astype(np.int64)[order] if cols else np.zeros(0, np.int64)))
        node_of_dof = np.repeat(np.arange(len(bases)), np.array(width, dtype=np.int64)[kind]).tolist()
        labels = zip(node_of_dof, chain.from_iterable([names[g, a] for g, a in zip(kind.tolist(), ancf.tolist())]))
        #: (node, component) of each reduced coordinate
        self.dof_labels = tuple(labels)

    @property
    def basis(self):
        """Sparse (CSR, 6 n_nodes x n_dofs) map from reduced increments to nodal
        coordinates; made on first use (scipy.sparse is not imported to build a model)."""
        if isinstance(self._basis_matrix, tuple):
            import scipy.sparse as sp

            self._basis_matrix = sp.csr_matrix(self._basis_matrix, shape=(6 * self.n_nodes, self.n_dofs))
        return self._basis_matrix

    def free_model(self) -> "Model":
        """The same structure without supports or hub (ANCF nodes stay planar): its
        coordinates are all nodal coordinates; ``basis`` maps them to the full ones."""
        if self._free is None:
            raise ValueError("this model has no unconstrained variant")
        core, bases = self._free
        return Model(core, self.positions.copy(), self.elements, bases, self.mass_flow, self.gravity.copy(),
                     ancf_nodes=self.ancf_nodes, description=self._description, is_free=True,
                     springs=self.springs)

    def __reduce__(self):
        if self._description is None:
            raise TypeError("this Model was not built by ModelBuilder.build: it cannot be pickled")
        return _rebuild_model, (self._description, self.mass_flow, self._is_free), {"info": self.info}

    def save(self, path):
        """Write the model as a model file, YAML (``.yaml``, ``.yml``) or JSON (``.json``)
        by the suffix of ``path`` [-] (its folder must exist; schema in
        docs/model_files.md): the file :func:`pipeflex.save_model` writes. Returns the path.

        Raises:
            ValueError: what a file cannot hold (a load function, a free model, a model not
                built by :class:`ModelBuilder`), or builder calls made in an order the file's
                grouping cannot keep (checked by building the calls in the file's order).
        """
        from .model_writer import save_elements

        return save_elements(self, path, ModelBuilder)

    def _summary(self) -> list:
        """(label, text) rows of the model's summary: counts, flow, mass, supports, loads."""
        kinds: dict = {}
        for e in self.elements:
            kinds[e.kind] = kinds.get(e.kind, 0) + 1
        d = self._description or {}
        rows = [("nodes", self.n_nodes), ("elements", ", ".join(f"{n} {k}" for k, n in kinds.items()) or "none"),
                ("dofs", self.n_dofs), ("fixed_coordinates", 6 * self.n_nodes - self.n_dofs)]
        if self._is_free:
            rows.append(("supports", "none (free_model)"))
        elif "_constraints" in d:
            held = sorted(d["_constraints"])  # supports, and the planar constraints of ANCF nodes
            rows.append(("constrained_nodes", f"[{', '.join(map(str, held))}]" if len(held) <= 8
                         else f"{len(held)} nodes"))
        rows += [("mass_flow", f"{self.mass_flow:.6g} kg/s"), ("total_mass", f"{self.total_mass:.6g} kg"),
                 ("total_length", f"{self.total_length:.6g} m")]
        if np.any(self.gravity):
            rows.append(("gravity", f"({', '.join(f'{g:.6g}' for g in self.gravity)}) m/s^2"))
        for key, label in (("_loads", "nodal_loads"), ("_masses", "point_masses")):
            if d.get(key):
                rows.append((label, len(d[key])))
        if self.ancf_nodes:
            rows.append(("ancf_nodes", len(self.ancf_nodes)))
        if self.springs:
            rows.append(("springs", ", ".join(f"{sum(s.kind == k for s in self.springs)} {k}"
                                              for k in ("axial", "ground", "bushing") if any(s.kind == k for s in self.springs))))
        if self.hub is not None:
            rows.append(("hub", f"(omega {self.hub.omega:.6g} rad/s, nodes {list(self.hub.nodes)})"))
        if self.info:
            rows.append(("info", f"[{', '.join(map(str, self.info))}]"))
        return rows

    def __repr__(self) -> str:
        return f"Model({', '.join(f'{k}={v}' for k, v in self._summary())})"

    def _repr_html_(self) -> str:
        from .results import _html_table

        return _html_table("Model", self._summary())

    @property
    def core(self):
        """The compiled model (read-only use)."""
        return self._core

    def initial_state(self) -> "_core.State":
        """The reference configuration at rest (positions, zero rotations and velocities)."""
        return _core.State(self._core)

    def load_state(self, *, mass_flow: Optional[float] = None, mass_flow_rate: float = 0.0,
                   gravity_factor: float = 1.0) -> "_core.LoadState":
        """Loading for the assembler: mdot [kg/s] (default the model's), d(mdot)/dt [kg/s^2]."""
        ls = _core.LoadState()
        ls.mass_flow = self.mass_flow if mass_flow is None else _checks.finite("mass_flow", mass_flow)
        ls.mass_flow_rate = _checks.finite("mass_flow_rate", mass_flow_rate)
        ls.gravity = list(self.gravity)
        ls.gravity_factor = gravity_factor
        return ls

    def node_dofs(self, node: int) -> np.ndarray:
        """Indices of the reduced coordinates that belong to ``node``."""
        return np.array([i for i, (n, _) in enumerate(self.dof_labels) if n == node], dtype=int)

    def dof_index(self, node: int, component: str) -> int:
        """Reduced index of a node's coordinate (``ux`` ... ``rz``); ValueError if fixed."""
        for i, lab in enumerate(self.dof_labels):
            if lab == (node, component):
                return i
        raise ValueError(f"node {node} has no free coordinate {component!r}")

    @property
    def length_scale(self) -> float:
        """The model's size [m] for Newton's tests: the core's one definition (the largest
        extent of the reference node positions along x, y or z, at least 1 mm)."""
        return float(self._core.length_scale)

    def system(self, state: Optional["_core.State"] = None, *, mass_flow: Optional[float] = None,
               gravity_factor: float = 1.0) -> "_core.System":
        """The model as the core's one system object (``pipeflex._core.System``) on
        ``state`` (default: the reference configuration at rest; updated in place by the
        analyses run on it), with gravity and the hub as the model's and mdot [kg/s]
        ``mass_flow`` (default the model's) for the loads that depend on it."""
        state = self.initial_state() if state is None else state
        return _core.element_system(self._core, state, self.load_state(mass_flow=mass_flow,
                                                                        gravity_factor=gravity_factor))

    # The protocol of the analyses (pipeflex.analysis: one driver for every formulation; the
    # same methods on pipeflex.multibody.MultibodySystem and pipeflex.CoupledSystem).

    def _system(self, state=None, *, mass_flow: Optional[float] = None) -> "_core.System":
        """The core system on a copy of ``state`` (what :func:`~pipeflex.state.as_core`
        takes; None: the reference configuration at rest), mdot [kg/s] ``mass_flow`` (None:
        the model's) for the loads that depend on it."""
        from .state import as_core

        return self.system(as_core(self, state), mass_flow=mass_flow)

    def _state_of(self, system):
        """The end state of an analysis run on ``system`` (from :meth:`_system`): a
        :class:`~pipeflex.state.State` (a copy)."""
        from .state import State

        return State.from_core(system.element_state, self)

    #: :func:`~pipeflex.linearize` without a state: about the reference configuration (an
    #: element model's supports are eliminated: no reactions to balance).
    _linearize_at_equilibrium = False

    def _gravity_rebuild(self):
        """(gravity g [m/s^2] (3,), rebuild(g) -> a copy of the model with gravity g), for
        continuation in the gravity; None if the model was not built by ModelBuilder."""
        desc = self._description
        if desc is None:
            return None

        def rebuild(g):
            out = _rebuild_model({**desc, "_gravity": np.array(g, float)}, self.mass_flow, self._is_free)
            out.info = self.info
            return out

        return np.array(desc["_gravity"], float), rebuild

    def _nodal_loads(self):
        """The nodal loads as (node, force [N] (3,)) (dead plus follower), None if the
        model was not built by ModelBuilder."""
        d = self._description
        if d is None or "_loads" not in d:
            return None
        return [(int(ld["node"]), np.asarray(ld["f"], float) + np.asarray(ld["ff"], float)) for ld in d["_loads"]]

    def _linearization(self, system, mass_flow: float, mass_flow_rate: float = 0.0) -> dict:
        """:func:`~pipeflex.linearize`'s fields for ``system`` at mdot [kg/s] ``mass_flow``
        changing at ``mass_flow_rate`` [kg/s^2]:
        the reduced coordinates' M, C, K (CSC) from the core's ``linear_matrices`` on the
        one system object, about the state re-based (phi = 0), and the coordinates' labels.
        The state is copied into a system the model keeps, so that repeated linearisations
        (critical_mass_flow's scan, campbell, stability maps) reuse its tangent's pattern;
        one per concurrent caller (a thread takes one from the pool or makes one)."""
        from .analysis.constrained import from_core
        from .state import State

        s = system.element_state  # a copy
        try:
            held, linear = self._linear_systems.pop()  # atomic: no two threads get the same one
        except IndexError:
            held = s.copy()
            linear = _core.element_system(self._core, held, self.load_state())
        held.q, held.v, held.a, held.frames = s.q, s.v, s.a, s.frames
        try:
            K, C, M, _ = from_core(_core.linear_matrices(linear, mass_flow, mass_flow_rate=mass_flow_rate))  # held re-based in place
            state = State.from_core(held, self)  # a copy
        finally:
            self._linear_systems.append((held, linear))
        return dict(M=M, C=C, K=K, state=state, dof_labels=self.dof_labels)

    def _equilibrium_state(self, result):
        """The state a static result holds (what :meth:`_system` takes): its ``state``."""
        return result.state

    def _flow_residual(self, state, mass_flow: float, mass_flow_rate: float) -> np.ndarray:
        """The static residual (n_dofs,) [N, N m] at ``state`` (a
        :class:`~pipeflex.state.State`) under the full loads with mdot [kg/s] ``mass_flow``
        changing at ``mass_flow_rate`` [kg/s^2] (the parametric analysis differences it in
        the flow: the quasi-static response to the flow's changes)."""
        from .state import as_core

        load = self.load_state(mass_flow=mass_flow, mass_flow_rate=mass_flow_rate)
        return np.asarray(_core.assemble_csc(self._core, as_core(self, state), load, 1.0, [], True)[0])

    def _zero_flow_growth_hint(self) -> str:
        """Why a mode may grow from the first flow on, for :func:`~pipeflex.critical_mass_flow`'s
        error: '' (an element model's equilibrium without flow is only marginal)."""
        return ""

    def _element_hinges(self) -> list:
        """The nodes with one free rotation and fixed position, as (node, axis, coordinate)
        (linear in the model size: only nodes with one reduced coordinate are looked at)."""
        nodes = np.fromiter((n for n, _ in self.dof_labels), dtype=int, count=self.n_dofs)
        single = np.bincount(nodes, minlength=self.n_nodes)[nodes] == 1
        basis = self.basis
        found = []
        for dof in np.flatnonzero(single):
            n = int(nodes[dof])
            t = basis[6 * n:6 * n + 6, [dof]].toarray()[:, 0]
            if np.allclose(t[:3], 0.0):
                found.append((n, t[3:] / np.linalg.norm(t[3:]), int(dof)))
        return found

    def _rotation_hinge(self):
        """:func:`~pipeflex.steady_rotation`'s hinge: (name, point [m], axis, body -1, node,
        coordinate) of the one node with fixed position and one free rotation."""
        found = self._element_hinges()
        if len(found) != 1:
            raise ValueError(f"steady_rotation needs exactly one hinge (a node with fixed position and one "
                             f"free rotation); this model has {len(found)}")
        node, axis, dof = found[0]
        return f"element node {node}", np.array(self.positions[node], float), axis, -1, node, dof

    def _steady_rotation_parts(self, state) -> dict:
        """:class:`~pipeflex.SteadyRotation`'s fields of the end ``state`` (from
        :meth:`_state_of`): the element state."""
        return dict(state=state)

    def _check_transient(self) -> None:
        """ValueError if :func:`~pipeflex.simulate` cannot integrate this model: an ANCF
        model on a hub under gravity in the x-y plane."""
        hub = self.hub
        if hub is not None and hub.nodes and hub.nodes[0] in self.ancf_nodes and np.any(self.gravity[:2] != 0):
            raise ValueError("gravity in the x-y plane: an ANCF model on a hub is integrated in the co-rotating "
                             "frame, where in-plane gravity would have to turn; keep gravity along the hub axis (z)")

    def _transient_parts(self, out: dict, system, stats: dict, metadata: dict) -> dict:
        """:class:`~pipeflex.TransientResult`'s fields from the core's record ``out`` of a run
        on ``system`` (``metadata`` completed): node positions, rotations, velocities,
        energies and works, the end state."""
        metadata.update(n_nodes=self.n_nodes, n_dofs=self.n_dofs)
        return dict(out, final_state=self._state_of(system))

    def _orbit_chart(self, base):
        """The periodic orbits' chart about ``base`` (None: the reference configuration): the
        reduced coordinates about a State with its node frames held."""
        from .charts import ElementChart

        return ElementChart(self, base)

    def _static_start(self, state) -> "_core.State":
        """The static driver's working state: a copy of ``state`` (as :meth:`_system`'s)."""
        from .state import as_core

        return as_core(self, state)

    def _static_newton(self, state, solve, *, mass_flow: float, load_factor: float, max_iterations: int,
                       start=None) -> dict:
        """One static Newton from the core State ``state`` (updated in place): the driver's
        ``solve(system, force_scale=)`` on the model's system object at mdot [kg/s]
        ``mass_flow``; its dict, with ``why`` the reason when it did not converge."""
        from .analysis.static import outcome_reason

        if self.n_dofs == 0:  # nothing to solve
            return dict(converged=True, singular=False, diverged=False, nonfinite=False, iterations=0,
                        residual=0.0, correction=0.0, negative_start=-1, negative_end=-1)
        load = self.load_state(mass_flow=mass_flow, gravity_factor=load_factor)
        out = solve(_core.element_system(self._core, state, load), force_scale=self.force_scale(mass_flow=mass_flow))
        if not out["converged"]:
            out["why"] = outcome_reason(out, max_iterations, lambda: self._singular_reason(state, load, load_factor))
        return out

    def _singular_reason(self, state, load, load_factor) -> str:
        """Why the tangent at the core State ``state`` is singular, naming its free coordinates."""
        import scipy.sparse as sp

        from .analysis.eigen import describe_coordinates, null_coordinates

        # the system object's tangent (its loads at the full factor: the null space of a
        # mechanism does not depend on them)
        out = _core.linear_matrices(_core.element_system(self._core, state.copy(), load), load.mass_flow)
        free = null_coordinates(sp.csc_matrix(out["K"], shape=(self.n_dofs, self.n_dofs)))
        named = f"; {describe_coordinates(free, self.dof_labels)}" if len(free) else ""
        return f"the tangent is singular (a mechanism: missing supports, or a bifurcation point{named})"

    def _static_increment(self, start, end) -> np.ndarray:
        """The reduced increment from the core State ``start`` to ``end`` (the continuation's secant)."""
        return _core.reduce(self._core, np.asarray(end.q) - np.asarray(start.q))

    def _static_failure(self, out, *, load_factor, mass_flow, reached, ramp, halvings, max_iterations,
                        earlier) -> Exception:
        """The error of a load stepping whose step failed with ``out`` (static.newton_failure's)."""
        from .analysis.static import newton_failure

        return newton_failure(out, load_factor=load_factor, mass_flow=mass_flow, reached=reached, ramp=ramp)

    def _static_result(self, state, *, iterations, residual, mass_flow, limit_points=()):
        """The StaticResult of the equilibrium ``state`` (a core State)."""
        from .analysis.static import StaticResult
        from .state import State

        return StaticResult(State.from_core(state, self), iterations, residual, mass_flow, limit_points)

    @property
    def total_length(self) -> float:
        """Sum of the elements' reference lengths [m]."""
        return float(sum(e.length for e in self.elements))

    @property
    def total_mass(self) -> float:
        """Pipe + fluid mass of all elements [kg] (point masses not included)."""
        return float(sum(e.length * (e.section.pipe_mass + e.section.fluid_mass) for e in self.elements))

    def force_scale(self, *, mass_flow: Optional[float] = None) -> float:
        """A force level [N] of the model, to judge residuals: the largest of EI/l0^2 of
        the elements, k L and k_phi / L of the axial and ground springs (L the model's
        length scale), the softest positive k L or k_phi / L of each bushing (a stiff
        joint's large stiffness, like an element's EA, does not set the level), the
        weight, the nodal loads and the fluid momentum flux P."""
        mdot = self.mass_flow if mass_flow is None else mass_flow
        f = max(((e.section.EIz if e.kind == "ancf" else max(e.section.EI, e.section.EIz)) / e.length**2
                 for e in self.elements), default=0.0)
        for s in self.springs:
            levels = [*(float(k) * self.length_scale for k in np.ravel(s.stiffness)),
                      *(k / self.length_scale for k in (s.rotational_stiffness or ()))]
            f = max(f, min((x for x in levels if x > 0.0), default=0.0) if s.kind == "bushing" else max(levels))
        f = max(f, self.total_mass * float(np.linalg.norm(self.gravity)))
        f = max(f, float(np.abs(_core.external_forces(self._core, self.initial_state())).max(initial=0.0)))
        for e in self.elements:
            if e.section.fluid_mass > 0:
                flux = e.flow_factor * mdot
                f = max(f, e.section.kv * (flux * flux) / e.section.fluid_mass)  # inf, not OverflowError
        if not np.isfinite(f):  # a convergence test against inf would accept any residual
            raise ValueError(f"the model's force level overflows ({f}): nodal loads [N], gravity [m/s^2] or "
                             f"mass_flow [kg/s] too large")
        return f

    def flow_scale(self) -> float:
        """mdot_ref = (pi / L) sqrt(rho_f A_f EI / k_v) [kg/s] with the flow-carrying
        elements' total length L and mean properties: a natural unit of mass flow."""
        els = [e for e in self.elements if e.flow_factor != 0 and e.section.fluid_mass > 0]
        if not els:
            raise ValueError("the model has no element that carries fluid")
        L = sum(e.length for e in els)
        mf = sum(e.length * e.section.fluid_mass for e in els) / L
        EI = sum(e.length * min(e.section.EI, e.section.EIz) for e in els) / L
        kv = sum(e.length * e.section.kv for e in els) / L
        return float(np.pi / L * np.sqrt(mf * EI / kv))
