"""Model files: an element model, a system of floating-frame bodies or a coupled system as
YAML or JSON, read by :func:`load_model` and written by :func:`save_model`. The schema is
in ``docs/model_files.md``.

A model file is the list of :class:`~pipeflex.ModelBuilder` calls that make the model,
grouped by kind: the loader makes a builder, calls it entry by entry and builds; the
builder stays the one way to build a model (every rule it checks holds for a file too).
Saving writes the calls the builder recorded (the model's recipe) and reads the text back
to check that it builds the same model (node positions, element data, supports, loads
and springs equal to the last bit), so a saved file always reproduces its model. The
writing half (the file's content and text) is :mod:`pipeflex.model_writer`, which the
models' own ``save`` methods use.

A file of ``kind: multibody`` is likewise the calls of
:class:`~pipeflex.multibody.MultibodyBuilder` (bodies made by
:func:`~pipeflex.multibody.flexible_body`, placed, joined and loaded); saving writes the
description that builder kept (bodies by their arguments, placements as position and
rotation, joints, loads with their time functions). A ``kind: coupled`` file holds an
element model, a system of bodies and the couplings of a :class:`~pipeflex.CoupledSystem`.

Errors in a file are :class:`ModelFileError` (a ValueError) naming the file, the line and
the key, e.g. ``frame.yaml, line 12, geometry[2].line.n_elements: must be an integer
>= 1, got -3``.
"""
from __future__ import annotations

import difflib
import inspect
import json
import math
from pathlib import Path
from typing import Optional, Union

import numpy as np

from .model import Model, ModelBuilder
from .model_writer import (DISTRIBUTED_LOAD, FORMAT_VERSION, GEOMETRY, HUB, LOAD, MASS, RAYLEIGH, SPRINGS, SUFFIXES,
                           SUPPORTS, _checked_path, _coupled_difference, _difference, _dumps, _multibody_difference,
                           coupled_data, model_data, multibody_data)
from .sections import PipeSection
from .time_functions import Pulse, Sine, time_function

# The kinds of value a key takes (checked before the builder sees them; the builder
# then checks its own rules: unit vectors, lengths, ...).
_KIND_TEXT = {"point": "3 numbers", "number": "a number", "nonneg": "a number >= 0", "positive": "a number > 0",
              "count": "an integer >= 1", "node": "a node index", "bool": "true or false",
              "section": "the name of a section", "components": "a component name or a list of them",
              "nonneg3": "3 numbers >= 0", "node_or_point": "a node index or 3 numbers",
              "elastic": "'A' or '0'", "nodes": "a list of node indices", "index": "a body index (an integer >= 0)",
              "body_node": "a node index or one of 'start', 'center', 'end'", "count0": "an integer >= 0",
              "text": "a text", "damping": "a number >= 0 or a list of them", "matrix": "3 rows of 3 numbers",
              "time_function": "a time function: a number, {table: {times, values}}, {sine: {omega, envelope, "
                               "phase, mean}} or {pulse: {start, duration, shape, amplitude}}",
              "time_functions": "3 time functions",
              "elements": "a pipe element index or a list of them (integers >= 0)"}

SECTION = {"EI": "positive", "pipe_mass": "nonneg", "fluid_mass": "nonneg", "EIz": "positive", "EA": "positive",
           "GJ": "positive", "GAy": "positive", "GAz": "positive", "kv": "positive", "rotary_inertia": "nonneg3",
           "eta_bending": "nonneg", "eta_torsion": "nonneg", "eta_axial": "nonneg", "c_ext": "nonneg",
           "k_found": "nonneg", "outer_diameter": "positive"}
TUBE = {"outer_diameter": "positive", "inner_diameter": "nonneg", "E": "positive", "G": "positive",
        "density": "positive", "fluid_density": "nonneg", "kv": "positive", "shear": "bool",
        "rotary_inertia": "bool", "fluid_bulk_modulus": "positive"}
FLOW = {"mass_flow": "number", "reservoir_inlets": "nodes"}
TOP = ("pipeflex_model", "kind", "info", "sections", "geometry", "supports", "hub", "springs", "masses", "loads",
       "distributed_loads", "flow", "gravity", "rayleigh_damping", "floating")
_REQUIRED_TOP = ("geometry",)
#: The file's ``kind``: what :func:`load_model` returns.
KINDS = ("elements", "multibody", "coupled")

