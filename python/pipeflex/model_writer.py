"""Writing model files: the content of a model file (plain dicts and lists) for an element
model, a system of floating-frame bodies or a coupled system, from the builder calls or
the description their builders kept, and its YAML or JSON text. The schema is in
``docs/model_files.md``; :mod:`pipeflex.model_files` reads the files and holds
:func:`~pipeflex.save_model`, which writes with these functions and reads the text back.

This module imports no model class (the builders' signatures come as arguments), so the
models' own ``save`` methods (:meth:`pipeflex.Model.save`,
:meth:`pipeflex.multibody.MultibodySystem.save`, :meth:`pipeflex.CoupledSystem.save`) can
use it.
"""
from __future__ import annotations

import dataclasses
import inspect
import json
import warnings
from pathlib import Path
from typing import Optional, Union

import numpy as np

from .sections import PipeSection
from .time_functions import Pulse, Sine

#: The format's version, the value of the file's ``pipeflex_model`` key.
FORMAT_VERSION = 1
SUFFIXES = (".yaml", ".yml", ".json")

# The element models' entry kinds (the reader, pipeflex.model_files, checks each key's
# kind; the writer groups the builder calls by them).
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
    "bushing": ("add_bushing", {"node_a": "node", "node_b": "node", "stiffness": "nonneg3", "damping": "nonneg3",
                                "rotational_stiffness": "nonneg3", "rotational_damping": "nonneg3"}, None),
}
HUB = ("rotating_hub", {"node": "node", "omega": "number", "spin_up_time": "nonneg", "center": "point",
                        "axis": "point"}, None)
MASS = ("add_point_mass", {"node": "node", "mass": "nonneg", "inertia": "nonneg3"}, None)
LOAD = ("add_load", {"node": "node", "force": "point", "moment": "point", "follower": "bool",
                     "time_function": "time_function"}, None)
RAYLEIGH = ("rayleigh_damping", {"alpha": "nonneg", "beta": "nonneg"}, None)
DISTRIBUTED_LOAD = ("add_distributed_load", {"elements": "elements", "line": "nodes", "force_per_length": "point",
                                             "time_function": "time_function"}, None)

# -- writing ------------------------------------------------------------------------

#: builder method -> (list or key of the file, entry kind or None)
_PLACES = {**{spec[0]: ("geometry", k) for k, spec in GEOMETRY.items()},
           **{spec[0]: ("supports", k) for k, spec in SUPPORTS.items()},
           **{spec[0]: ("springs", k) for k, spec in SPRINGS.items()},
           HUB[0]: ("hub", None), MASS[0]: ("masses", None), LOAD[0]: ("loads", None),
           DISTRIBUTED_LOAD[0]: ("distributed_loads", None),
           "reservoir_inlet": ("flow", None), "set_gravity": ("gravity", None),
           RAYLEIGH[0]: ("rayleigh_damping", None)}


_FIELDS = {spec[0]: spec[1] for spec in (*GEOMETRY.values(), *SUPPORTS.values(), *SPRINGS.values(), HUB, MASS, LOAD,
                                          RAYLEIGH, DISTRIBUTED_LOAD)}
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


def _time_function_data(f):
    """A time function (a number, a table (times, values), a Sine or a Pulse) as file data."""
    if isinstance(f, Pulse):
        out = {"start": float(f.start), "duration": float(f.duration)}
        if f.shape != "half_sine":
            out["shape"] = str(f.shape)
        if f.amplitude != 1.0:
            out["amplitude"] = float(f.amplitude)
        return {"pulse": out}
    if isinstance(f, Sine):
        out = {"omega": float(f.omega)}
        if not _same_value(f.envelope, 1.0):
            out["envelope"] = _time_function_data(f.envelope)
        for name in ("phase", "mean"):
            if getattr(f, name) != 0.0:
                out[name] = float(getattr(f, name))
        return {"sine": out}
    if callable(f):
        raise ValueError(f"model: its time function {getattr(f, '__name__', f)!s} is a Python callable, which a "
                         f"model file cannot hold: the model cannot be saved")
    if np.isscalar(f) and not isinstance(f, (str, bytes)):
        return float(f)
    ts, vs = (np.asarray(a, dtype=float) for a in f)
    return {"table": {"times": [float(x) for x in ts], "values": [float(x) for x in vs]}}


