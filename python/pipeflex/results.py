"""One contract for analysis results: frozen dataclasses of arrays and plain values.

A result class derives from :class:`Result` and is a ``@dataclass(frozen=True)``. Its
fields may hold numpy arrays and numpy scalars, ``None``, bools, ints, floats, complex
numbers, strings, scipy sparse matrices (CSC, CSR, COO), lists, tuples and dicts of
those, and nested results (e.g. a :class:`~pipeflex.state.State`).

Files are ``.npz`` archives: every array is an entry of its own, and one JSON entry
(``__result__``) holds the rest, referring to the array entries by name. No pickle is
involved: :meth:`Result.load` reads the archive with ``allow_pickle=False`` and creates
only :class:`Result` classes of pipeflex. A load gives back the same types, dtypes and
bit-identical values.
"""
from __future__ import annotations

import dataclasses
import importlib
import json
import os
import zipfile
import zlib
from pathlib import Path
from typing import Any, Dict, Optional, Tuple, Union

import numpy as np

FORMAT = 1

#: The integrators' work counters, one vocabulary for every formulation and integrator (a
#: transient result's ``stats``): steps taken, Newton iterations, Jacobians (iteration
#: matrices) evaluated, frame re-basings, steps failed by the error test (IDA) and steps
#: redone after Newton failed (halved).
COUNTERS = ("steps", "newton_iterations", "jacobians", "rebases", "failed_steps", "convergence_failures")
_META = "__result__"
_SPARSE_FORMATS = ("csc_matrix", "csr_matrix", "coo_matrix", "csc_array", "csr_array", "coo_array")
_REGISTRY: Dict[str, type] = {}


def _class_key(cls) -> str:
    return f"{cls.__module__}:{cls.__qualname__}"


class Result:
    """Base of the result dataclasses: :meth:`save`, :meth:`load`, :meth:`to_dict`; a
    summary repr (each field as its value, or ``array(shape, dtype)``)."""

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        _REGISTRY[_class_key(cls)] = cls
        # @dataclass writes its own __repr__ (every array in full) unless the class has one
        if "__repr__" not in cls.__dict__:
            cls.__repr__ = Result.__repr__

    def __repr__(self) -> str:
        items = _summary_items(self)
        return f"{type(self).__name__}({', '.join(f'{k}={v}' for k, v in items)})"

    def _repr_html_(self) -> str:
        return _html_table(type(self).__name__, _summary_items(self))

    def to_dict(self) -> dict:
        """The fields as a dict of plain Python/numpy values (nested results as dicts;
        arrays are the result's own, not copies)."""
        return {f.name: _plain(getattr(self, f.name)) for f in dataclasses.fields(self)}

    def save(self, path: Union[str, Path], *, compress: bool = False) -> Path:
        """Write to the ``.npz`` file ``path`` (``.npz`` is appended if missing; parent
        folders are created) and return its path. ``compress``: zip-deflate the arrays."""
        path = Path(path)
        if path.suffix != ".npz":
            path = path.with_name(path.name + ".npz")
        arrays: Dict[str, np.ndarray] = {}
        meta = {"format": FORMAT, "root": _encode(self, arrays, type(self).__name__)}
        arrays[_META] = np.array(json.dumps(meta, allow_nan=True))
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
        try:
            with open(tmp, "wb") as fh:
                (np.savez_compressed if compress else np.savez)(fh, **arrays)
            os.replace(tmp, path)
        finally:
            if tmp.exists():
                tmp.unlink()
        return path

    @classmethod
    def load(cls, path: Union[str, Path]):
        """Read a result written by :meth:`save` (of this class or a subclass).

        Raises:
            FileNotFoundError: no file ``path`` (nor ``path`` + ``.npz``).
            ValueError: the file is not a pipeflex result file or is damaged (truncated,
                garbled, not an ``.npz`` archive); the message names the file.
            TypeError: the file holds a result of another class.
        """
        path = Path(path)
        if not path.exists() and path.suffix != ".npz" and path.with_name(path.name + ".npz").exists():
            path = path.with_name(path.name + ".npz")
        try:
            f = np.load(path, allow_pickle=False)
        except _DAMAGED as exc:  # numpy says "pickled data" of any file that is not .npy/.npz
            raise _damaged(path, "not an .npz archive" if isinstance(exc, ValueError) else exc) from None
        if not isinstance(f, np.lib.npyio.NpzFile):
            raise _damaged(path, "a single .npy array, not an .npz archive")
        with f:
            try:
                obj = cls._read(f)
            except _DAMAGED as exc:
                raise _damaged(path, exc) from exc
        if not isinstance(obj, cls):
            raise TypeError(f"{path} holds a {type(obj).__name__}, not a {cls.__name__}")
        return obj

    @classmethod
    def _read(cls, f):
        if _META not in f.files:
            return cls._load_legacy(f)
        meta = json.loads(str(f[_META][()]))
        if not isinstance(meta, dict) or "root" not in meta:
            raise ValueError(f"its {_META!r} entry is not a result description")
        if meta.get("format") != FORMAT:
            raise ValueError(f"unknown result file format {meta.get('format')!r}")
        return _decode(meta["root"], f)

    @classmethod
    def _load_legacy(cls, f):
        raise ValueError(f"no {_META!r} entry")