# -- systems of floating-frame bodies (kind: multibody) --
#: flexible_body's arguments
BODY = {"length": "positive", "n_elements": "count", "section": "section", "internal_modes": "count0",
        "reduction": "text", "curvature": "number", "modal_damping": "damping", "fluid_lever_arm": "text"}
#: an assembly entry: add_body (position, rotation) or add_body_between (start, end, up)
PLACEMENT = {"body": "text", "position": "point", "rotation": "matrix", "start": "point", "end": "point",
             "up": "point", "flow_factor": "number"}
JOINTS = {
    "fix": ("fix", {"body": "index", "node": "body_node"}, None),
    "rigid": ("rigid", {"body_a": "index", "node_a": "body_node", "body_b": "index", "node_b": "body_node"}, None),
    "hinge": ("hinge", {"body_a": "index", "node_a": "body_node", "axis": "point", "body_b": "index",
                        "node_b": "body_node", "torque": "time_function"}, None),
    "spherical": ("spherical", {"body_a": "index", "node_a": "body_node", "body_b": "index",
                                "node_b": "body_node"}, None),
    "roller": ("roller", {"body": "index", "node": "body_node", "direction": "point"}, None),
}
BODY_LOAD = ("add_load", {"body": "index", "node": "body_node", "force": "time_functions",
                          "moment": "time_functions"}, None)
BODY_DISTRIBUTED_LOAD = ("add_distributed_load", {"body": "index", "force_per_length": "point",
                                                  "time_function": "time_function"}, None)
_SIX = {"stiffness": "nonneg3", "damping": "nonneg3", "rotational_stiffness": "nonneg3",
        "rotational_damping": "nonneg3"}
#: MultibodyBuilder's spring-dampers: axial, ground, bushing (the builder's dict keys of each)
BODY_SPRINGS = {
    "axial": ("add_spring", {"body_a": "index", "node_a": "body_node", "body_b": "index", "node_b": "body_node",
                             "stiffness": "nonneg", "damping": "nonneg"}, None),
    "ground": ("add_ground_spring", {"body": "index", "node": "body_node", "anchor": "point", **_SIX}, None),
    "bushing": ("add_bushing", {"body_a": "index", "node_a": "body_node", "body_b": "index", "node_b": "body_node",
                                **_SIX}, None),
}
BODY_FLOW = {"mass_flow": "number", "junction_forces": "bool"}
TOP_MULTIBODY = ("pipeflex_model", "kind", "info", "sections", "bodies", "assembly", "joints", "springs", "loads",
                 "distributed_loads", "gravity", "flow")
# -- an element model joined to bodies (kind: coupled) --
COUPLINGS = {"rigid": {"node": "node", "body": "index", "body_node": "body_node"},
             "hinge": {"node": "node", "body": "index", "body_node": "body_node", "axis": "point"},
             "spherical": {"node": "node", "body": "index", "body_node": "body_node"},
             "axial": {"node": "node", "body": "index", "body_node": "body_node", "stiffness": "nonneg",
                       "damping": "nonneg"},
             "bushing": {"node": "node", "body": "index", "body_node": "body_node", **_SIX}}
#: the CoupledSystem method of each coupling kind (the joints': the kind's name)
_COUPLING_METHODS = {"axial": "add_spring", "bushing": "add_bushing"}
TOP_COUPLED = ("pipeflex_model", "kind", "elements", "bodies", "couplings")
#: a time function's kinds (a bare number is a constant)
TIME_FUNCTIONS = {"table": {"times": "numbers", "values": "numbers"},
                  "sine": {"omega": "positive", "envelope": "envelope", "phase": "number", "mean": "number"},
                  "pulse": {"start": "number", "duration": "positive", "shape": "text", "amplitude": "number"}}


class ModelFileError(ValueError):
    """A model file that cannot be read: ``path``, ``line`` (1-based, None if unknown)
    and ``key`` (the entry's path in the file, e.g. ``geometry[2].line.n_elements``)."""

    def __init__(self, message: str, *, path=None, line: Optional[int] = None, key: Optional[str] = None):
        where = ", ".join(x for x in (str(path) if path is not None else None,
                                      f"line {line}" if line is not None else None, key) if x)
        super().__init__(f"{where}: {message}" if where else message)
        self.path, self.line, self.key = path, line, key