def _section_data(s: PipeSection) -> dict:
    """The section's fields (those at their default left out)."""
    out = {}
    for f in dataclasses.fields(PipeSection):
        v = getattr(s, f.name)
        default = {"EIz": s.EI, "EA": 1e10 * s.EI, "GJ": s.EI / 1.3}.get(f.name, f.default)
        if f.name in ("EI", "pipe_mass") or not _same_value(v, default):
            out[f.name] = [float(x) for x in v] if f.name == "rotary_inertia" else float(v)
    return out


def _section_name(section: PipeSection, names: dict, sections: dict) -> str:
    """The file's name of ``section`` (equal sections share one name; new ones are added
    to ``sections``, name -> section; ``names`` is id -> name)."""
    if id(section) not in names:
        for name, known in sections.items():
            if known == section:
                names[id(section)] = name
                break
        else:
            names[id(section)] = f"section_{len(sections)}"
            sections[names[id(section)]] = section
    return names[id(section)]


def _info_data(info: dict) -> dict:
    out = {}
    for k, v in info.items():
        try:
            out[str(k)] = _plain(v, {})
        except TypeError:
            warnings.warn(f"info[{k!r}] ({type(v).__name__}) is not model-file data: not saved", stacklevel=4)
    return out


def model_data(model, builder) -> dict:
    """The model file's content (plain dicts and lists) for ``model``, from the builder
    calls it recorded (ValueError if it has none: not built by
    :class:`~pipeflex.ModelBuilder`, or a :meth:`~pipeflex.Model.free_model`);
    ``builder`` the :class:`~pipeflex.ModelBuilder` class (its signatures tell the
    defaults, which the file leaves out)."""
    desc = getattr(model, "_description", None)
    if desc is None or "_recipe" not in desc:
        raise ValueError(f"model: an element model file describes a model built by pipeflex.ModelBuilder, got a "
                         f"{type(model).__name__} without its builder calls")
    if model._is_free:
        raise ValueError("model: a free_model() cannot be saved (it has no supports): save the model it came from")
    names: dict = {}
    sections: dict = {}
    lists: dict = {k: [] for k in ("geometry", "supports", "hub", "springs", "masses", "loads", "distributed_loads")}
    inlets = []
    rayleigh = None
    for method, args, kwargs in desc["_recipe"]:
        if method == "add_load_function":  # code, not data
            fn = kwargs.get("fn", args[1] if len(args) > 1 else None)
            raise ValueError(f"model: its load function {getattr(fn, '__name__', fn)!s} (add_load_function) is a "
                             f"Python callable, which a model file cannot hold: the model cannot be saved")
        if method not in _PLACES:
            raise ValueError(f"model: its builder call {method}() has no model-file key: the model cannot be saved")
        place, kind = _PLACES[method]
        f = getattr(builder, method)
        params = {**inspect.signature(builder.add_pipe).parameters, **inspect.signature(f).parameters}
        bound = inspect.signature(f).bind(None, *args, **kwargs).arguments
        bound.pop("self", None)
        bound.update(bound.pop("options", {}))  # add_line's and add_arc's add_pipe options
        entry = {}
        for key, v in bound.items():
            p = params.get(key)
            if p is not None and p.default is not inspect.Parameter.empty and _same_value(v, p.default):
                continue  # the builder's default: left out
            if isinstance(v, PipeSection):
                _section_name(v, names, sections)
            entry[key] = _time_function_data(v) if _FIELDS[method].get(key) == "time_function" else _plain(v, names)
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
    info = _info_data(model.info)
    if info:
        data["info"] = info
    data["sections"] = {name: _section_data(s) for name, s in sections.items()}
    data["geometry"] = lists["geometry"]
    if lists["supports"]:
        data["supports"] = lists["supports"]
    if lists["hub"]:
        data["hub"] = lists["hub"][0] if len(lists["hub"]) == 1 else lists["hub"]
    for key in ("springs", "masses", "loads", "distributed_loads"):
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


