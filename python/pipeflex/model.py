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
import math
from dataclasses import dataclass
from typing import Iterable, List, Optional, Sequence, Tuple

import numpy as np

from . import _checks, _core
from .rotation import skew
from .sections import PipeSection, refuse_unsupported

COMPONENTS = ("ux", "uy", "uz", "rx", "ry", "rz")
ANCF_COMPONENTS = ("ux", "uy", "uz", "dx", "dy", "dz")  # position, slope dr/dx
ELASTIC_MODELS = ("A", "0")


def _triad(tangent: np.ndarray, up: Optional[np.ndarray]) -> np.ndarray:
    """Orthonormal triad [e_x, e_y, e_z] (columns): e_x along the tangent, e_z towards ``up``.
    Plain float arithmetic: numpy's per-call overhead on 3-vectors dominated building
    large models."""
    tx, ty, tz = (float(c) for c in tangent)
    t = math.sqrt(tx * tx + ty * ty + tz * tz)
    ex = (tx / t, ty / t, tz / t)
    if up is None:
        u = (0.0, 0.0, 1.0) if abs(ex[2]) < 0.9 else (0.0, 1.0, 0.0)
    else:
        u = tuple(float(c) for c in up)
    d = u[0] * ex[0] + u[1] * ex[1] + u[2] * ex[2]
    ez = [u[i] - d * ex[i] for i in range(3)]
    n = math.sqrt(ez[0] * ez[0] + ez[1] * ez[1] + ez[2] * ez[2])
    if n < 1e-9:
        raise ValueError(f"up vector {np.array(u)} is parallel to the element axis {np.array(ex)}")
    ez = [c / n for c in ez]
    ey = (ez[1] * ex[2] - ez[2] * ex[1], ez[2] * ex[0] - ez[0] * ex[2], ez[0] * ex[1] - ez[1] * ex[0])
    return np.array([[ex[i], ey[i], ez[i]] for i in range(3)])


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