# what reading a damaged or foreign file raises: zip, deflate, JSON (a ValueError) and
# numpy errors, and a missing entry (KeyError)
_DAMAGED = (zipfile.BadZipFile, zlib.error, EOFError, ValueError, KeyError)


def _damaged(path: Path, why) -> ValueError:
    if isinstance(why, KeyError):
        why = f"missing entry: {why.args[0] if why.args else why}"
    why = str(why)
    if len(why) > 200:  # zipfile quotes garbled headers in full
        why = why[:200] + " ..."
    return ValueError(f"{path}: not a pipeflex result file, or a damaged one ({why}); a result file is the "
                      ".npz archive Result.save writes: save the result again, or re-run its analysis")


def _plain(x):
    if isinstance(x, Result):
        return x.to_dict()
    if isinstance(x, dict):
        return {k: _plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return type(x)(_plain(v) for v in x)
    return x


def _store(arrays: dict, a: np.ndarray, where: str) -> str:
    if a.dtype.hasobject:
        raise TypeError(f"{where}: arrays of Python objects cannot be saved")
    key = f"a{len(arrays)}"
    arrays[key] = a
    return key


def _encode(x: Any, arrays: dict, where: str):
    if x is None or isinstance(x, (bool, str)):
        return x
    if isinstance(x, int) and type(x) is int:
        return x
    if type(x) is float:
        return x
    if type(x) is complex:
        return {"__complex__": [x.real, x.imag]}
    if isinstance(x, np.ndarray):
        return {"__array__": _store(arrays, x, where)}
    if isinstance(x, np.generic):
        return {"__scalar__": _store(arrays, np.asarray(x), where)}
    import scipy.sparse as sp

    if sp.issparse(x):
        name = type(x).__name__
        if name not in _SPARSE_FORMATS:
            raise TypeError(f"{where}: sparse format {name} is not supported (use CSC, CSR or COO)")
        parts = ("row", "col", "data") if x.format == "coo" else ("data", "indices", "indptr")
        return {"__sparse__": name, "shape": list(x.shape),
                **{p: _store(arrays, getattr(x, p), where) for p in parts}}
    if isinstance(x, Result) and dataclasses.is_dataclass(x):
        fields = {f.name: _encode(getattr(x, f.name), arrays, f"{where}.{f.name}") for f in dataclasses.fields(x)}
        return {"__result__": _class_key(type(x)), "fields": fields}
    if type(x) is list:
        return [_encode(v, arrays, f"{where}[{i}]") for i, v in enumerate(x)]
    if type(x) is tuple:
        return {"__tuple__": [_encode(v, arrays, f"{where}[{i}]") for i, v in enumerate(x)]}
    if type(x) is dict:
        return {"__dict__": [[_encode(k, arrays, f"{where} key"), _encode(v, arrays, f"{where}[{k!r}]")]
                             for k, v in x.items()]}
    raise TypeError(f"{where}: cannot save a {type(x).__name__} (results hold arrays, numbers, strings, "
                    "lists, tuples, dicts and results)")


def _result_class(key: str) -> type:
    if key not in _REGISTRY:
        module = key.split(":", 1)[0]
        if module == "pipeflex" or module.startswith("pipeflex."):
            importlib.import_module(module)
    if key not in _REGISTRY:
        raise ValueError(f"unknown result class {key!r} in the file")
    return _REGISTRY[key]


def _decode(x, f):
    if not isinstance(x, (dict, list)):
        return x
    if isinstance(x, list):
        return [_decode(v, f) for v in x]
    if "__array__" in x:
        return f[x["__array__"]]
    if "__scalar__" in x:
        return f[x["__scalar__"]][()]
    if "__complex__" in x:
        return complex(*x["__complex__"])
    if "__tuple__" in x:
        return tuple(_decode(v, f) for v in x["__tuple__"])
    if "__dict__" in x:
        return {_decode(k, f): _decode(v, f) for k, v in x["__dict__"]}
    if "__sparse__" in x:
        import scipy.sparse as sp

        cls = {name: getattr(sp, name) for name in _SPARSE_FORMATS if hasattr(sp, name)}[x["__sparse__"]]
        shape = tuple(x["shape"])
        if "row" in x:
            row, col, data = (f[x[p]] for p in ("row", "col", "data"))
            m = cls((data, (row, col)), shape=shape)
            m.row, m.col, m.data = row, col, data
        else:
            data, indices, indptr = (f[x[p]] for p in ("data", "indices", "indptr"))
            m = cls((data, indices, indptr), shape=shape)
            m.data, m.indices, m.indptr = data, indices, indptr  # keep the index dtype as saved
        return m
    if "__result__" in x:
        cls = _result_class(x["__result__"])
        values = {k: _decode(v, f) for k, v in x["fields"].items()}
        fields = dataclasses.fields(cls)
        unknown = [k for k in values if k not in {fl.name for fl in fields}]
        if unknown:  # a file sets fields of the class only, never other attributes
            raise ValueError(f"the file's {cls.__name__} has the entry {unknown[0]!r}, which is not a field of "
                             f"{cls.__name__} (fields: {', '.join(fl.name for fl in fields)})")
        missing = [fl.name for fl in fields if fl.init and fl.name not in values
                   and fl.default is dataclasses.MISSING and fl.default_factory is dataclasses.MISSING]
        if missing:
            raise ValueError(f"the file's {cls.__name__} lacks the field {missing[0]!r}")
        init = {fl.name for fl in fields if fl.init}
        obj = cls(**{k: v for k, v in values.items() if k in init})
        for k, v in values.items():
            if k not in init:
                object.__setattr__(obj, k, v)
        return obj
    raise ValueError(f"malformed result file entry {x!r}")


# ---------------------------------------------------------------------------------------
# summaries (repr)

_MAX_ITEMS = 8  # a list, tuple or dict up to this long is shown item by item


def summary(x) -> str:
    """A short text of a value: numbers and strings as themselves, an array as
    ``array(shape, dtype)`` (a 0-d one as its value), a result or matrix by its type."""
    if isinstance(x, np.ndarray):
        return repr(x.item()) if x.ndim == 0 else f"array({x.shape}, {x.dtype})"
    if isinstance(x, np.generic):
        return repr(x.item())
    if x is None or isinstance(x, (bool, int, float, complex, str)):
        return repr(x)
    if isinstance(x, Result):
        return f"{type(x).__name__}(...)"
    if hasattr(x, "nnz") and hasattr(x, "shape"):  # a scipy sparse matrix (without importing scipy)
        return f"{type(x).__name__}({x.shape}, nnz={x.nnz})"
    if isinstance(x, (list, tuple)):
        if len(x) > _MAX_ITEMS:
            return f"{type(x).__name__}(len={len(x)})"
        inner = ", ".join(summary(v) for v in x)
        return f"[{inner}]" if isinstance(x, list) else f"({inner}{',' if len(x) == 1 else ''})"
    if isinstance(x, dict):
        if len(x) > _MAX_ITEMS:
            return f"dict(len={len(x)})"
        return "{" + ", ".join(f"{k!r}: {summary(v)}" for k, v in x.items()) + "}"
    return f"<{type(x).__name__}>"


def _summary_items(result) -> list:
    return [(f.name, summary(getattr(result, f.name))) for f in dataclasses.fields(result) if f.repr]


def _html_table(title: str, items) -> str:
    """An HTML table of (name, text) rows under a bold title (Jupyter's rich display)."""
    import html

    rows = "".join(f"<tr><td style='text-align:left'><code>{html.escape(str(k))}</code></td>"
                   f"<td style='text-align:left'>{html.escape(str(v))}</td></tr>" for k, v in items)
    return f"<div><b>{html.escape(title)}</b><table>{rows}</table></div>"


# ---------------------------------------------------------------------------------------
# units, long names and dimensions of the result fields (xarray)

#: The fields of the results as xarray variables: class name -> field -> (units, long
#: name, the dimensions of the field's own axes). Units follow the classes' docstrings
#: (UDUNITS spelling; "1": dimensionless); None where a field has none or mixes several
#: (reduced coordinates: m and rad). ``to_xarray`` methods and :func:`pipeflex.sweep`
#: read them from here.
FIELDS: Dict[str, Dict[str, tuple]] = {
    "CriticalFlow": {
        "mass_flow": ("kg/s", "critical mass flow", ()),
        "kind": (None, "kind of instability (flutter or divergence)", ()),
        "frequency": ("rad/s", "angular frequency of the critical mode", ()),
        "eigenvalue": ("1/s", "critical eigenvalue", ()),
        "mode": ("1", "critical mode shape (reduced coordinates)", ("dof",)),
        "evaluations": (None, "eigen-analyses used", ()),
    },
    "StaticResult": {
        "iterations": (None, "Newton iterations", ()),
        "residual": ("N", "final residual norm", ()),
        "mass_flow": ("kg/s", "mass flow", ()),
        "coupling_forces": (None, "coupling multipliers (N, N m)", ("coupling",)),
    },
    "EigenResult": {
        "values": ("1/s", "eigenvalue", ("mode",)),
        "noise": ("1/s", "round-off bound of the eigenvalue", ("mode",)),
        "vectors": ("1", "mode shape (reduced coordinates)", ("dof", "mode")),
        "block_of": (None, "decoupled block of the eigenvalue", ("mode",)),
        "static_negative": (None, "negative stiffness eigenvalues in massless blocks", ()),
    },
    "TransientResult": {
        "t": ("s", "time", ("time",)),
        "x": ("m", "node position", ("time", "node", "component")),
        "R": ("1", "node rotation matrix", ("time", "node", "row", "column")),
        "xd": ("m/s", "node velocity", ("time", "node", "component")),
        "omega": ("rad/s", "node angular velocity (spatial)", ("time", "node", "component")),
        "kinetic": ("J", "kinetic energy", ("time",)),
        "elastic": ("J", "elastic energy", ("time",)),
        "gravity_potential": ("J", "gravitational potential energy", ("time",)),
        "fluid_work": ("J", "work of the fluid forces since the start", ("time",)),
        "load_work": ("J", "work of the nodal loads since the start", ("time",)),
        "dissipated": ("J", "energy dissipated by the damping forces since the start", ("time",)),
    },
    "PeriodicOrbit": {
        "mass_flow": ("kg/s", "mass flow", ()),
        "period": ("s", "period", ()),
        "z0": (None, "reduced displacement at t = 0 (m, rad)", ("dof",)),
        "v0": (None, "reduced velocity at t = 0 (m/s, rad/s)", ("dof",)),
        "t": ("s", "time over one period", ("time",)),
        "x": ("m", "node position over one period", ("time", "node", "component")),
        "amplitude": ("m", "half peak-to-peak excursion of the node coordinate", ("node", "component")),
        "multipliers": ("1", "Floquet multiplier", ("multiplier",)),
        "trivial": (None, "index of the trivial multiplier", ()),
        "stable": (None, "orbit stable", ()),
        "residual": (None, "shooting residual max |phi_T(x0) - x0| (m, m/s)", ()),
        "iterations": (None, "Newton iterations of the shooting", ()),
        "steps": (None, "integrator steps per period", ()),
    },
    "OrbitBranch": {
        "mass_flow": ("kg/s", "mass flow", ("orbit",)),
        "period": ("s", "period", ("orbit",)),
        "amplitude": ("m", "half peak-to-peak excursion of the node coordinate", ("orbit", "node", "component")),
        "stable": (None, "orbit stable", ("orbit",)),
        "max_multiplier": ("1", "largest modulus of the non-trivial Floquet multipliers", ("orbit",)),
        "folds": ("kg/s", "mass flow of a fold of the branch", ("fold",)),
        "parameter": (None, "value of the continued parameter (its unit)", ("orbit",)),
        "multipliers": ("1", "Floquet multiplier", ("orbit", "multiplier")),
        "trivial": (None, "index of the trivial multiplier", ("orbit",)),
        "hopf_mass_flow": ("kg/s", "mass flow of the Hopf point", ()),
        "hopf_frequency": ("rad/s", "angular frequency at the Hopf point", ()),
    },
    "OrbitGuess": {
        "period": ("s", "period", ()),
        "amplitude": ("m", "half peak-to-peak range of the watched coordinate", ()),
        "time": ("s", "motion integrated", ()),
        "settled": (None, "last two cycles agreed", ()),
    },
    "Campbell": {
        "speeds": ("rad/s", "rotation rate", ("speed",)),
        "gamma": ("1", "rotation rate over the reference rate", ("speed",)),
        "omega0": ("rad/s", "reference rate", ()),
        "frequencies": ("rad/s", "angular frequency in the rotating frame", ("speed", "branch")),
        "mac": ("1", "modal assurance criterion between neighbouring speeds", ("speed_interval", "branch")),
        "family": (None, "family of the branch at the first speed", ("branch",)),
        "share": ("1", "fraction of the squared nodal translations", ("speed", "branch", "direction")),
        "modes": ("1", "mode shape (reduced coordinates)", ("speed", "branch", "dof")),
        "growth": ("1/s", "largest real part of the eigenvalues", ("speed",)),
        "harmonics": (None, "multiple k of the excitation line omega = k Omega", ("harmonic",)),
        "crossing_k": (None, "multiple k of the excitation line crossed", ("crossing",)),
        "crossing_branch": (None, "branch crossing the excitation line", ("crossing",)),
        "crossing_speed": ("rad/s", "rotation rate of the crossing", ("crossing",)),
        "crossing_frequency": ("rad/s", "angular frequency of the crossing", ("crossing",)),
        "linearization": (None, "linearisation", ()),
    },
    "RotatingFrequencies": {
        "gamma": ("1", "rotation rate over the reference rate", ("speed",)),
        "omega0": ("rad/s", "reference rate", ()),
        "transverse": ("1", "in-plane bending frequency over the reference rate", ("speed", "mode")),
        "longitudinal": ("1", "axial frequency over the reference rate", ("speed", "mode")),
        "out_of_plane": ("1", "flapwise frequency over the reference rate", ("speed", "mode")),
        "growth": ("1", "largest real part of the eigenvalues over the reference rate", ("speed",)),
        "max_strain": ("1", "largest axial strain", ("speed",)),
        "linearization": (None, "linearisation", ()),
        "transverse_shapes": ("1", "transverse mode shape (radial, tangential)",
                              ("speed", "mode", "node", "direction")),
    },
    "SteadyRotation": {
        "omega": ("rad/s", "angular velocity about the hinge axis", ()),
        "axis": ("1", "hinge axis", ("component",)),
        "hinge_node": (None, "hinge node", ()),
        "iterations": (None, "Newton iterations", ()),
        "residual": ("N", "final residual norm", ()),
        "coupling_forces": (None, "coupling multipliers (N, N m)", ("coupling",)),
        "point": ("m", "point of the hinge axis", ("component",)),
        "hinge": (None, "hinge", ()),
    },

    # pipeflex.stability_map's Dataset (the variables of stability_map.critical_point)
    "stability_map": {
        "mass_ratio": ("1", "mass ratio beta = M / (M + m)", ()),
        "gravity": ("1", "gravity parameter gamma = (M + m) g L^3 / EI", ()),
        "u_cr": ("1", "critical flow speed u = U L sqrt(M / EI)", ()),
        "omega_cr": ("1", "angular frequency at the onset omega L^2 sqrt((M + m) / EI)", ()),
        "kind": (None, "kind of instability (flutter or divergence)", ()),
        "mass_flow": ("kg/s", "critical mass flow of the dimensionless model", ()),
        "evaluations": (None, "eigen-analyses used", ()),
    },
}


def field_info(kind: str, name: str) -> Tuple[dict, Optional[tuple]]:
    """The xarray attributes (``units`` if known, ``long_name``) of the field ``name`` of
    the result class (or table) ``kind``, and the dimensions of its own axes (None if the
    table has no such field: then only ``long_name`` = the name)."""
    entry = FIELDS.get(kind, {}).get(name)
    if entry is None:
        return {"long_name": name}, None
    units, long_name, dims = entry
    return ({"units": units} if units else {}) | {"long_name": long_name}, dims


def variables(name: str, values: np.ndarray, dims: tuple, attrs: dict) -> dict:
    """xarray variables ``name -> (dims, values, attrs)``; a complex field as two,
    ``<name>_real`` and ``<name>_imag`` (netCDF has no complex numbers)."""
    if values.dtype.kind != "c":
        return {name: (dims, values, attrs)}
    long_name = attrs.get("long_name", name)
    return {f"{name}_{part}": (dims, np.ascontiguousarray(getattr(values, part)),
                               {**attrs, "long_name": f"{long_name} ({what} part)"})
            for part, what in (("real", "real"), ("imag", "imaginary"))}


def to_dataset(kind: str, values: Dict[str, Any], coords: Dict[str, tuple], attrs: Optional[dict] = None):
    """An ``xarray.Dataset`` of a result: ``values`` (name -> array or number; None left
    out) as variables with the dimensions, units and long names of ``FIELDS[kind]``;
    ``coords``: name -> (dims, values, attrs). xarray is imported here, on first use."""
    import xarray as xr

    data_vars = {}
    for name, value in values.items():
        if value is None:
            continue
        info, dims = field_info(kind, name)
        a = np.asarray(value)
        if dims is None or len(dims) != a.ndim:
            raise ValueError(f"{kind}.{name}: {a.ndim} axes, the table FIELDS has the dimensions {dims}")
        data_vars.update(variables(name, a, dims, info))
    return xr.Dataset(data_vars, coords=coords, attrs={"result": kind, **(attrs or {})})


def node_coords(n_nodes: int) -> Dict[str, tuple]:
    """The coordinates ``node`` (indices 0 .. n_nodes - 1) and ``component`` (x, y, z) of
    nodal vectors in a result's Dataset."""
    return {"node": ("node", np.arange(n_nodes), {"long_name": "node index"}),
            "component": ("component", np.array(["x", "y", "z"], dtype=object), {"long_name": "global axis"})}
