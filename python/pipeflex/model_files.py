"""Model files: an element model as YAML or JSON, read by :func:`load_model` and written by
:func:`save_model`. The schema is in ``docs/model_files.md``.

A model file is the list of :class:`~pipeflex.ModelBuilder` calls that make the model,
grouped by kind: the loader makes a builder, calls it entry by entry and builds; the
builder stays the one way to build a model (every rule it checks holds for a file too).
Saving writes the calls the builder recorded (the model's recipe) and reads the text back
to check that it builds the same model (node positions, element data, supports, loads
and springs equal to the last bit), so a saved file always reproduces its model.

Errors in a file are :class:`ModelFileError` (a ValueError) naming the file, the line and
the key, e.g. ``frame.yaml, line 12, geometry[2].line.n_elements: must be an integer
>= 1, got -3``.
"""
from __future__ import annotations

import dataclasses
import difflib
import inspect
import json
import math
import warnings
from pathlib import Path
from typing import Optional, Union

import numpy as np

from .model import Model, ModelBuilder
from .sections import PipeSection

#: The format's version, the value of the file's ``pipeflex_model`` key.
FORMAT_VERSION = 1
SUFFIXES = (".yaml", ".yml", ".json")

# The kinds of value a key takes (checked before the builder sees them; the builder
# then checks its own rules: unit vectors, lengths, ...).
_KIND_TEXT = {"point": "3 numbers", "number": "a number", "nonneg": "a number >= 0", "positive": "a number > 0",
              "count": "an integer >= 1", "node": "a node index", "bool": "true or false",
              "section": "the name of a section", "components": "a component name or a list of them",
              "nonneg3": "3 numbers >= 0", "node_or_point": "a node index or 3 numbers",
              "elastic": "'A' or '0'", "nodes": "a list of node indices"}

_PIPE_OPTIONS = {"flow_factor": "number", "fluid_end_terms": "bool", "length": "positive"}

#: Each list's entry kinds: key -> (builder method, {key: kind}, shorthand key (a bare
#: value stands for it) or None).
GEOMETRY = {
    "node": ("add_node", {"position": "point"}, "position"),
    "ancf_node": ("add_ancf_node", {"position": "point", "slope": "point"}, None),
    "pipe": ("add_pipe", {"p": "node", "q": "node", "section": "section", "up": "point", "tangent_p": "point",
                          "tangent_q": "point", **_PIPE_OPTIONS}, None),
    "line": ("add_line", {"start": "node", "end": "point", "n_elements": "count", "section": "section",
                          "up": "point", "tangent_p": "point", "tangent_q": "point", **_PIPE_OPTIONS}, None),
    "arc": ("add_arc", {"start": "node", "center": "point", "angle": "number", "normal": "point",
                        "n_elements": "count", "section": "section", **_PIPE_OPTIONS}, None),
    "ancf_beam": ("add_ancf_beam", {"start": "node_or_point", "end": "point", "n_elements": "count",
                                    "section": "section", "elastic": "elastic"}, None),
}
SUPPORTS = {
    "clamp": ("clamp", {"node": "node"}, "node"),
    "pin": ("pin", {"node": "node"}, "node"),
    "fix": ("fix", {"node": "node", "components": "components"}, None),
    "hinge": ("hinge", {"node": "node", "axis": "point"}, None),
    "axial_support": ("axial_support", {"node": "node", "direction": "point"}, None),
    "fix_rotation": ("fix_rotation", {"node": "node", "axis": "point"}, None),
}
SPRINGS = {
    "axial": ("add_spring", {"node_a": "node", "node_b": "node", "stiffness": "nonneg", "damping": "nonneg"}, None),
    "ground": ("add_ground_spring", {"node": "node", "stiffness": "nonneg3", "damping": "nonneg3", "anchor": "point",
                                     "rotational_stiffness": "nonneg3", "rotational_damping": "nonneg3"}, None),
}
HUB = ("rotating_hub", {"node": "node", "omega": "number", "spin_up_time": "nonneg", "center": "point",
                        "axis": "point"}, None)
MASS = ("add_point_mass", {"node": "node", "mass": "nonneg", "inertia": "nonneg3"}, None)
LOAD = ("add_load", {"node": "node", "force": "point", "moment": "point", "follower": "bool"}, None)
SECTION = {"EI": "positive", "pipe_mass": "nonneg", "fluid_mass": "nonneg", "EIz": "positive", "EA": "positive",
           "GJ": "positive", "GAy": "positive", "GAz": "positive", "kv": "positive", "rotary_inertia": "nonneg3",
           "eta_bending": "nonneg", "eta_torsion": "nonneg", "eta_axial": "nonneg", "c_ext": "nonneg",
           "k_found": "nonneg"}