def _strain_free_length(chord: np.ndarray, Ep: np.ndarray, Eq: np.ndarray) -> float:
    """l0 with eps_1 = 0 (eq. 1) for end triads Ep, Eq (columns e_x, e_y, e_z) and a chord:
    eps_1 = l - l0 + l0 c with c = (2c3^2 + c3 c4 + 2c4^2 + 2c5^2 + c5 c6 + 2c6^2)/30, where
    c_k = eps_bar_k / l0 depend on the directions only."""
    lc = float(np.linalg.norm(chord))
    el = chord / lc
    c3, c4 = -el @ Ep[:, 2], el @ Eq[:, 2]
    c5, c6 = el @ Ep[:, 1], -el @ Eq[:, 1]
    c = (2 * c3**2 + c3 * c4 + 2 * c4**2 + 2 * c5**2 + c5 * c6 + 2 * c6**2) / 30.0
    if c >= 1.0:
        raise ValueError("element end tangents turn too far from the chord for one element")
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
        self._hub: Optional[HubInfo] = None

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
                rho A; ``fluid_mass`` must be 0 (no flow in ANCF elements) and ``kv``,
                ``GAy``, ``GAz``, ``rotary_inertia``, ``GJ`` at their defaults (refused by
                name otherwise: the element has none of them).
            elastic: elastic force model, ``"A"`` (continuum strain, captures centrifugal
                stiffening) or ``"0"`` (linear strain in a local element frame).
        """
        if elastic not in ELASTIC_MODELS:
            raise ValueError(f"elastic must be one of {ELASTIC_MODELS}, got {elastic!r}")
        if not isinstance(section, PipeSection):
            raise ValueError("section must be a pipeflex.PipeSection")
        if section.fluid_mass != 0.0:
            raise ValueError("ANCF beams carry no fluid: section.fluid_mass must be 0")
        refuse_unsupported(section, {"kv": "the ANCF beam carries no fluid",
                                     "GAy": "the ANCF beam is rigid in shear (Euler-Bernoulli)",
                                     "GAz": "the ANCF beam is rigid in shear (Euler-Bernoulli)",
                                     "rotary_inertia": "the ANCF beam has no rotary inertia of the cross-section",
                                     "GJ": "the planar ANCF beam has no torsion"}, "add_ancf_beam")
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
        if p == q:
            raise ValueError(f"a pipe element needs two different nodes, got p = q = {p}")
        for i in (p, q):
            if i in self._ancf_nodes:
                raise ValueError(f"node {i} is an ANCF node; pipe elements need frame nodes (add_node)")
        if not isinstance(section, PipeSection):
            raise ValueError("section must be a pipeflex.PipeSection")
        chord = self._positions[q] - self._positions[p]
        lc = float(np.linalg.norm(chord))
        if lc <= 0.0:
            raise ValueError(f"element {p}->{q} has zero length: nodes {p} and {q} coincide")
        up_v = None if up is None else _checks.unit_vector("up", up)
        tp = chord if tangent_p is None else _checks.unit_vector("tangent_p", tangent_p)
        tq = chord if tangent_q is None else _checks.unit_vector("tangent_q", tangent_q)
        Ep = _triad(tp, up_v)
        Eq = Ep if tangent_p is None and tangent_q is None else _triad(tq, up_v)  # straight: one triad
        if length is not None:
            l0 = _checks.positive("length", length)
        elif tangent_p is None and tangent_q is None:
            l0 = lc  # a straight element: eps_1 of eq. 1 vanishes at the chord
        else:
            l0 = _strain_free_length(chord, Ep, Eq)
        if l0 < lc * (1 - 1e-12):
            raise ValueError(f"length l0 = {l0} must not be shorter than the chord {lc}")
        self._elements.append(dict(p=p, q=q, section=section, l0=l0, Ep=Ep, Eq=Eq, flow_factor=_checks.finite("flow_factor", flow_factor),
                                   fluid_end_terms=bool(fluid_end_terms)))
        return len(self._elements) - 1

    def add_line(self, start: int, end: Sequence[float], n_elements: int, section: PipeSection,
                 **options) -> List[int]:
        """A straight pipe from node ``start`` to the point ``end`` [m] in ``n_elements``
        equal elements; returns the node indices along it (``start`` first)."""
        start = self._node("start", start)
        n = _checks.element_count("n_elements", n_elements, self._n_elements())
        x0, x1 = self._positions[start], _checks.vector3("end", end)
        nodes = [start]
        for k in range(1, n + 1):
            nodes.append(self.add_node(x0 + (x1 - x0) * k / n))
            self.add_pipe(nodes[-2], nodes[-1], section, **options)
        return nodes

    def add_arc(self, start: int, *, center: Sequence[float], angle: float, normal: Sequence[float],
                n_elements: int, section: PipeSection, **options) -> List[int]:
        """A circular arc of curved elements from node ``start`` about ``center`` [m],
        turning by ``angle`` [rad] about the unit ``normal`` (right-hand rule). The local z
        axes are set along the normal; |angle| <= 2 pi (one turn at most). Returns the node
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

        nodes = [start]
        sgn = np.sign(angle)
        for i in range(1, n + 1):
            nodes.append(self.add_node(c + rot(dth * i) @ r0))
            tp = sgn * np.cross(k, rot(dth * (i - 1)) @ r0)
            tq = sgn * np.cross(k, rot(dth * i) @ r0)
            self.add_pipe(nodes[-2], nodes[-1], section, up=k, tangent_p=tp, tangent_q=tq, **options)
        return nodes

    def _n_elements(self) -> int:
        return len(self._elements) + len(self._ancf)

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
                 moment: Sequence[float] = (0.0, 0.0, 0.0), follower: bool = False) -> None:
        """Nodal force [N] and moment [N m]; dead (global axes) or, with ``follower=True``,
        given in the node's frame and turning with it (the frame is the global one in the
        reference configuration)."""
        node = self._node("node", node)
        f = _checks.vector3("force", force)
        m = _checks.vector3("moment", moment)
        z = np.zeros(3)
        self._loads.append(dict(node=node, f=z if follower else f, m=z if follower else m,
                                ff=f if follower else z, fm=m if follower else z))

    def add_point_mass(self, node: int, mass: float, inertia: Sequence[float] = (0.0, 0.0, 0.0)) -> None:
        """Concentrated mass [kg] and principal rotary inertia [kg m^2] (node frame)."""
        node = self._node("node", node)
        self._masses.append(dict(node=node, mass=_checks.non_negative("mass", mass),
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
        if not self._elements and not self._ancf:
            raise ValueError("the model has no elements")
        if not self._constraints and not floating:
            raise ValueError("the model has no supports: add clamp/pin/hinge/fix so it cannot drift (or build it "
                             "with floating=True to join it to bodies in a pipeflex.CoupledSystem)")
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
        used = {e["p"] for e in els} | {e["q"] for e in els}
        loose = sorted(set(range(len(self._positions))) - used)
        if loose:
            raise ValueError(f"nodes {loose} are not connected to any element")
        if not floating:
            self._check_parts_supported(els)
        for e in self._elements:
            if mdot != 0.0 and e["flow_factor"] != 0.0 and e["section"].fluid_mass <= 0.0:
                raise ValueError(f"element {e['p']}->{e['q']} carries a mass flow but its fluid_mass is 0")
        known = {}  # nodes with the same constraint rows share one basis (e.g. all planar ANCF nodes)
        bases = [self._basis(i, known) for i in range(len(self._positions))]
        data = [self._element_data(e) for e in self._elements]  # both cores copy them
        core, infos = self._make_core(bases, self._hub, data)
        # the same model without supports (planar ANCF nodes keep z, z' fixed), for
        # analyses that need the unconstrained matrices (rotating frame)
        free_bases = [np.eye(6)[:, [0, 1, 3, 4]] if i in self._ancf_nodes else np.eye(6)
                      for i in range(len(self._positions))]
        free_core, _ = self._make_core(free_bases, None, data)
        model = Model(core, np.array(self._positions), tuple(infos), bases, mdot, self._gravity.copy(),
                      hub=self._hub, ancf_nodes=tuple(sorted(self._ancf_nodes)),
                      free=(free_core, free_bases), description=_snapshot(vars(self)))
        return model

    def _check_parts_supported(self, els) -> None:
        """Every connected part of the structure needs a support, as the whole model does:
        an unsupported part drifts (a mechanism whose round-off eigenvalues would decide
        a stability answer)."""
        count, part = _parts(len(self._positions), [(e["p"], e["q"]) for e in els])
        supported = {part[i] for i in self._constraints}
        for k in range(count):
            if k not in supported:
                nodes = np.flatnonzero(part == k)
                raise ValueError(f"nodes {nodes[0]}..{nodes[-1]} ({len(nodes)} nodes) form a part with no supports, "
                                 f"not connected to a supported node: add clamp/pin/hinge/fix on it so it cannot "
                                 f"drift")

    def _make_core(self, bases, hub, data):
        core = _core.Model()
        for i, x in enumerate(self._positions):
            if i in self._ancf_nodes:
                core.add_ancf_node(x, self._ancf_nodes[i])
            else:
                core.add_node(x)
        infos = []
        for e, d in zip(self._elements, data):
            core.add_pipe(e["p"], e["q"], d)
            infos.append(ElementInfo((e["p"], e["q"]), e["section"], e["l0"], e["flow_factor"]))
        for e in self._ancf:
            d = _core.AncfElementData()
            sec = e["section"]
            d.l, d.EA, d.EI, d.mass, d.elastic = e["l"], sec.EA, sec.EIz, sec.pipe_mass, e["elastic"]
            core.add_ancf(e["p"], e["q"], d)
            infos.append(ElementInfo((e["p"], e["q"]), sec, e["l"], 0.0, kind="ancf", elastic=e["elastic"]))
        if hub is not None:
            core.set_hub(list(hub.nodes), hub.axis, hub.center, hub.omega, hub.spin_up_time)
        for ld in self._loads:
            core.add_load(ld["node"], ld["f"], ld["m"], ld["ff"], ld["fm"])
        for m in self._masses:
            core.add_mass(m["node"], m["mass"], m["inertia"])
        core.set_bases(bases)
        core.finalize()
        return core, infos

    def _basis(self, node: int, known: dict) -> np.ndarray:
        rows = self._constraints.get(node, [])
        if not rows:
            return np.eye(6)
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

    @staticmethod
    def _element_data(e: dict) -> "_core.PipeElementData":
        s: PipeSection = e["section"]
        l0 = e["l0"]
        d = _core.PipeElementData()
        d.l0 = l0
        d.EA, d.GJ, d.EIy, d.EIz = s.EA, s.GJ, s.EI, s.EIz
        # eq. 7: Phi_z = 12 E I_y / (G A k_z l0^2), Phi_y = 12 E I_z / (G A k_y l0^2)
        d.Phi_z = 0.0 if s.GAz is None else 12.0 * s.EI / (s.GAz * l0**2)
        d.Phi_y = 0.0 if s.GAy is None else 12.0 * s.EIz / (s.GAy * l0**2)
        d.offset_p, d.offset_q = e["Ep"], e["Eq"]
        d.pipe_mass, d.fluid_mass, d.kv = s.pipe_mass, s.fluid_mass, s.kv
        d.rotary_inertia = list(s.rotary_inertia)
        d.flow_factor = e["flow_factor"]
        d.end_terms_p = e["fluid_end_terms"] and e["p"] not in e.get("reservoir", ())
        d.end_terms_q = e["fluid_end_terms"] and e["q"] not in e.get("reservoir", ())
        return d


def _parts(n: int, edges) -> Tuple[int, np.ndarray]:
    """The connected parts of an undirected graph of ``n`` nodes: their count and each
    node's part, numbered in the order of the parts' first nodes (as scipy's
    connected_components). A union-find, linear in the edges: building a model needs no
    scipy (its sparse package imports in about 30 ms)."""
    root = list(range(n))

    def find(i):
        while root[i] != i:
            root[i] = root[root[i]]  # path halving
            i = root[i]
        return i

    for p, q in edges:
        a, b = find(p), find(q)
        if a != b:
            root[max(a, b)] = min(a, b)
    labels: dict = {}
    part = np.array([labels.setdefault(find(i), len(labels)) for i in range(n)], dtype=np.int64)
    return len(labels), part


def _rebuild_model(description: dict, mass_flow: float, free: bool) -> "Model":
    """A model built again from :meth:`Model.__reduce__`'s description."""
    b = ModelBuilder()
    vars(b).update(copy.deepcopy(description))
    model = b.build(mass_flow=mass_flow)
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
        info: free-form description a scene attaches (e.g. reference frequencies).
    """

    def __init__(self, core, positions, elements, bases, mass_flow, gravity, *, hub=None, ancf_nodes=(),
                 free=None, description=None, is_free=False):
        self._description = description
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
        rows, cols, vals = [], [], []
        labels = []
        first_dof = list(core.first_dof)  # one conversion: each attribute access copies the vector
        ancf = set(ancf_nodes)  # a tuple's `in` would make the build quadratic in the nodes
        # each distinct basis (most nodes have the identity) read once: its entries column by
        # column (j, then i) and each column's one component (-1: combined)
        seen = {}
        for n, T in enumerate(bases):
            key = (T.shape, T.tobytes())
            entries = seen.get(key)
            if entries is None:
                j, i = np.nonzero(T.T)
                single = np.count_nonzero(T, axis=0) == 1
                entries = seen[key] = (i, j, T[i, j], [int(i[j == c][0]) if single[c] else -1
                                                         for c in range(T.shape[1])])
            i, j, v, component = entries
            names = ANCF_COMPONENTS if n in ancf else COMPONENTS
            labels.extend((n, names[k] if k >= 0 else "combined") for k in component)
            rows.append(6 * n + i)
            cols.append(first_dof[n] + j)
            vals.append(v)
        # the triplets of `basis` (CSR on first use), kept as arrays: 24 bytes an entry
        self._basis_matrix = (np.concatenate(vals).astype(float) if vals else np.zeros(0),
                              (np.concatenate(rows).astype(np.int64) if rows else np.zeros(0, np.int64),
                               np.concatenate(cols).astype(np.int64) if cols else np.zeros(0, np.int64)))
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
                     ancf_nodes=self.ancf_nodes, description=self._description, is_free=True)

    def __reduce__(self):
        if self._description is None:
            raise TypeError("this Model was not built by ModelBuilder.build: it cannot be pickled")
        return _rebuild_model, (self._description, self.mass_flow, self._is_free), {"info": self.info}

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
    def total_length(self) -> float:
        """Sum of the elements' reference lengths [m]."""
        return float(sum(e.length for e in self.elements))

    @property
    def total_mass(self) -> float:
        """Pipe + fluid mass of all elements [kg] (point masses not included)."""
        return float(sum(e.length * (e.section.pipe_mass + e.section.fluid_mass) for e in self.elements))

    def force_scale(self, *, mass_flow: Optional[float] = None) -> float:
        """A force level [N] of the model, to judge residuals: the largest of EI/l0^2 of
        the elements, the weight, the nodal loads and the fluid momentum flux P."""
        mdot = self.mass_flow if mass_flow is None else mass_flow
        f = max((e.section.EIz if e.kind == "ancf" else max(e.section.EI, e.section.EIz)) / e.length**2
                for e in self.elements)
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