def _node_data(body, node: int):
    """A body node as the file writes it: 'start', 'center', 'end' or its index."""
    names = {0: "start", body.n_elements // 2: "center", body.n_elements: "end"}
    return names.get(int(node), int(node))


def multibody_data(system, make_body) -> dict:
    """The model file's content for a :class:`~pipeflex.multibody.MultibodySystem`, from
    the description its builder kept (ValueError for what a file cannot hold: a body not
    made by :func:`~pipeflex.multibody.flexible_body` or with a custom basis);
    ``make_body`` that function (its defaults are left out)."""
    desc = getattr(system, "_description", None)
    if desc is None:
        raise ValueError("system: it was not built by MultibodyBuilder.build: it cannot be saved")
    b, junction_forces = desc
    defaults = {n: p.default for n, p in inspect.signature(make_body).parameters.items()}
    names: dict = {}
    sections: dict = {}
    bodies: dict = {}
    made: list = []  # (flexible_body's arguments, the body's name)
    assembly = []
    for j, (body, r, R, f) in enumerate(zip(b["_bodies"], b["_r"], b["_R"], b["_flow"])):
        args = body._arguments
        if args is None:
            raise ValueError(f"system: body {j} was not made by pipeflex.multibody.flexible_body(): it cannot be "
                             f"saved")
        if args.get("basis") is not None:
            raise ValueError(f"system: body {j} has a custom basis (flexible_body(basis=...)), which a model file "
                             f"does not hold: it cannot be saved")
        name = next((n for a, n in made if a is args or _equal(a, args)), None)
        if name is None:
            name = f"body_{len(bodies)}"
            made.append((args, name))
            entry = {"length": float(args["length"]), "n_elements": int(args["n_elements"]),
                     "section": _section_name(args["section"], names, sections)}
            for key in ("internal_modes", "reduction", "curvature", "modal_damping", "fluid_lever_arm"):
                if not _same_value(args[key], defaults[key]):
                    entry[key] = _plain(args[key], {})
                    if key in ("curvature", "modal_damping"):
                        entry[key] = _floats(entry[key])
            bodies[name] = entry
        place = {"body": name, "position": [float(x) for x in r]}
        if not np.array_equal(R, np.eye(3)):
            place["rotation"] = [[float(x) for x in row] for row in R]
        if f != 1.0:
            place["flow_factor"] = float(f)
        assembly.append(place)
    placed = b["_bodies"]
    joints = []
    for kind, a, other, extra in b["_joints"]:
        ends = ({"body": int(a[0]), "node": _node_data(placed[a[0]], a[1])} if other is None and kind != "hinge"
                else {"body_a": int(a[0]), "node_a": _node_data(placed[a[0]], a[1])})
        if kind == "hinge":
            ends["axis"] = [float(x) for x in extra.get("given_axis", extra["axis"])]
        if other is not None:
            ends.update(body_b=int(other[0]), node_b=_node_data(placed[other[0]], other[1]))
        if kind == "hinge" and extra["torque"] is not None:
            ends["torque"] = _time_function_data(extra["torque"])
        if kind == "roller":
            ends["direction"] = [float(x) for x in extra.get("given_direction", extra["direction"])]
        joints.append({"fix" if kind == "rigid" and other is None else kind: ends})
    springs = []
    for sp in b["_springs"]:  # the builder's dicts: kind, nodes ((body, node), ...), k, c (, anchor, k_phi, c_phi)
        ends = [(int(j), _node_data(placed[j], n)) for j, n in sp["nodes"]]
        entry = (dict(body=ends[0][0], node=ends[0][1]) if sp["kind"] == "ground" else
                 dict(body_a=ends[0][0], node_a=ends[0][1], body_b=ends[1][0], node_b=ends[1][1]))
        entry.update(_spring_values(sp))
        springs.append({sp["kind"]: entry})
    loads = []
    for ld in b["_loads"]:
        entry = {"body": int(ld.body), "node": _node_data(placed[ld.body], ld.node)}
        for key, value in (("force", ld.force), ("moment", ld.moment)):
            if not all(_same_value(v, 0.0) for v in value):
                entry[key] = [_time_function_data(v) for v in value]
        loads.append(entry)
    distributed = []
    for d in b.get("_distributed", ()):
        entry = {"body": int(d["body"]), "force_per_length": [float(x) for x in d["q"]]}
        if d["tf"] is not None:
            entry["time_function"] = _time_function_data(d["tf"])
        distributed.append(entry)
    data: dict = {"pipeflex_model": FORMAT_VERSION, "kind": "multibody"}
    info = _info_data(system.info)
    if info:
        data["info"] = info
    data["sections"] = {name: _section_data(s) for name, s in sections.items()}
    data.update(bodies=bodies, assembly=assembly, joints=joints)
    if springs:
        data["springs"] = springs
    if loads:
        data["loads"] = loads
    if distributed:
        data["distributed_loads"] = distributed
    if np.any(b["_gravity"]):
        data["gravity"] = [float(g) for g in b["_gravity"]]
    data["flow"] = {"mass_flow": float(system.mass_flow)}
    if not junction_forces:
        data["flow"]["junction_forces"] = False
    return data


def _spring_values(sp: dict) -> dict:
    """A spring's stiffness and damping keys as the file writes them (from a builder's
    dict: k, c (, anchor, k_phi, c_phi)); zeros, the builders' defaults, left out."""
    out = {}
    for key, name in (("k", "stiffness"), ("c", "damping"), ("anchor", "anchor"), ("k_phi", "rotational_stiffness"),
                      ("c_phi", "rotational_damping")):
        v = sp.get(key)
        if v is None or (name != "stiffness" and name != "anchor" and not np.any(v)):
            continue
        out[name] = _floats(_plain(v, {}))
    return out


def coupled_data(system, builder, make_body) -> dict:
    """The model file's content for a :class:`~pipeflex.CoupledSystem`: its element model,
    its bodies and the couplings, joints then spring-dampers (``builder``, ``make_body``: as
    :func:`model_data` and :func:`multibody_data` take them)."""
    elements = model_data(system.model, builder)
    bodies = multibody_data(system.bodies, make_body)
    for part in (elements, bodies):
        part.pop("pipeflex_model")
        part.pop("kind", None)
    couplings = []
    for c in system.joints:
        entry = {"node": int(c.node), "body": int(c.body),
                 "body_node": _node_data(system.bodies.bodies[c.body], c.body_node)}
        if c.axis is not None:
            entry["axis"] = [float(x) for x in (c.given_axis or c.axis)]
        couplings.append({c.kind: entry})
    for sp in system._springs:  # dicts: kind, node, body, body_node, k, c (, k_phi, c_phi)
        entry = {"node": int(sp["node"]), "body": int(sp["body"]),
                 "body_node": _node_data(system.bodies.bodies[sp["body"]], sp["body_node"])}
        entry.update(_spring_values(sp))
        couplings.append({sp["kind"]: entry})
    return {"pipeflex_model": FORMAT_VERSION, "kind": "coupled", "elements": elements, "bodies": bodies,
            "couplings": couplings}


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


def _difference(model, other) -> Optional[str]:
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


def _multibody_difference(system, other) -> Optional[str]:
    """The first part of two multibody systems' builder descriptions that differs, or None."""
    (a, ja), (b, jb) = system._description, other._description
    if ja != jb:
        return "junction_forces"
    if len(a["_bodies"]) != len(b["_bodies"]) or not all(
            _equal(x._arguments, y._arguments) for x, y in zip(a["_bodies"], b["_bodies"])):
        return "bodies"
    for key in ("_r", "_R", "_flow", "_joints", "_springs", "_loads", "_gravity", "_distributed"):
        if not _equal(a.get(key, []), b.get(key, [])):
            return key.lstrip("_")
    return "mass_flow" if system.mass_flow != other.mass_flow else None


def _coupled_difference(system, other) -> Optional[str]:
    diff = _difference(system.model, other.model) or _multibody_difference(system.bodies, other.bodies)
    if diff is None and not _equal(system.joints, other.joints):
        diff = "couplings"
    return diff or (None if _equal(system._springs, other._springs) else "coupling springs")


def _checked_path(path, *, reading: bool) -> Path:
    p = Path(path)
    if p.suffix.lower() not in SUFFIXES:
        raise ValueError(f"path {str(p)!r}: a model file ends in {', '.join(SUFFIXES)} (the suffix picks the format)")
    if reading and not p.is_file():
        raise FileNotFoundError(f"path {str(p)!r}: no such model file")
    return p


#: The order in which a model file's groups make an element model (pipeflex.model_files
#: reads them so): the builder calls of each place, in their own order within it.
ELEMENT_ORDER = ("geometry", "flow", "supports", "hub", "springs", "masses", "loads", "distributed_loads",
                 "rayleigh_damping", "gravity")


def grouped_difference(model, builder) -> Optional[str]:
    """The first part of ``model``'s description that differs from the model its builder
    calls make in a model file's order (:data:`ELEMENT_ORDER`), or None: calls made in an
    order that matters across the file's groups do not come back the same."""
    desc = model._description
    recipe = sorted(desc["_recipe"], key=lambda call: ELEMENT_ORDER.index(_PLACES[call[0]][0]))
    b = builder()
    for method, args, kwargs in recipe:
        getattr(b, method)(*args, **kwargs)
    return _difference(model, b.build(mass_flow=model.mass_flow, floating=bool(desc.get("_floating"))))


def write(data: dict, path: Union[str, Path]) -> Path:
    """Write a model file's content ``data`` as YAML (``.yaml``, ``.yml``) or JSON
    (``.json``) by the suffix of ``path`` [-] (its folder must exist); returns the path."""
    p = _checked_path(path, reading=False)
    if p.is_dir():
        raise ValueError(f"path {str(p)!r} is a folder; give a file name ending in {', '.join(SUFFIXES)}")
    p.write_text(_dumps(data, p.suffix.lower()), encoding="utf-8")
    return p


def _check_grouping(model, builder) -> None:
    diff = grouped_difference(model, builder)
    if diff is not None:
        raise ValueError(f"model: its model file would not rebuild it exactly (the {diff} differ): the builder "
                         f"calls were made in an order the file's grouping ({', '.join(ELEMENT_ORDER)}) cannot "
                         f"keep")


def save_elements(model, path: Union[str, Path], builder) -> Path:
    """:meth:`pipeflex.Model.save`: the file :func:`~pipeflex.save_model` writes, after
    checking that the file's grouping of the builder calls rebuilds ``model``
    (:func:`grouped_difference`; ValueError naming what differs)."""
    _checked_path(path, reading=False)
    data = model_data(model, builder)
    _check_grouping(model, builder)
    return write(data, path)


def save_coupled(system, path: Union[str, Path], builder, make_body) -> Path:
    """:meth:`pipeflex.CoupledSystem.save`: as :func:`save_elements` for its element model."""
    _checked_path(path, reading=False)
    data = coupled_data(system, builder, make_body)
    _check_grouping(system.model, builder)
    return write(data, path)
