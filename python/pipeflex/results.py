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
from pathlib import Path
from typing import Any, Dict, Union

import numpy as np

FORMAT = 1
_META = "__result__"
_SPARSE_FORMATS = ("csc_matrix", "csr_matrix", "coo_matrix", "csc_array", "csr_array", "coo_array")
_REGISTRY: Dict[str, type] = {}


def _class_key(cls) -> str:
    return f"{cls.__module__}:{cls.__qualname__}"


class Result:
    """Base of the result dataclasses: :meth:`save`, :meth:`load`, :meth:`to_dict`."""

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        _REGISTRY[_class_key(cls)] = cls

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
        """Read a result written by :meth:`save` (of this class or a subclass)."""
        path = Path(path)
        if not path.exists() and path.suffix != ".npz" and path.with_name(path.name + ".npz").exists():
            path = path.with_name(path.name + ".npz")
        with np.load(path, allow_pickle=False) as f:
            if _META not in f.files:
                obj = cls._load_legacy(f)
            else:
                meta = json.loads(str(f[_META][()]))
                if meta.get("format") != FORMAT:
                    raise ValueError(f"{path}: unknown result file format {meta.get('format')!r}")
                obj = _decode(meta["root"], f)
        if not isinstance(obj, cls):
            raise TypeError(f"{path} holds a {type(obj).__name__}, not a {cls.__name__}")
        return obj

    @classmethod
    def _load_legacy(cls, f):
        raise ValueError(f"not a pipeflex result file (no {_META!r} entry)")


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
        init = {fl.name for fl in dataclasses.fields(cls) if fl.init}
        obj = cls(**{k: v for k, v in values.items() if k in init})
        for k, v in values.items():
            if k not in init:
                object.__setattr__(obj, k, v)
        return obj
    raise ValueError(f"malformed result file entry {x!r}")
