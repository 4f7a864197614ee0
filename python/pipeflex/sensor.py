"""Sensors: quantities recorded at every accepted step of ``simulate``, and crossing (event)
sensors.

``pf.simulate(model, t_end, sensors=[...])`` records each sensor at the start and at the
end of every step the integrator accepts (generalised-alpha, fixed step or ``rtol``, and
IDA), inside the C++ time loop: no Python call per step. The results are in
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

Sensors are recorded on element models (:class:`~pipeflex.Model`); on a system of
floating-frame bodies (:class:`~pipeflex.multibody.MultibodySystem`) :func:`joint_force`
(its joints' multipliers); otherwise (an element sensor on bodies, a joint force of an
element model, a coupled system) ValueError names the sensor and the system kind.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import _checks

__all__ = ["Sensor", "Crossing", "node_position", "node_velocity", "node_acceleration", "node_rotation", "strain",
           "section_force", "spring_force", "joint_force", "energy", "crossing"]

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
}
_DIRECTIONS = {"up": 1, "down": -1, "both": 0}


@dataclass(frozen=True)
class Sensor:
    """A sensor of :func:`~pipeflex.simulate` (build it with this module's functions).

    Attributes:
        kind: ``"node_position"``, ``"node_velocity"``, ``"node_acceleration"``,
            ``"node_rotation"``, ``"node_angle"``, ``"energy"``, ``"strain"``,
            ``"section_force"``, ``"spring_force"`` or ``"joint_force"``.
        index: the node, element, spring or joint [-] (0 for ``energy``).
        component: index of the one component recorded, or None (all).
        s: [-] local coordinate along the element in [0, 1] (strain, section_force).
        axis: (3,) unit axis of ``node_angle``, else None.
        name: the result's key (None: the default name).
    """

    kind: str
    index: int = 0
    component: Optional[int] = None
    s: float = 0.0
    axis: Optional[Tuple[float, float, float]] = None
    name: Optional[str] = None

    def components(self, model=None) -> Tuple[str, ...]:
        """The names of all the sensor's components (``model``: for a spring's kind)."""
        return _KINDS[self._core_kind(model)][1]

    def _core_kind(self, model=None) -> str:
        if self.kind != "spring_force":
            return self.kind
        if model is None:
            raise ValueError("spring_force: the model decides the spring's kind")
        return {"axial": "axial_spring", "bushing": "bushing"}.get(model.springs[self.index].kind, "ground_spring")

    @property
    def label(self) -> str:
        """The result's key: ``name`` or the default, e.g. ``node_acceleration[4].y``."""
        if self.name is not None:
            return self.name
        where = {"energy": "", "strain": f"[{self.index}](s={self.s:g})",
                 "section_force": f"[{self.index}](s={self.s:g})"}.get(self.kind, f"[{self.index}]")
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


def _node_sensor(kind: str, node: int, component, name: Optional[str]) -> Sensor:
    return Sensor(kind, _index(kind, "node", node), _component(kind, component, _XYZ), name=name)


def node_position(node: int, component: Union[None, str, int] = None, *, name: Optional[str] = None) -> Sensor:
    """x [m] of ``node``: ``component`` ``"x"``, ``"y"``, ``"z"`` (or 0, 1, 2), None: all three."""
    return _node_sensor("node_position", node, component, name)


def node_velocity(node: int, component: Union[None, str, int] = None, *, name: Optional[str] = None) -> Sensor:
    """v [m/s] of ``node`` (``component`` as :func:`node_position`)."""
    return _node_sensor("node_velocity", node, component, name)


def node_acceleration(node: int, component: Union[None, str, int] = None, *, name: Optional[str] = None) -> Sensor:
    """a [m/s^2] of ``node`` (``component`` as :func:`node_position`): the integrator's
    acceleration at each step's end (generalised-alpha's true acceleration, not its
    pseudo-acceleration)."""
    return _node_sensor("node_acceleration", node, component, name)


def node_rotation(node: int, component: Union[None, str, int] = None, *,
                  axis: Optional[Sequence[float]] = None, name: Optional[str] = None) -> Sensor:
    """The rotation of ``node`` from its reference orientation [rad]: the rotation vector
    log(R) (3 components, ``|phi| <= pi``; ``component`` as :func:`node_position`), or with
    ``axis`` (a unit vector, normalised) the angle axis . log(R), unwrapped step by step
    (a continuous angle beyond pi: the rotation about a hinge; exact for a rotation about
    ``axis``)."""
    if axis is None:
        return _node_sensor("node_rotation", node, component, name)
    if component is not None:
        raise ValueError("node_rotation: give either component (of the rotation vector) or axis (an angle)")
    k = tuple(float(a) for a in _checks.unit_vector("axis", axis))
    return Sensor("node_angle", _index("node_rotation", "node", node), None, axis=k, name=name)


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


def spring_force(spring: int, component: Union[None, str, int] = None, *, name: Optional[str] = None) -> Sensor:
    """The force of spring ``spring`` (the index ``add_spring``/``add_ground_spring``
    returned) [N], stiffness and dashpot together: an axial spring's tension (one value),
    a ground spring's force on its node, a bushing's force on its node b (``component``
    as :func:`node_position`)."""
    return Sensor("spring_force", _index("spring_force", "spring", spring),
                  _component("spring_force", component, _XYZ), name=name)