# -- reading ------------------------------------------------------------------------


class _Reader:
    """The parsed file (plain Python values) and the line of every key, by its path."""

    def __init__(self, path: Path):
        self.path = path
        self.lines: dict = {}
        text = path.read_text(encoding="utf-8")
        try:
            self.data = self._parse_yaml(text)
        except ImportError:
            if path.suffix.lower() != ".json":
                raise ImportError("reading a YAML model file needs PyYAML: apt install python3-yaml (or pip install "
                                  "pyyaml), or use a .json model file") from None
            self._json(text)
        except ModelFileError:
            raise
        except Exception as exc:  # noqa: BLE001 (yaml's errors carry their own line)
            if path.suffix.lower() == ".json":  # JSON that YAML's 1.1 parser cannot read: without lines
                self._json(text)
                return
            mark = getattr(exc, "problem_mark", None)
            raise ModelFileError(f"not valid YAML: {getattr(exc, 'problem', None) or exc}", path=path,
                                 line=None if mark is None else mark.line + 1) from None

    def _json(self, text: str) -> None:
        try:
            self.data = json.loads(text)
        except json.JSONDecodeError as exc:
            raise ModelFileError(f"not valid JSON: {exc.msg}", path=self.path, line=exc.lineno) from None

    def _parse_yaml(self, text: str):
        import yaml

        loader = yaml.SafeLoader(text)
        try:
            node = loader.get_single_node()
            if node is None:
                raise ModelFileError("the file is empty", path=self.path)
            return self._walk(loader, node, ())
        finally:
            loader.dispose()

    def _walk(self, loader, node, where: tuple):
        import yaml

        self.lines.setdefault(where, node.start_mark.line + 1)
        if isinstance(node, yaml.MappingNode):
            out = {}
            for k, v in node.value:
                key = loader.construct_object(k)
                if not isinstance(key, str):
                    raise ModelFileError(f"keys must be names, got {key!r}", path=self.path,
                                         line=k.start_mark.line + 1, key=_text(where))
                if key in out:
                    raise ModelFileError(f"the key {key!r} appears twice", path=self.path,
                                         line=k.start_mark.line + 1, key=_text(where + (key,)))
                self.lines[where + (key,)] = k.start_mark.line + 1
                out[key] = self._walk(loader, v, where + (key,))
            return out
        if isinstance(node, yaml.SequenceNode):
            return [self._walk(loader, v, where + (i,)) for i, v in enumerate(node.value)]
        return loader.construct_object(node, deep=True)

    def line(self, where: tuple) -> Optional[int]:
        while where and where not in self.lines:
            where = where[:-1]
        return self.lines.get(where)

    def error(self, where: tuple, message: str) -> ModelFileError:
        return ModelFileError(message, path=self.path, line=self.line(where), key=_text(where) or None)


class _View:
    """A part of the file (e.g. a coupled file's ``elements``) read as a file of its own:
    its keys' paths and lines are those of the whole file."""

    def __init__(self, reader, prefix: tuple, data):
        self.reader, self.prefix, self.data = reader, prefix, data
        self.path = reader.path

    def line(self, where: tuple) -> Optional[int]:
        return self.reader.line(self.prefix + where)

    def error(self, where: tuple, message: str) -> ModelFileError:
        return self.reader.error(self.prefix + where, message)


def _text(where: tuple) -> str:
    """``geometry[2].line.n_elements`` for the path ("geometry", 2, "line", "n_elements")."""
    out = ""
    for part in where:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else part)
    return out


def _unknown_key(key: str, valid) -> str:
    close = difflib.get_close_matches(key, list(valid), n=1, cutoff=0.5)
    hint = f"did you mean {close[0]!r}?" if close else f"valid keys: {', '.join(valid)}"
    return f"unknown key {key!r} ({hint})"


def _number(r: _Reader, where: tuple, value) -> float:
    # YAML 1.1 reads 1e10 (no dot) as text: accept text that is a number
    if isinstance(value, str):
        try:
            value = float(value)
        except ValueError:
            pass
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise r.error(where, f"must be a number, got {value!r}")
    if not math.isfinite(value):
        raise r.error(where, f"must be finite, got {value!r}")
    return float(value)