TUBE = {"outer_diameter": "positive", "inner_diameter": "nonneg", "E": "positive", "G": "positive",
        "density": "positive", "fluid_density": "nonneg", "kv": "positive", "shear": "bool",
        "rotary_inertia": "bool", "fluid_bulk_modulus": "positive"}
FLOW = {"mass_flow": "number", "reservoir_inlets": "nodes"}
RAYLEIGH = ("rayleigh_damping", {"alpha": "nonneg", "beta": "nonneg"}, None)
TOP = ("pipeflex_model", "info", "sections", "geometry", "supports", "hub", "springs", "masses", "loads", "flow",
       "gravity", "rayleigh_damping", "floating")
_REQUIRED_TOP = ("geometry",)


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
    if kind == "elastic":
        if value in ("A", "0") or (type(value) is int and value == 0):  # YAML reads a bare 0 as a number
            return str(value)
        raise bad()
    raise AssertionError(kind)


def _arguments(r: _Reader, where: tuple, value, spec, b: ModelBuilder, sections: dict) -> dict:
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
    params = inspect.signature(getattr(ModelBuilder, method)).parameters
    for name, p in params.items():
        if name != "self" and p.default is inspect.Parameter.empty and p.kind is not p.VAR_KEYWORD \
                and name not in value:
            raise r.error(where, f"missing required key {name!r}")
    return {key: _value(r, where + (key,), fields[key], v, b, sections) for key, v in value.items()}


def _call(r: _Reader, where: tuple, b: ModelBuilder, method: str, kwargs: dict) -> None:
    try:
        getattr(b, method)(**kwargs)
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


def _entries(r: _Reader, data, key: str, kinds: dict, b: ModelBuilder, sections: dict) -> None:
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


def _model_from(r: _Reader) -> Model:
    data = r.data
    if not isinstance(data, dict):
        raise r.error((), f"a model file is a mapping of {', '.join(TOP)}, got {type(data).__name__}")
    for key in data:
        if key not in TOP:
            raise r.error((key,), _unknown_key(key, TOP))
    for key in _REQUIRED_TOP:
        if key not in data:
            raise r.error((), f"missing required key {key!r}")
    version = data.get("pipeflex_model", FORMAT_VERSION)
    if version != FORMAT_VERSION:
        raise r.error(("pipeflex_model",), f"this pipeflex reads model files of version {FORMAT_VERSION}, got "
                                           f"{version!r}")
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
    for key, spec in (("masses", MASS), ("loads", LOAD)):
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


def _checked_path(path, *, reading: bool) -> Path:
    p = Path(path)
    if p.suffix.lower() not in SUFFIXES:
        raise ValueError(f"path {str(p)!r}: a model file ends in {', '.join(SUFFIXES)} (the suffix picks the format)")
    if reading and not p.is_file():
        raise FileNotFoundError(f"path {str(p)!r}: no such model file")
    return p


def load_model(path: Union[str, Path]) -> Model:
    """The model described by the model file ``path`` (``.yaml``, ``.yml`` or ``.json``;
    schema in ``docs/model_files.md``), built by :class:`~pipeflex.ModelBuilder`.

    Args:
        path: the file [-].

    Raises:
        ModelFileError: (a ValueError) a file the schema or the builder refuses, naming the
            file, the line and the key: unknown key (with the closest valid one), wrong
            type, negative stiffness, unknown node or section, missing required key, or
            the builder's own rule.
    """
    return _model_from(_Reader(_checked_path(path, reading=True)))


# -- writing ------------------------------------------------------------------------

#: builder method -> (list or key of the file, entry kind or None)
_PLACES = {**{spec[0]: ("geometry", k) for k, spec in GEOMETRY.items()},
           **{spec[0]: ("supports", k) for k, spec in SUPPORTS.items()},
           **{spec[0]: ("springs", k) for k, spec in SPRINGS.items()},
           HUB[0]: ("hub", None), MASS[0]: ("masses", None), LOAD[0]: ("loads", None),
           "reservoir_inlet": ("flow", None), "set_gravity": ("gravity", None),
           RAYLEIGH[0]: ("rayleigh_damping", None)}


_FIELDS = {spec[0]: spec[1] for spec in (*GEOMETRY.values(), *SUPPORTS.values(), *SPRINGS.values(), HUB, MASS, LOAD,
                                          RAYLEIGH)}
