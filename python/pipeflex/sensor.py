"""Sensors: quantities recorded at every accepted step of ``simulate``, and crossing (event)
sensors.

``pf.simulate(model, t_end, sensors=[...])`` records each sensor at the start and at the
end of every step the integrator accepts (generalised-alpha, fixed step or ``rtol``, and
IDA), inside the C++ time loop: no Python call per step (but :func:`custom` sensors'). The
results are in
``result.sensors`` (name -> ``(t_steps, values)``) and in ``result.to_xarray()`` (one
variable per sensor on the ``step_time`` coordinate)::

    tip = pf.sensor.node_position(8, "y")
    res = pf.simulate(model, 1.0, sensors=[tip, pf.sensor.crossing(tip, direction="up"),
                                           pf.sensor.section_force(0, 0.0, "My")])
    t, y = res.sensors["node_position[8].y"]
    up = res.sensors["node_position[8].y up 0"][0]  # the times it rose through 0 [s]

A sensor's name defaults to its kind, index and component (``"node_acceleration[4].y"``,
``"section_force[0](s=0).My"``); ``name=`` sets it. Without ``component`` a sensor
records all its components (values of shape (n_steps, n_components)).

:func:`crossing` records the times [s] a one-component sensor passes a level, located
inside the step on the cubic Hermite interpolant between the two step ends (with the
component's rate where the state has it: a position's velocity, a velocity's
acceleration, an angle's angular velocity; otherwise the rates of the parabola through
the last three steps' values): accurate to the integrator's own error, independent of the
output times. ``terminal=True`` ends the run at the step that crosses: the outputs then end
with that step's end (``result.t[-1]``, ``final_state``) and
``result.metadata["stopped_at"]`` holds the crossing's time.

Every system records sensors:

- an element model (:class:`~pipeflex.Model`): node sensors of its nodes (by index),
  :func:`strain`, :func:`section_force`, :func:`spring_force`, :func:`energy`;
- floating-frame bodies (:class:`~pipeflex.multibody.MultibodySystem`): node sensors of
  a body node addressed ``(body, node)`` (``node`` its index or ``"start"``, ``"center"``,
  ``"end"``), evaluated through the body's node map (position r + R (x + Phi_u eta),
  orientation R exp(Phi_theta eta), velocity and acceleration by the map's Jacobians),
  :func:`energy` (as :meth:`~pipeflex.multibody.MultibodySystem.energy`, springs
  included), :func:`spring_force` of its springs and :func:`joint_force`;
- a coupled system (:class:`~pipeflex.coupled.CoupledSystem`): both, element nodes by
  index and body nodes by ``(body, node)``; :func:`energy` is the two parts' sum (the
  coupling springs' energy left out); ``spring_force(k)`` the element model's spring,
  ``spring_force(k, part="bodies")`` the bodies', ``spring_force(k, part="couplings")``
  a coupling spring's tension; ``joint_force(j)`` the bodies' joint,
  ``joint_force(j, part="couplings")`` a coupling's multipliers.

A sensor of a part the system does not have, or a node, element, spring or joint not in
it, raises ValueError naming the sensor.

:func:`custom` records the user's function ``fn(t, state)`` of the state at every
accepted step (the core calls it from its time loop, taking the GIL): what no built-in
sensor gives, e.g. a distance between two nodes, or a signal processed on line. A
trivial function costs about 1 us per step (CPU time, measured on the 8-element cantilever
of benchmarks/bench_limit_cycle.py at h = 1 ms: 1.15 us on a step of 21 us, 5 %; each
further one 0.26 us; a built-in sensor 0.05 us); its own work comes on top (reading
``state.q``, a copy: 0.3 us more). :func:`crossing` takes any one-component sensor,
custom ones included (which, having no rate, are interpolated on the parabola through
three steps). On a coupled system, a robot's hand (body 2's end) and the height of the
hose it carries (element node 8) above it::

    hand = pf.sensor.node_position((2, "end"), "z")
    above = pf.sensor.custom(lambda t, s: s.state.q[6 * 8 + 2] - s.body_state.r[2, 2], name="above", unit="m")
    res = pf.simulate(system, 2.0, sensors=[hand, above, pf.sensor.crossing(above, 0.0, terminal=True)])
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import _checks

__all__ = ["Sensor", "Crossing", "node_position", "node_velocity", "node_acceleration", "node_rotation", "strain",
           "section_force", "spring_force", "joint_force", "energy", "custom", "crossing"]

_XYZ = ("x", "y", "z")
#: per kind: the core's SensorKind number, the components' names and units
_KINDS = {
    "node_position": (0, _XYZ, "m"),
    "node_velocity": (1, _XYZ, "m/s"),
    "node_acceleration": (2, _XYZ, "m/s^2"),
    "node_rotation": (3, _XYZ, "rad"),
    "node_angle": (4, ("angle",), "rad"),
    "energy": (5, ("kinetic", "elastic", "gravity_potential", "total"), "J"),
    "strain": (6, ("axial", "twist", "kappa_y", "kappa_z"), ("1", "1/m", "1/m", "1/m")),
    "section_force": (7, ("N", "T", "My", "Mz"), ("N", "N m", "N m", "N m")),
    "axial_spring": (8, ("tension",), "N"),
    "ground_spring": (9, _XYZ, "N"),
    "joint_force": (10, None, "N, N m"),  # components: the joint's rows
    "bushing": (11, _XYZ, "N"),
    "custom": (12, None, None),  # components and unit: the user's
}
#: the core's SensorPart numbers
_PARTS = {"elements": 0, "bodies": 1, "couplings": 2}
_DIRECTIONS = {"up": 1, "down": -1, "both": 0}


@dataclass(frozen=True)
class Sensor:
    """A sensor of :func:`~pipeflex.simulate` (build it with this module's functions).

    Attributes:
        kind: ``"node_position"``, ``"node_velocity"``, ``"node_acceleration"``,
            ``"node_rotation"``, ``"node_angle"``, ``"energy"``, ``"strain"``,
            ``"section_force"``, ``"spring_force"``, ``"joint_force"`` or ``"custom"``.
        index: the node (a body node's: its index or ``"start"``, ``"center"``, ``"end"``),
            element, spring or joint [-] (0 for ``energy`` and ``custom``).
        component: index of the one component recorded, or None (all).
        s: [-] local coordinate along the element in [0, 1] (strain, section_force).
        axis: (3,) unit axis of ``node_angle``, else None.
        name: the result's key (None: the default name).
        body: a body node's body [-] (node sensors addressed ``(body, node)``), else None.
        part: ``"bodies"`` or ``"couplings"`` where a spring or joint index refers to
            them (:func:`spring_force`, :func:`joint_force`), else None.
        fn: a custom sensor's function (:func:`custom`), else None.
        names: a custom sensor's component names, else None.
        unit: a custom sensor's unit (free text), else None.
    """

    kind: str
    index: Union[int, str] = 0
    component: Optional[int] = None
    s: float = 0.0
    axis: Optional[Tuple[float, float, float]] = None
    name: Optional[str] = None
    body: Optional[int] = None
    part: Optional[str] = None
    fn: Optional[Callable] = field(default=None, compare=False)
    names: Optional[Tuple[str, ...]] = None
    unit: Optional[str] = None

    def components(self, model=None) -> Tuple[str, ...]:
        """The names of all the sensor's components (``model``: for a spring's kind)."""
        if self.kind == "custom":
            return self.names
        return _KINDS[self._core_kind(model)][1]

    def _core_kind(self, model=None) -> str:
        if self.kind != "spring_force":
            return self.kind
        if model is None:
            raise ValueError("spring_force: the model decides the spring's kind")
        return {"axial": "axial_spring", "bushing": "bushing"}.get(_spring_kinds(model, self.part)[self.index],
                                                                   "ground_spring")

    @property
    def label(self) -> str:
        """The result's key: ``name`` or the default, e.g. ``node_acceleration[4].y``."""
        if self.name is not None:
            return self.name
        where = {"energy": "", "strain": f"[{self.index}](s={self.s:g})",
                 "section_force": f"[{self.index}](s={self.s:g})"}.get(self.kind, f"[{self.index}]")
        if self.body is not None:
            where = f"[{self.body},{self.index}]"
        elif self.part is not None:
            where = f"[{self.part} {self.index}]"
        if self.kind == "node_angle":
            where += "(axis=" + ",".join(f"{a:g}" for a in self.axis) + ")"
        if self.component is None:
            return f"{self.kind}{where}"
        if self.kind == "joint_force":
            return f"{self.kind}{where}.{self.component}"
        names = (_XYZ if self.kind == "spring_force" else _KINDS[self.kind][1])
        return f"{self.kind}{where}.{names[self.component]}" if len(names) > 1 else f"{self.kind}{where}"


@dataclass(frozen=True)
class Crossing:
    """A crossing sensor (:func:`crossing`): the times ``sensor`` passes ``level``."""

    sensor: Sensor
    level: float = 0.0
    direction: str = "both"
    terminal: bool = False
    name: Optional[str] = None

    @property
    def label(self) -> str:
        """The result's key: ``name`` or ``"<sensor> <direction> <level>"``."""
        return self.name if self.name is not None else f"{self.sensor.label} {self.direction} {self.level:g}"


def _component(kind: str, component, names: Sequence[str]) -> Optional[int]:
    if component is None:
        return None
    if isinstance(component, str):
        if component not in names:
            raise ValueError(f"{kind}: component must be one of {list(names)} or None, got {component!r}")
        return names.index(component)
    k = _checks.non_negative_int("component", component)
    if not 0 <= k < len(names):
        raise ValueError(f"{kind}: component must be one of {list(names)} (or 0..{len(names) - 1}) or None, "
                         f"got {component!r}")
    return k


def _index(kind: str, what: str, value) -> int:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise ValueError(f"{kind}: {what} must be an integer index, got {value!r}")
    if value < 0:
        raise ValueError(f"{kind}: {what} {value} is negative")
    return int(value)


def _node(kind: str, node) -> Tuple[Optional[int], Union[int, str]]:
    """(body or None, node) of a node sensor's address: an element node's index, or a
    body node's (body, node) with node an index or "start", "center", "end"."""
    if isinstance(node, tuple):
        if len(node) != 2:
            raise ValueError(f"{kind}: a body node is addressed (body, node), got {node!r}")
        body, n = node
        if not (isinstance(n, str) and n in ("start", "center", "end")):
            n = _index(kind, "node", n)
        return _index(kind, "body", body), n
    return None, _index(kind, "node", node)


def _node_sensor(kind: str, node, component, name: Optional[str]) -> Sensor:
    body, n = _node(kind, node)
    return Sensor(kind, n, _component(kind, component, _XYZ), name=name, body=body)


def node_position(node, component: Union[None, str, int] = None, *, name: Optional[str] = None) -> Sensor:
    """x [m] of ``node``: ``component`` ``"x"``, ``"y"``, ``"z"`` (or 0, 1, 2), None: all three.

    ``node`` is an element node's index, or a body node's ``(body, node)`` with ``node`` its
    index or ``"start"``, ``"center"``, ``"end"`` (as the bodies' builder names them): its
    position r + R (x + Phi_u eta) through the body's node map (every node sensor)."""
    return _node_sensor("node_position", node, component, name)


def node_velocity(node: int, component: Union[None, str, int] = None, *, name: Optional[str] = None) -> Sensor:
    """v [m/s] of ``node`` (``component`` as :func:`node_position`)."""
    return _node_sensor("node_velocity", node, component, name)


def node_acceleration(node: int, component: Union[None, str, int] = None, *, name: Optional[str] = None) -> Sensor:
    """a [m/s^2] of ``node`` (``component`` as :func:`node_position`): the integrator's
    acceleration at each step's end (generalised-alpha's true acceleration, not its
    pseudo-acceleration)."""
    return _node_sensor("node_acceleration", node, component, name)


def node_rotation(node, component: Union[None, str, int] = None, *,
                  axis: Optional[Sequence[float]] = None, name: Optional[str] = None) -> Sensor:
    """The rotation of ``node`` from its reference orientation [rad]: the rotation vector
    log(R) (3 components, abs(phi) <= pi; ``component`` as :func:`node_position`), or with
    ``axis`` (a unit vector, normalised) the angle axis . log(R), unwrapped step by step
    (a continuous angle beyond pi: the rotation about a hinge; exact for a rotation about
    ``axis``). A body node's (``(body, node)``): R = A A0^T, A its orientation
    R_frame exp(Phi_theta eta) and A0 that in the assembly configuration."""
    if axis is None:
        return _node_sensor("node_rotation", node, component, name)
    if component is not None:
        raise ValueError("node_rotation: give either component (of the rotation vector) or axis (an angle)")
    k = tuple(float(a) for a in _checks.unit_vector("axis", axis))
    body, n = _node("node_rotation", node)
    return Sensor("node_angle", n, None, axis=k, name=name, body=body)


def _element_sensor(kind: str, element: int, s: float, component, name) -> Sensor:
    e = _index(kind, "element", element)
    s = _checks.finite("s", s)
    if not 0.0 <= s <= 1.0:
        raise ValueError(f"{kind}: s must be in [0, 1] (the local coordinate along element {e}), got {s:g}")
    return Sensor(kind, e, _component(kind, component, _KINDS[kind][1]), s=s, name=name)


def strain(element: int, s: float = 0.5, component: Union[None, str, int] = None, *,
           name: Optional[str] = None) -> Sensor:
    """The strains of pipe element ``element`` at local coordinate ``s`` in [0, 1] (0: its
    node p, 1: node q): ``"axial"`` [-] the chord's stretch (l - l0)/l0 with the bending
    terms of the element's eq. 1, ``"twist"`` [1/m] the rate of twist, ``"kappa_y"``,
    ``"kappa_z"`` [1/m] the curvatures about the element's local y and z axes (of its
    Hermite centre line: linear in s between the ends; uniform, kappa, in a uniform bend),
    each from the element's own generalised strains (minus their stress-free values)."""
    return _element_sensor("strain", element, s, component, name)


def section_force(element: int, s: float = 0.5, component: Union[None, str, int] = None, *,
                  name: Optional[str] = None) -> Sensor:
    """The section resultants of pipe element ``element`` at ``s`` in [0, 1] from the
    element's own constitutive law (its generalised stresses, shear flexibility included):
    ``"N"`` [N] the axial force (tension positive), ``"T"`` [N m] the torque, ``"My"``,
    ``"Mz"`` [N m] the bending moments about the local y and z axes (EI kappa in a uniform
    bend; linear in s between the element's end moments). The shear forces are not
    recorded (they are the moments' slope: (M(1) - M(0)) / l0)."""
    return _element_sensor("section_force", element, s, component, name)


def _part(kind: str, part, allowed) -> Optional[str]:
    if part is not None and part not in allowed:
        raise ValueError(f"{kind}: part must be one of {list(allowed)} or None, got {part!r}")
    return part


def spring_force(spring: int, component: Union[None, str, int] = None, *, part: Optional[str] = None,
                 name: Optional[str] = None) -> Sensor:
    """The force of spring ``spring`` (the index ``add_spring``/``add_ground_spring``
    returned) [N], stiffness and dashpot together: an axial spring's tension (one value),
    a ground spring's force on its node, a bushing's force on its node b (``component``
    as :func:`node_position`).
    ``part``: None, the element model's springs (a system of bodies: the bodies'),
    ``"bodies"``: the bodies' springs of a coupled system
    (:meth:`pipeflex.multibody.MultibodyBuilder.add_spring`), or ``"couplings"``: its
    springs between an element node and a body node
    (:meth:`pipeflex.coupled.CoupledSystem.add_spring`)."""
    return Sensor("spring_force", _index("spring_force", "spring", spring),
                  _component("spring_force", component, _XYZ), name=name,
                  part=_part("spring_force", part, ("bodies", "couplings")))


def joint_force(joint: int, component: Optional[int] = None, *, part: Optional[str] = None,
                name: Optional[str] = None) -> Sensor:
    """The multipliers of joint ``joint`` of a system of floating-frame bodies (its index
    in the order the builder added the joints), one per constraint row in the joint's
    order (a clamp's ``fix``: 3 force rows [N], then 3 moment rows [N m]; a hinge: 3 and
    2; a spherical joint: 3; a roller: 1): the reactions C_q^T lambda the joint applies,
    as generalised-alpha and IDA carry them (``component``: one row, None: all).
    ``part``: None (or ``"bodies"``) the bodies' joints, also in a coupled system;
    ``"couplings"`` a coupled system's coupling ``joint`` (its index in the order they were
    added: :attr:`pipeflex.coupled.CoupledSystem.joints`), its rows as
    ``TransientResult.coupling_forces`` holds them."""
    j = _index("joint_force", "joint", joint)
    return Sensor("joint_force", j, None if component is None else _checks.non_negative_int("component", component),
                  name=name, part=_part("joint_force", part, ("bodies", "couplings")))


def energy(component: Union[None, str, int] = None, *, name: Optional[str] = None) -> Sensor:
    """The energies [J]: ``"kinetic"``, ``"elastic"``, ``"gravity_potential"`` and their sum
    ``"total"`` (None: all four)."""
    return Sensor("energy", 0, _component("energy", component, _KINDS["energy"][1]), name=name)


def custom(fn: Callable, *, name: str, components: Union[None, int, Sequence[str]] = None,
           unit: Optional[str] = None) -> Sensor:
    """A sensor of the user's: ``fn(t, state)`` called in the time loop at the start and
    every accepted step, returning a number (``components=None``) or a 1-D array of
    ``len(components)`` values (``components``: their names, or their count: named
    "0", "1", ...).

    ``t`` [s] is the step's end, ``state`` the system's state there (read-only copies on
    attribute access, valid during the call only): an element model's ``q``, ``v``, ``a``
    (6 n_nodes,) and ``frames`` as :class:`pipeflex.State`; bodies' ``r``, ``R``, ``eta``,
    ``v``, ``a``, ``lam`` as :class:`pipeflex.multibody.MultibodyState`; a coupled
    system's ``state`` and ``body_state`` (those two) and ``coupling_forces``.

    Each call takes the GIL from the core's time loop: a trivial function costs about 1 us per
    step (5 % of a step of the 8-element cantilever of benchmarks/bench_limit_cycle.py;
    module docstring), its own work comes on top; a run without custom sensors makes no
    Python call. An
    exception in ``fn`` ends the run: RuntimeError naming the sensor, the time and the
    exception's type and message; a value of the wrong size or not finite: ValueError.

    Args:
        fn: the function (t [s], state) -> float or (n,) array.
        name: the result's key (required: the function has no default name).
        components: None (one value), the number of values, or their names.
        unit: their unit (free text for the metadata), or None.
    """
    if not callable(fn):
        raise ValueError(f"custom: fn must be callable, got {fn!r}")
    if not isinstance(name, str) or not name:
        raise ValueError(f"custom: name must be a non-empty string, got {name!r}")
    if components is None:
        names = (name,)
    elif isinstance(components, (int, np.integer)) and not isinstance(components, bool):
        if components < 1:
            raise ValueError(f"custom: components must be >= 1 (the number of values), got {components}")
        names = tuple(str(i) for i in range(int(components)))
    else:
        names = tuple(components)
        if not names or not all(isinstance(c, str) for c in names) or len(set(names)) != len(names):
            raise ValueError(f"custom: components must be None, a count or distinct names, got {components!r}")
    return Sensor("custom", 0, None, name=name, fn=fn, names=names, unit=None if unit is None else str(unit))


def crossing(sensor: Sensor, level: float = 0.0, direction: str = "both", *, terminal: bool = False,
             name: Optional[str] = None) -> Crossing:
    """The times [s] ``sensor`` (one component) passes ``level`` [its unit]: rising
    (``direction="up"``), falling (``"down"``) or either (``"both"``), located inside the
    step (module docstring). ``terminal=True``: the run ends at the step that crosses first.
    ``result.sensors[name]`` is ``(times, signs)``, signs +1 up and -1 down."""
    if not isinstance(sensor, Sensor):
        raise ValueError(f"crossing: sensor must be a pipeflex.sensor sensor, got {sensor!r}")
    if direction not in _DIRECTIONS:
        raise ValueError(f"crossing: direction must be one of {list(_DIRECTIONS)}, got {direction!r}")
    names = sensor.names if sensor.kind == "custom" else _KINDS.get(sensor.kind, (0, ()))[1] or ()
    if sensor.component is None and sensor.kind not in ("spring_force", "joint_force") and len(names) > 1:
        how = "give a custom sensor of one value" if sensor.kind == "custom" else "choose one (component=)"
        raise ValueError(f"crossing: sensor {sensor.label!r} records {len(names)} components: {how}")
    return Crossing(sensor, _checks.finite("level", level), direction, bool(terminal), name)


# -- the run's side (pipeflex.analysis.transient) ------------------------------------------------

def _parts(model):
    """(element model or None, bodies (a MultibodySystem) or None, couplings or None) of
    the system simulate runs."""
    if getattr(model, "joint_rows", None) is not None:
        return None, model, None
    if hasattr(model, "bodies") and hasattr(model, "core_couplings"):  # a coupled system
        return model.model, model.bodies, model
    return model, None, None


def _spring_kinds(model, part) -> Tuple[str, ...]:
    """Per spring of the part a spring_force sensor addresses: "axial", "ground" or "bushing"."""
    elements, bodies, coupled = _parts(model)
    if part == "couplings":
        return tuple(sp["kind"] for sp in getattr(coupled, "_springs", ())) if coupled is not None else ()
    if part == "bodies" or elements is None:
        return bodies.spring_kinds if bodies is not None else ()
    return tuple(sp.kind for sp in elements.springs)


def prepare(model, system, sensors) -> Tuple[object, List[tuple]]:
    """The core's SensorLog of ``sensors`` checked against ``model`` (an element model, a
    system of bodies or a coupled system), and per entry (label, kind, core sensor index,
    component or None, units, component names) to collect the results."""
    from . import _core

    items = list(sensors)
    elements, bodies, coupled = _parts(model)
    log = _core.SensorLog()
    entries, added, labels = [], {}, set()

    def add(s: Sensor) -> int:
        key = (s.kind, s.index, s.s, s.axis, s.body, s.part) if s.kind != "custom" else ("custom", s.label)
        if key in added:
            return added[key]
        if s.kind == "custom":
            added[key] = log.add_custom(s.fn, len(s.names), s.label)
            return added[key]
        part, index, body, frame = _check(model, elements, bodies, coupled, s)
        kind = s._core_kind(model)
        rows = 0
        if kind == "joint_force":
            index, rows = index
        elif kind in ("strain", "section_force"):
            pass
        elif kind in ("axial_spring", "ground_spring", "bushing") and part == "elements":
            index += len(elements.elements)  # the springs follow the elements in the core's registry
        added[key] = log.add(_KINDS[kind][0], index, s.s, s.axis or (0.0, 0.0, 0.0), rows=rows, part=_PARTS[part],
                             body=body, frame=frame)
        return added[key]

    for s in items:
        if not isinstance(s, (Sensor, Crossing)):
            raise ValueError(f"sensors: each must be a pipeflex.sensor sensor or crossing, got {s!r}")
        if s.label in labels:
            raise ValueError(f"sensors: two sensors are named {s.label!r} (give one a name=)")
        labels.add(s.label)
        if isinstance(s, Sensor):
            k = add(s)
            if s.kind == "custom":
                entries.append((s.label, "sensor", k, None, s.unit or "", s.names))
                continue
            kind = s._core_kind(model)
            names = _KINDS[kind][1] or tuple(str(i) for i in range(log.width(k)))
            entries.append((s.label, "sensor", k, s.component, _KINDS[kind][2], names))
        else:
            k = add(s.sensor)
            comp, width = (0 if s.sensor.component is None else s.sensor.component), log.width(k)
            if s.sensor.component is None and width > 1:
                raise ValueError(f"crossing {s.label!r}: sensor {s.sensor.label!r} records {width} "
                                 "components: choose one (component=)")
            j = log.add_crossing(k, comp, s.level, _DIRECTIONS[s.direction], s.terminal)
            entries.append((s.label, "crossing", j, None, "s", ()))
    return log, entries


_IDENTITY = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)