def _value(r: _Reader, where: tuple, kind: str, value, b: Optional[ModelBuilder], sections: dict):
    """The builder's argument for ``value`` of ``kind``, or ModelFileError naming the key."""
    def bad(rule=None):
        return r.error(where, f"must be {rule or _KIND_TEXT[kind]}, got {value!r}")

    if kind in ("number", "nonneg", "positive"):
        x = _number(r, where, value)
        if (kind == "nonneg" and x < 0) or (kind == "positive" and x <= 0):
            raise r.error(where, f"must be {_KIND_TEXT[kind]}, got {x:g}")
        return x
    if kind in ("point", "nonneg3"):
        if not isinstance(value, list) or len(value) != 3:
            raise bad()
        return tuple(_value(r, where + (i,), "nonneg" if kind == "nonneg3" else "number", v, b, sections)
                     for i, v in enumerate(value))
    if kind == "count":
        if isinstance(value, bool) or not isinstance(value, int) or value < 1:
            raise bad()
        return value
    if kind == "node":
        if isinstance(value, bool) or not isinstance(value, int):
            raise bad()
        if not isinstance(b, ModelBuilder):  # a coupling's element node: the coupled system checks it
            if value < 0:
                raise bad()
            return value
        n = len(b._positions)
        if not 0 <= value < n:
            raise r.error(where, f"unknown node {value}: the model has nodes 0..{n - 1} at this entry (nodes are "
                                 f"numbered in the order the geometry entries make them)")
        return value
    if kind == "nodes":
        if not isinstance(value, list):
            raise bad()
        return [_value(r, where + (i,), "node", v, b, sections) for i, v in enumerate(value)]
    if kind == "node_or_point":
        return _value(r, where, "node" if isinstance(value, int) and not isinstance(value, bool) else "point", value,
                      b, sections)
    if kind == "bool":
        if not isinstance(value, bool):
            raise bad()
        return value
    if kind == "section":
        if not isinstance(value, str):
            raise bad()
        if value not in sections:
            close = difflib.get_close_matches(value, list(sections), n=1, cutoff=0.5)
            raise r.error(where, f"unknown section {value!r}" + (f" (did you mean {close[0]!r}?)" if close else
                                                                 f" (the file's sections: {', '.join(sections)})"
                                                                 if sections else " (the file has no sections)"))
        return sections[value]
    if kind == "components":
        names = [value] if isinstance(value, str) else value
        if not isinstance(names, list) or not all(isinstance(c, str) for c in names):
            raise bad()
        return value if isinstance(value, str) else tuple(names)
    if kind in ("index", "count0"):
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            raise bad()
        return value
    if kind == "elements":  # the builder checks the range
        if isinstance(value, list):
            return [_value(r, where + (i,), "index", v, b, sections) for i, v in enumerate(value)]
        return _value(r, where, "index", value, b, sections)
    if kind == "body_node":
        if value in ("start", "center", "end") or (isinstance(value, int) and not isinstance(value, bool)
                                                   and value >= 0):
            return value
        raise bad()
    if kind == "text":
        if not isinstance(value, str):
            raise bad()
        return value
    if kind == "damping":
        if isinstance(value, list):
            return [_value(r, where + (i,), "nonneg", v, b, sections) for i, v in enumerate(value)]
        return _value(r, where, "nonneg", value, b, sections)
    if kind == "matrix":
        if not isinstance(value, list) or len(value) != 3:
            raise bad()
        return np.array([_value(r, where + (i,), "point", v, b, sections) for i, v in enumerate(value)])
    if kind == "time_function":
        return _time_function(r, where, value)
    if kind == "time_functions":
        if not isinstance(value, list) or len(value) != 3:
            raise bad()
        return tuple(_time_function(r, where + (i,), v) for i, v in enumerate(value))
    if kind == "elastic":
        if value in ("A", "0") or (type(value) is int and value == 0):  # YAML reads a bare 0 as a number
            return str(value)
        raise bad()
    raise AssertionError(kind)