_FIELDS.update(reservoir_inlet={"node": "node"}, set_gravity={"g": "point"})
_FLOATS = ("number", "nonneg", "positive", "point", "nonneg3")


def _floats(value):
    return [_floats(v) for v in value] if isinstance(value, list) else float(value)


def _plain(value, names: dict):
    """A builder argument as YAML/JSON data: sections by their name in ``names``."""
    if isinstance(value, PipeSection):
        return names[id(value)]
    if isinstance(value, np.ndarray):
        return _plain(value.tolist(), names)
    if isinstance(value, (list, tuple)):
        return [_plain(v, names) for v in value]
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return float(value)
    if isinstance(value, dict):
        return {str(k): _plain(v, names) for k, v in value.items()}
    if value is None or isinstance(value, str):
        return value
    raise TypeError(f"{type(value).__name__} is not model-file data")


def _same_value(a, b) -> bool:
    if a is None or b is None or isinstance(a, (str, PipeSection)) or isinstance(b, str):
        return a is b or a == b
    try:
        return bool(np.array_equal(np.asarray(a, dtype=float), np.asarray(b, dtype=float)))
    except (TypeError, ValueError):
        return a == b


def _section_data(s: PipeSection) -> dict:
    """The section's fields (those at their default left out)."""
    out = {}
    for f in dataclasses.fields(PipeSection):
        v = getattr(s, f.name)
        default = {"EIz": s.EI, "EA": 1e10 * s.EI, "GJ": s.EI / 1.3}.get(f.name, f.default)
        if f.name in ("EI", "pipe_mass") or not _same_value(v, default):
            out[f.name] = [float(x) for x in v] if f.name == "rotary_inertia" else float(v)
    return out


def model_data(model: Model) -> dict:
    """The model file's content (plain dicts and lists) for ``model``, from the builder
    calls it recorded (ValueError if it has none: not built by
    :class:`~pipeflex.ModelBuilder`, or a :meth:`~pipeflex.Model.free_model`)."""
    desc = getattr(model, "_description", None)
    if desc is None or "_recipe" not in desc:
        raise ValueError(f"model: a model file describes an element model built by pipeflex.ModelBuilder (the "
                         f"schema has no floating-frame bodies or coupled systems yet), got a {type(model).__name__}")
    if model._is_free:
        raise ValueError("model: a free_model() cannot be saved (it has no supports): save the model it came from")
    names: dict = {}
    sections: dict = {}
    lists: dict = {k: [] for k in ("geometry", "supports", "hub", "springs", "masses", "loads")}
    inlets = []
    rayleigh = None
    for method, args, kwargs in desc["_recipe"]:
        if method == "add_load_function":  # code, not data
            fn = kwargs.get("fn", args[1] if len(args) > 1 else None)
            raise ValueError(f"model: its load function {getattr(fn, '__name__', fn)!s} (add_load_function) is a "
                             f"Python callable, which a model file cannot hold: the model cannot be saved")
        if method == "add_load" and kwargs.get("time_function") is not None:
            raise ValueError("model: add_load(time_function=...) has no model-file key yet: the model cannot be "
                             "saved (give the time function to the analysis as load_factor= instead)")
        if method not in _PLACES:
            raise ValueError(f"model: its builder call {method}() has no model-file key: the model cannot be saved")
        place, kind = _PLACES[method]
        f = getattr(ModelBuilder, method)
        params = {**inspect.signature(ModelBuilder.add_pipe).parameters, **inspect.signature(f).parameters}
        bound = inspect.signature(f).bind(None, *args, **kwargs).arguments
        bound.pop("self", None)
        bound.update(bound.pop("options", {}))  # add_line's and add_arc's add_pipe options
        entry = {}
        for key, v in bound.items():
            p = params.get(key)
            if p is not None and p.default is not inspect.Parameter.empty and _same_value(v, p.default):
                continue  # the builder's default: left out
            if isinstance(v, PipeSection) and id(v) not in names:
                for name, known in sections.items():  # equal sections share one name
                    if known == v:
                        names[id(v)] = name
                        break
                else:
                    names[id(v)] = f"section_{len(sections)}"
                    sections[names[id(v)]] = v
            entry[key] = _plain(v, names)
            if _FIELDS[method].get(key) in _FLOATS or (isinstance(entry[key], list) and key in ("start",)):
                entry[key] = _floats(entry[key])  # as the loader reads them: the text does not depend on 0 vs 0.0
        if place == "flow":
            inlets.append(entry["node"])
        elif place == "gravity":
            continue  # the model's gravity, below
        elif place == "rayleigh_damping":
            rayleigh = entry  # a later call replaces an earlier one, as in the builder
        elif kind is None:
            lists[place].append(entry)
        else:
            shorthand = (GEOMETRY.get(kind) or SUPPORTS.get(kind) or SPRINGS.get(kind))[2]
            lists[place].append({kind: entry[shorthand] if list(entry) == [shorthand] else entry})
    data: dict = {"pipeflex_model": FORMAT_VERSION}
    info = {}
    for k, v in model.info.items():
        try:
            info[str(k)] = _plain(v, {})
        except TypeError:
            warnings.warn(f"model.info[{k!r}] ({type(v).__name__}) is not model-file data: not saved", stacklevel=3)
    if info:
        data["info"] = info
    data["sections"] = {name: _section_data(s) for name, s in sections.items()}
    data["geometry"] = lists["geometry"]
    if lists["supports"]:
        data["supports"] = lists["supports"]
    if lists["hub"]:
        data["hub"] = lists["hub"][0] if len(lists["hub"]) == 1 else lists["hub"]
    for key in ("springs", "masses", "loads"):
        if lists[key]:
            data[key] = lists[key]
    flow = {"mass_flow": float(model.mass_flow)}
    if inlets:
        flow["reservoir_inlets"] = inlets
    data["flow"] = flow
    if np.any(model.gravity):
        data["gravity"] = [float(g) for g in model.gravity]
    if rayleigh:
        data["rayleigh_damping"] = rayleigh
    if desc.get("_floating"):
        data["floating"] = True
    return data