def _check(model, elements, bodies, coupled, s: Sensor):
    """(part, core index, body, reference frame) of sensor ``s`` on the system's parts;
    ValueError naming the sensor where its node, element, spring or joint is not there
    (a joint's core index: (first row, rows))."""
    what = ("a system of floating-frame bodies" if elements is None else
            "a coupled system (elements and bodies)" if bodies is not None else "an element model")
    label = s.label
    if s.kind.startswith("node_"):
        if s.body is None:
            if elements is None:
                raise ValueError(f"sensor {label!r}: this run is of {what}: address a body node as (body, node)")
            if s.index >= elements.n_nodes:
                raise ValueError(f"sensor {label!r}: node {s.index} is not in the model (nodes "
                                 f"0..{elements.n_nodes - 1})")
            if s.kind == "node_rotation" and s.index in set(elements.ancf_nodes):
                raise ValueError(f"sensor {label!r}: node {s.index} is an ANCF node (no rotation vector; its slope's "
                                 "angle: node_rotation(node, axis=(0, 0, 1)))")
            return "elements", s.index, 0, _IDENTITY
        if bodies is None:
            raise ValueError(f"sensor {label!r}: this run is of {what}, which has no bodies (node sensors address "
                             "its nodes by index)")
        try:
            j = bodies.body_index(s.body)
            i = bodies.bodies[j].node_index(s.index)
        except ValueError as e:
            raise ValueError(f"sensor {label!r}: {e}") from None
        frame = _IDENTITY
        if s.kind in ("node_rotation", "node_angle"):
            A0 = bodies.node_kinematics(bodies.initial_state(), j, i)[1]
            frame = tuple(float(x) for x in np.asarray(A0).ravel())
        return "bodies", i, j, frame
    if s.kind in ("strain", "section_force"):
        if elements is None:
            raise ValueError(f"sensor {label!r}: this run is of {what}; {s.kind} is recorded on pipe elements "
                             "(pipeflex.Model, or a coupled system's element model)")
        n = len(elements.elements)
        if s.index >= n:
            raise ValueError(f"sensor {label!r}: element {s.index} is not in the model (elements 0..{n - 1})")
        if elements.elements[s.index].kind != "pipe":
            raise ValueError(f"sensor {label!r}: element {s.index} is an {elements.elements[s.index].kind} element; "
                             f"{s.kind} is recorded on pipe elements")
        return "elements", s.index, 0, _IDENTITY
    if s.kind == "energy":
        return ("elements" if elements is not None else "bodies"), 0, 0, _IDENTITY
    if s.kind == "spring_force" and s.part == "couplings":
        if coupled is None:
            raise ValueError(f"sensor {label!r}: this run is of {what}, which has no couplings")
        n = len(_spring_kinds(model, "couplings"))
        if s.index >= n:
            raise ValueError(f"sensor {label!r}: spring {s.index} is not in the couplings ({n} springs)")
        if s.component is not None:
            raise ValueError(f"sensor {label!r}: a coupling spring is axial: its one value is the tension "
                             "(component=None)")
        return "couplings", len(coupled.joints) + s.index, 0, _IDENTITY  # the springs follow the joints
    if s.kind == "spring_force":
        on_bodies = s.part == "bodies" or elements is None
        if on_bodies and bodies is None:
            raise ValueError(f"sensor {label!r}: this run is of {what}, which has no bodies' springs")
        kinds = _spring_kinds(model, s.part)
        if s.index >= len(kinds):
            where = "the bodies" if on_bodies and elements is not None else "the model"
            raise ValueError(f"sensor {label!r}: spring {s.index} is not in {where} ({len(kinds)} springs)")
        if s.component is not None and kinds[s.index] == "axial":
            raise ValueError(f"sensor {label!r}: spring {s.index} is axial: its one value is the tension "
                             "(component=None)")
        return ("bodies" if on_bodies else "elements"), s.index, 0, _IDENTITY
    if s.kind == "joint_force":
        if s.part == "couplings":
            if coupled is None:
                raise ValueError(f"sensor {label!r}: this run is of {what}, which has no couplings")
            joints = coupled.joints
            if s.index >= len(joints):
                raise ValueError(f"sensor {label!r}: coupling {s.index} is not in the system "
                                 f"({len(joints)} coupling joints)")
            sizes = {"rigid": 6, "hinge": 5, "spherical": 3}  # CoupledSystem.n_constraints
            rows = [3 if coupled._ancf(c.node) else sizes[c.kind] for c in joints]
            first, n, part = int(sum(rows[:s.index])), rows[s.index], "couplings"
        else:
            if bodies is None:
                raise ValueError(f"sensor {label!r}: an element model has no joints (its supports are eliminated "
                                 "from the coordinates); joint_force is a system of bodies' (pipeflex.multibody)")
            jr = bodies.joint_rows
            if s.index >= len(jr) - 1:
                raise ValueError(f"sensor {label!r}: joint {s.index} is not in the system "
                                 f"(joints 0..{len(jr) - 2})")
            first, n, part = int(jr[s.index]), int(jr[s.index + 1] - jr[s.index]), "bodies"
        if s.component is not None and s.component >= n:
            raise ValueError(f"sensor {label!r}: joint {s.index} has {n} rows: component 0..{n - 1}")
        return part, (first, n), 0, _IDENTITY
    raise ValueError(f"sensor {label!r}: unknown kind {s.kind!r}")


def collect(log, entries) -> Tuple[Dict[str, tuple], dict]:
    """``result.sensors`` (label -> (t, values) or, for a crossing, (times, signs)) and
    their descriptions for the metadata (units, components)."""
    t = np.asarray(log.t, dtype=float)
    out, info = {}, {}
    for label, what, k, component, units, names in entries:
        if what == "crossing":
            times, signs = log.crossings(k)
            out[label] = (np.asarray(times, float), np.asarray(signs, dtype=np.int64))
            info[label] = {"kind": "crossing", "units": "s"}
            continue
        values = log.values(k)
        if component is not None or values.shape[1] == 1:
            c = 0 if component is None else component
            values = np.ascontiguousarray(values[:, c])
            unit = units if isinstance(units, str) else units[c]
            info[label] = {"kind": "sensor", "units": unit}
        else:
            info[label] = {"kind": "sensor", "units": units if isinstance(units, str) else list(units),
                           "components": list(names)}
        out[label] = (t.copy(), values)
    return out, info