def _time_function(r: _Reader, where: tuple, value, *, envelope: bool = False):
    """A time function from the file: a number, or one of {table: {times, values}},
    {sine: {...}}, {pulse: {...}} (a sine's envelope: a number or a table)."""
    kinds = {"table": TIME_FUNCTIONS["table"]} if envelope else TIME_FUNCTIONS
    rule = "a number or {table: {times, values}}" if envelope else _KIND_TEXT["time_function"]
    if not isinstance(value, dict):
        if isinstance(value, (list, bool)) or value is None:
            raise r.error(where, f"must be {rule}, got {value!r}")
        return _number(r, where, value)
    if len(value) != 1:
        raise r.error(where, f"must be {rule} (one key), got {value!r}")
    (kind, fields), = value.items()
    if kind not in kinds:
        raise r.error(where + (kind,), _unknown_key(kind, kinds))
    inner = where + (kind,)
    fields = _mapping(r, inner, fields)
    spec = kinds[kind]
    for key in fields:
        if key not in spec:
            raise r.error(inner + (key,), _unknown_key(key, spec))
    required = {"table": ("times", "values"), "sine": ("omega",), "pulse": ("start", "duration")}[kind]
    for key in required:
        if key not in fields:
            raise r.error(inner, f"missing required key {key!r}")
    args = {}
    for key, v in fields.items():
        at = inner + (key,)
        if spec[key] == "numbers":
            args[key] = tuple(_number(r, at + (i,), x) for i, x in enumerate(_listing(r, at, v)))
        elif spec[key] == "envelope":
            args[key] = _time_function(r, at, v, envelope=True)
        else:
            args[key] = _value(r, at, spec[key], v, None, {})
    f = (args["times"], args["values"]) if kind == "table" else (Sine if kind == "sine" else Pulse)(**args)
    try:
        time_function(_text(where), f)
    except (ValueError, TypeError) as exc:
        raise r.error(where, str(exc)) from None
    return f


def _arguments(r: _Reader, where: tuple, value, spec, b, sections: dict) -> dict:
    """The keyword arguments of the builder call ``spec`` from the file's ``value`` (a
    mapping, or the shorthand's bare value); required keys are the builder's."""
    method, fields, shorthand = spec
    if not isinstance(value, dict):
        if shorthand is None:
            raise r.error(where, f"must be a mapping of {', '.join(fields)}, got {value!r}")
        value = {shorthand: value}
    for key in value:
        if key not in fields:
            raise r.error(where + (key,), _unknown_key(key, fields))
    params = inspect.signature(getattr(type(b), method)).parameters
    for name, p in params.items():
        if name != "self" and p.default is inspect.Parameter.empty and p.kind is not p.VAR_KEYWORD \
                and name not in value:
            raise r.error(where, f"missing required key {name!r}")
    return {key: _value(r, where + (key,), fields[key], v, b, sections) for key, v in value.items()}


def _call(r: _Reader, where: tuple, b, method: str, kwargs: dict):
    try:
        return getattr(b, method)(**kwargs)
    except (ValueError, TypeError) as exc:
        raise r.error(where, str(exc)) from None


def _mapping(r: _Reader, where: tuple, value) -> dict:
    if not isinstance(value, dict):
        raise r.error(where, f"must be a mapping, got {value!r}")
    return value


def _listing(r: _Reader, where: tuple, value) -> list:
    if not isinstance(value, list):
        raise r.error(where, f"must be a list, got {value!r}")
    return value


def _sections(r: _Reader, data) -> dict:
    out = {}
    for name, fields in _mapping(r, ("sections",), data).items():
        where = ("sections", name)
        fields = _mapping(r, where, fields)
        tube = "tube" in fields
        if tube and len(fields) > 1:
            raise r.error(where, "a section is either {tube: {...}} or its fields, not both")
        spec = TUBE if tube else SECTION
        values = _mapping(r, where + ("tube",), fields["tube"]) if tube else fields
        inner = where + ("tube",) if tube else where
        for key in values:
            if key not in spec:
                raise r.error(inner + (key,), _unknown_key(key, spec if tube else list(SECTION) + ["tube"]))
        factory = PipeSection.tube if tube else PipeSection
        for pname, p in inspect.signature(factory).parameters.items():
            if p.default is inspect.Parameter.empty and pname not in values:
                raise r.error(inner, f"missing required key {pname!r}")
        kwargs = {k: _value(r, inner + (k,), spec[k], v, None, {}) for k, v in values.items()}
        try:
            out[name] = factory(**kwargs)
        except (ValueError, TypeError) as exc:
            raise r.error(inner, str(exc)) from None
    return out