def joint_force(joint: int, component: Optional[int] = None, *, name: Optional[str] = None) -> Sensor:
    """The multipliers of joint ``joint`` of a system of floating-frame bodies (its index
    in the order the builder added the joints), one per constraint row in the joint's
    order (a clamp's ``fix``: 3 force rows [N], then 3 moment rows [N m]; a hinge: 3 and
    2; a spherical joint: 3; a roller: 1): the reactions C_q^T lambda the joint applies,
    as generalised-alpha and IDA carry them (``component``: one row, None: all)."""
    j = _index("joint_force", "joint", joint)
    return Sensor("joint_force", j, None if component is None else _checks.non_negative_int("component", component),
                  name=name)


def energy(component: Union[None, str, int] = None, *, name: Optional[str] = None) -> Sensor:
    """The energies [J]: ``"kinetic"``, ``"elastic"``, ``"gravity_potential"`` and their sum
    ``"total"`` (None: all four)."""
    return Sensor("energy", 0, _component("energy", component, _KINDS["energy"][1]), name=name)


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
    if sensor.component is None and sensor.kind not in ("spring_force", "joint_force") and \
            len(_KINDS[sensor.kind][1]) > 1:
        raise ValueError(f"crossing: sensor {sensor.label!r} records {len(_KINDS[sensor.kind][1])} components: "
                         "choose one (component=)")
    return Crossing(sensor, _checks.finite("level", level), direction, bool(terminal), name)


# -- the run's side (pipeflex.analysis.transient) ------------------------------------------------

def prepare(model, system, sensors) -> Tuple[object, List[tuple]]:
    """The core's SensorLog of ``sensors`` checked against ``model``, and per entry
    (label, kind, core sensor index, component or None, units, component names) to collect
    the results."""
    from . import _core

    items = list(sensors)
    rows = getattr(model, "joint_rows", None)  # a system of bodies
    if system.body_state is not None:
        what = "a system of floating-frame bodies" if rows is not None else "a coupled system (elements and bodies)"
        for s in items:
            base = s.sensor if isinstance(s, Crossing) else s
            if rows is None or not isinstance(base, Sensor) or base.kind != "joint_force":
                label = s.label if isinstance(s, (Sensor, Crossing)) else repr(s)
                raise ValueError(f"sensor {label!r}: this run is of {what}, which records "
                                 f"{'joint_force only' if rows is not None else 'no sensors'} (element sensors: "
                                 "element models, pipeflex.Model)")
    log = _core.SensorLog()
    entries, added, labels = [], {}, set()

    def add(s: Sensor) -> int:
        key = (s.kind, s.index, s.s, s.axis)
        if key in added:
            return added[key]
        if s.kind == "joint_force":
            if rows is None:
                raise ValueError(f"sensor {s.label!r}: an element model has no joints (its supports are eliminated "
                                 "from the coordinates); joint_force is a system of bodies' (pipeflex.multibody)")
            if s.index >= len(rows) - 1:
                raise ValueError(f"sensor {s.label!r}: joint {s.index} is not in the system "
                                 f"(joints 0..{len(rows) - 2})")
            n = int(rows[s.index + 1] - rows[s.index])
            if s.component is not None and s.component >= n:
                raise ValueError(f"sensor {s.label!r}: joint {s.index} has {n} rows: component 0..{n - 1}")
            added[key] = log.add(_KINDS["joint_force"][0], int(rows[s.index]), rows=n)
            return added[key]
        _check(model, s)
        kind = s._core_kind(model)
        element = s.index + (len(model.elements) if s.kind == "spring_force" else 0)
        index = element if kind in ("strain", "section_force", "axial_spring", "ground_spring", "bushing") else s.index
        added[key] = log.add(_KINDS[kind][0], index, s.s, s.axis or (0.0, 0.0, 0.0))
        return added[key]

    for s in items:
        if not isinstance(s, (Sensor, Crossing)):
            raise ValueError(f"sensors: each must be a pipeflex.sensor sensor or crossing, got {s!r}")
        if s.label in labels:
            raise ValueError(f"sensors: two sensors are named {s.label!r} (give one a name=)")
        labels.add(s.label)
        if isinstance(s, Sensor):
            k = add(s)
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


def _check(model, s: Sensor) -> None:
    """ValueError naming the sensor where its node, element or spring is not in the model."""
    if s.kind.startswith("node_"):
        if s.index >= model.n_nodes:
            raise ValueError(f"sensor {s.label!r}: node {s.index} is not in the model (nodes 0..{model.n_nodes - 1})")
        if s.kind == "node_rotation" and s.index in set(model.ancf_nodes):
            raise ValueError(f"sensor {s.label!r}: node {s.index} is an ANCF node (no rotation vector; its slope's "
                             "angle: node_rotation(node, axis=(0, 0, 1)))")
    elif s.kind in ("strain", "section_force"):
        n = len(model.elements)
        if s.index >= n:
            raise ValueError(f"sensor {s.label!r}: element {s.index} is not in the model (elements 0..{n - 1})")
        if model.elements[s.index].kind != "pipe":
            raise ValueError(f"sensor {s.label!r}: element {s.index} is an {model.elements[s.index].kind} element; "
                             f"{s.kind} is recorded on pipe elements")
    elif s.kind == "spring_force":
        n = len(model.springs)
        if s.index >= n:
            raise ValueError(f"sensor {s.label!r}: spring {s.index} is not in the model ({n} springs)")
        if s.component is not None and model.springs[s.index].kind == "axial":
            raise ValueError(f"sensor {s.label!r}: spring {s.index} is axial: its one value is the tension "
                             "(component=None)")


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