def _dumps(data: dict, suffix: str) -> str:
    if suffix == ".json":
        return json.dumps(data, indent=2) + "\n"
    try:
        import yaml
    except ImportError:
        raise ImportError("writing a YAML model file needs PyYAML: apt install python3-yaml (or pip install pyyaml), "
                          "or save as .json") from None

    return ("# pipeflex model file (schema: docs/model_files.md)\n"
            + yaml.safe_dump(data, sort_keys=False, default_flow_style=None, width=100))


def _equal(a, b) -> bool:
    """Exact equality of two builder descriptions' values (arrays bit for bit)."""
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_equal(a[k], b[k]) for k in a)
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):
        return len(a) == len(b) and all(_equal(x, y) for x, y in zip(a, b))
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return np.shape(a) == np.shape(b) and bool(np.array_equal(a, b))
    if dataclasses.is_dataclass(a) and type(a) is type(b):
        return all(_equal(getattr(a, f.name), getattr(b, f.name)) for f in dataclasses.fields(a))
    return a == b


def _difference(model: Model, other: Model) -> Optional[str]:
    """The first part of the two models' descriptions that differs, or None."""
    d, e = model._description, other._description
    for key in sorted(set(d) | set(e)):
        if key in ("_recipe", "_depth"):
            continue
        if not _equal(d.get(key), e.get(key)):
            return key.lstrip("_")
    if model.mass_flow != other.mass_flow:
        return "mass_flow"
    return None


def save_model(model: Model, path: Union[str, Path]) -> Path:
    """Write ``model`` as a model file, YAML (``.yaml``, ``.yml``) or JSON (``.json``) by
    the suffix of ``path``; returns the path. The text is read back before it is written:
    ValueError if it would not build the same model (builder calls whose order a model
    file cannot keep, e.g. a support on a node before a later line re-used it in a way
    that changes its constraints), so a saved file always reproduces the model.

    Args:
        model: a model built by :class:`~pipeflex.ModelBuilder`.
        path: the file to write [-]; its folder must exist.
    """
    p = _checked_path(path, reading=False)
    if p.is_dir():
        raise ValueError(f"path {str(p)!r} is a folder; give a file name ending in {', '.join(SUFFIXES)}")
    text = _dumps(model_data(model), p.suffix.lower())
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:  # the check reads the very text written
        probe = Path(tmp) / f"model{p.suffix.lower()}"
        probe.write_text(text, encoding="utf-8")
        try:
            again = load_model(probe)
        except ModelFileError as exc:
            raise ValueError(f"model: its model file would not load back ({exc.key}: {exc}); the builder calls "
                             f"were made in an order the file's grouping cannot keep") from None
    diff = _difference(model, again)
    if diff is not None:
        raise ValueError(f"model: its model file would not rebuild it exactly (the {diff} differ): the builder "
                         f"calls were made in an order the file's grouping (geometry, supports, hub, springs, "
                         f"masses, loads) cannot keep")
    p.write_text(text, encoding="utf-8")
    return p