def _entries(r: _Reader, data, key: str, kinds: dict, b, sections: dict) -> None:
    """A list of one-key mappings ``- kind: {...}`` (geometry, supports, springs)."""
    for i, entry in enumerate(_listing(r, (key,), data)):
        where = (key, i)
        if not isinstance(entry, dict) or len(entry) != 1:
            raise r.error(where, f"each entry is one of {', '.join(kinds)} with its keys, e.g. "
                                 f"'- {next(iter(kinds))}: ...', got {entry!r}")
        (kind, value), = entry.items()
        if kind not in kinds:
            raise r.error(where + (kind,), _unknown_key(kind, kinds) + f" in {key}")
        spec = kinds[kind]
        _call(r, where + (kind,), b, spec[0], _arguments(r, where + (kind,), value, spec, b, sections))


def _top(r: _Reader, keys: tuple, required: tuple, kind: str) -> dict:
    """The file's (or part's) mapping, its keys checked against ``keys``."""
    data = r.data
    if not isinstance(data, dict):
        raise r.error((), f"a model file of kind {kind} is a mapping of {', '.join(keys)}, got "
                          f"{type(data).__name__}")
    for key in data:
        if key not in keys:
            raise r.error((key,), _unknown_key(key, keys))
    if data.get("kind", kind) != kind:
        raise r.error(("kind",), f"must be {kind!r} here, got {data['kind']!r}")
    for key in required:
        if key not in data:
            raise r.error((), f"missing required key {key!r}")
    version = data.get("pipeflex_model", FORMAT_VERSION)
    if version != FORMAT_VERSION:
        raise r.error(("pipeflex_model",), f"this pipeflex reads model files of version {FORMAT_VERSION}, got "
                                           f"{version!r}")
    return data


def _from(r: _Reader):
    """What the file describes, by its ``kind``."""
    kind = r.data.get("kind", "elements") if isinstance(r.data, dict) else "elements"
    if kind not in KINDS:
        close = difflib.get_close_matches(str(kind), KINDS, n=1, cutoff=0.5)
        raise r.error(("kind",), f"must be one of {', '.join(KINDS)}, got {kind!r}"
                                 + (f" (did you mean {close[0]!r}?)" if close else ""))
    return {"elements": _model_from, "multibody": _multibody_from, "coupled": _coupled_from}[kind](r)


def _model_from(r: _Reader) -> Model:
    data = _top(r, TOP, _REQUIRED_TOP, "elements")
    sections = _sections(r, data.get("sections", {}))
    b = ModelBuilder()
    _entries(r, data["geometry"], "geometry", GEOMETRY, b, sections)
    flow = _mapping(r, ("flow",), data.get("flow", {}))
    for key in flow:
        if key not in FLOW:
            raise r.error(("flow", key), _unknown_key(key, FLOW))
    for i, node in enumerate(_value(r, ("flow", "reservoir_inlets"), "nodes", flow.get("reservoir_inlets", []), b,
                                    sections)):
        _call(r, ("flow", "reservoir_inlets", i), b, "reservoir_inlet", dict(node=node))
    _entries(r, data.get("supports", []), "supports", SUPPORTS, b, sections)
    hubs = data.get("hub", [])
    for i, hub in enumerate(hubs if isinstance(hubs, list) else [hubs]):
        where = ("hub", i) if isinstance(hubs, list) else ("hub",)
        _call(r, where, b, HUB[0], _arguments(r, where, hub, HUB, b, sections))
    _entries(r, data.get("springs", []), "springs", SPRINGS, b, sections)
    for key, spec in (("masses", MASS), ("loads", LOAD), ("distributed_loads", DISTRIBUTED_LOAD)):
        for i, entry in enumerate(_listing(r, (key,), data.get(key, []))):
            _call(r, (key, i), b, spec[0], _arguments(r, (key, i), entry, spec, b, sections))
    if "rayleigh_damping" in data:
        where = ("rayleigh_damping",)
        _call(r, where, b, RAYLEIGH[0], _arguments(r, where, data["rayleigh_damping"], RAYLEIGH, b, sections))
    if "gravity" in data:
        _call(r, ("gravity",), b, "set_gravity", dict(g=_value(r, ("gravity",), "point", data["gravity"], b,
                                                                sections)))
    floating = _value(r, ("floating",), "bool", data.get("floating", False), b, sections)
    mass_flow = _value(r, ("flow", "mass_flow"), "number", flow.get("mass_flow", 0.0), b, sections)
    try:
        model = b.build(mass_flow=mass_flow, floating=floating)
    except (ValueError, TypeError) as exc:
        raise ModelFileError(str(exc), path=r.path) from None
    model.info.update(_mapping(r, ("info",), data.get("info", {})))
    return model


def _keys(r: _Reader, where: tuple, value, spec: dict, required=()) -> dict:
    value = _mapping(r, where, value)
    for key in value:
        if key not in spec:
            raise r.error(where + (key,), _unknown_key(key, spec))
    for key in required:
        if key not in value:
            raise r.error(where, f"missing required key {key!r}")
    return value


def _multibody_from(r: _Reader):
    from .multibody import MultibodyBuilder, flexible_body

    data = _top(r, TOP_MULTIBODY, ("bodies", "assembly", "joints"), "multibody")
    sections = _sections(r, data.get("sections", {}))
    required = [n for n, p in inspect.signature(flexible_body).parameters.items() if p.default is p.empty]
    bodies = {}
    for name, fields in _mapping(r, ("bodies",), data["bodies"]).items():
        where = ("bodies", name)
        fields = _keys(r, where, fields, BODY, required)
        kwargs = {k: _value(r, where + (k,), BODY[k], v, None, sections) for k, v in fields.items()}
        try:
            bodies[name] = flexible_body(**kwargs)
        except (ValueError, TypeError) as exc:
            raise r.error(where, str(exc)) from None
    b = MultibodyBuilder()
    for i, entry in enumerate(_listing(r, ("assembly",), data["assembly"])):
        where = ("assembly", i)
        entry = _keys(r, where, entry, PLACEMENT, ("body",))
        name = _value(r, where + ("body",), "text", entry["body"], None, {})
        if name not in bodies:
            close = difflib.get_close_matches(name, list(bodies), n=1, cutoff=0.5)
            raise r.error(where + ("body",), f"unknown body {name!r}" + (
                f" (did you mean {close[0]!r}?)" if close else f" (the file's bodies: {', '.join(bodies)})"))
        kwargs = {k: _value(r, where + (k,), PLACEMENT[k], v, b, sections) for k, v in entry.items() if k != "body"}
        between = "start" in entry or "end" in entry
        if between:
            for key in ("position", "rotation"):
                if key in entry:
                    raise r.error(where + (key,), "a body is placed by position (and rotation) or by start and end "
                                                  "(and up), not both")
            for key in ("start", "end"):
                if key not in entry:
                    raise r.error(where, f"missing required key {key!r} (placed by start and end)")
        elif "position" not in entry:
            raise r.error(where, "missing required key 'position' (or place the body by start and end)")
        elif "up" in entry:
            raise r.error(where + ("up",), "up goes with start and end (a body placed by position takes rotation)")
        _call(r, where, b, "add_body_between" if between else "add_body", dict(body=bodies[name], **kwargs))
    _entries(r, data["joints"], "joints", JOINTS, b, sections)
    _entries(r, data.get("springs", []), "springs", BODY_SPRINGS, b, sections)
    for i, entry in enumerate(_listing(r, ("loads",), data.get("loads", []))):
        _call(r, ("loads", i), b, BODY_LOAD[0], _arguments(r, ("loads", i), entry, BODY_LOAD, b, sections))
    for i, entry in enumerate(_listing(r, ("distributed_loads",), data.get("distributed_loads", []))):
        where = ("distributed_loads", i)
        _call(r, where, b, BODY_DISTRIBUTED_LOAD[0], _arguments(r, where, entry, BODY_DISTRIBUTED_LOAD, b, sections))
    if "gravity" in data:
        _call(r, ("gravity",), b, "set_gravity", dict(g=_value(r, ("gravity",), "point", data["gravity"], b,
                                                                sections)))
    flow = _keys(r, ("flow",), data.get("flow", {}), BODY_FLOW)
    options = {k: _value(r, ("flow", k), BODY_FLOW[k], v, b, sections) for k, v in flow.items()}
    try:
        system = b.build(**options)
    except (ValueError, TypeError) as exc:
        raise ModelFileError(str(exc), path=r.path) from None
    system.info.update(_mapping(r, ("info",), data.get("info", {})))
    return system


def _coupled_from(r: _Reader):
    from .coupled import CoupledSystem

    data = _top(r, TOP_COUPLED, ("elements", "bodies"), "coupled")
    model = _model_from(_View(r, ("elements",), _mapping(r, ("elements",), data["elements"])))
    bodies = _multibody_from(_View(r, ("bodies",), _mapping(r, ("bodies",), data["bodies"])))
    system = CoupledSystem(model, bodies)
    kinds = {k: (_COUPLING_METHODS.get(k, k), fields, None) for k, fields in COUPLINGS.items()}
    _entries(r, data.get("couplings", []), "couplings", kinds, system, {})
    return system


def load_model(path: Union[str, Path]):
    """The model described by the model file ``path`` (``.yaml``, ``.yml`` or ``.json``;
    schema in ``docs/model_files.md``): by the file's ``kind``, a :class:`~pipeflex.Model`
    built by :class:`~pipeflex.ModelBuilder` (``elements``, the default), a
    :class:`~pipeflex.multibody.MultibodySystem` built by
    :class:`~pipeflex.multibody.MultibodyBuilder` (``multibody``) or a
    :class:`~pipeflex.CoupledSystem` (``coupled``).

    Args:
        path: the file [-].

    Raises:
        ModelFileError: (a ValueError) a file the schema or the builder refuses, naming the
            file, the line and the key: unknown key (with the closest valid one), wrong
            type, negative stiffness, unknown node or section, missing required key, or
            the builder's own rule.
    """
    return _from(_Reader(_checked_path(path, reading=True)))


def _data_and_check(model):
    """(file content, the function naming the first difference of a rebuilt system)."""
    if isinstance(model, Model):
        return model_data(model, ModelBuilder), _difference
    from .multibody import flexible_body
    from .multibody.system import MultibodySystem

    if isinstance(model, MultibodySystem):
        return multibody_data(model, flexible_body), _multibody_difference
    from .coupled import CoupledSystem

    if isinstance(model, CoupledSystem):
        return coupled_data(model, ModelBuilder, flexible_body), _coupled_difference
    raise ValueError(f"model: a model file describes a pipeflex.Model, a pipeflex.multibody.MultibodySystem or a "
                     f"pipeflex.CoupledSystem, got a {type(model).__name__}")


def save_model(model, path: Union[str, Path]) -> Path:
    """Write ``model`` as a model file, YAML (``.yaml``, ``.yml``) or JSON (``.json``) by
    the suffix of ``path``; returns the path. The text is read back before it is written:
    ValueError if it would not build the same model (builder calls whose order a model
    file cannot keep, e.g. a support on a node before a later line re-used it in a way
    that changes its constraints), so a saved file always reproduces the model.

    Args:
        model: a model built by :class:`~pipeflex.ModelBuilder`, a
            :class:`~pipeflex.multibody.MultibodySystem` built by
            :class:`~pipeflex.multibody.MultibodyBuilder` (``kind: multibody``) or a
            :class:`~pipeflex.CoupledSystem` of the two (``kind: coupled``).
        path: the file to write [-]; its folder must exist.

    Raises:
        ValueError: what a file cannot hold (a Python callable as a load or time function,
            a body with a custom basis, a free model), or a file that would not rebuild
            the model exactly.
    """
    p = _checked_path(path, reading=False)
    if p.is_dir():
        raise ValueError(f"path {str(p)!r} is a folder; give a file name ending in {', '.join(SUFFIXES)}")
    data, difference = _data_and_check(model)
    text = _dumps(data, p.suffix.lower())
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:  # the check reads the very text written
        probe = Path(tmp) / f"model{p.suffix.lower()}"
        probe.write_text(text, encoding="utf-8")
        try:
            again = load_model(probe)
        except ModelFileError as exc:
            raise ValueError(f"model: its model file would not load back ({exc.key}: {exc}); the builder calls "
                             f"were made in an order the file's grouping cannot keep") from None
    diff = difference(model, again)
    if diff is not None:
        raise ValueError(f"model: its model file would not rebuild it exactly (the {diff} differ): the builder "
                         f"calls were made in an order the file's grouping (geometry, supports, hub, springs, "
                         f"masses, loads) cannot keep")
    p.write_text(text, encoding="utf-8")
    return p
