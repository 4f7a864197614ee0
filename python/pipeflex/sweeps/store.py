"""A sweep's store: a folder with one ``.npz`` file per finished point, named by the
point's key (a hash of its parameters), each written atomically (a temporary file, then
``os.replace``), so that a process killed mid-write leaves no partial point behind.

Files: ``sweep.json`` (the format; the function's name and fixed arguments) and ``<key>.npz`` (entries
``__point__``, JSON: parameters, error, field names; ``f0``, ``f1``, ...: the fields'
arrays). Read without pickle.
"""
from __future__ import annotations

import json
import os
import warnings
from pathlib import Path
from typing import Any, Dict, Mapping, Optional, Union

import numpy as np

from .grid import key_value
from .outcome import Outcome

FORMAT = 1
_META = "sweep.json"


class PointStore:
    """The folder ``path`` (created if missing) of the sweep of the function ``fn_name``
    (:func:`~pipeflex.sweeps.grid.function_identity`: the name and fixed arguments)."""

    def __init__(self, path: Union[str, os.PathLike], fn_name: str):
        self.path = Path(path)
        if self.path.exists() and not self.path.is_dir():
            raise ValueError(f"store={str(path)!r} is a file; a sweep's store is a folder")
        self.path.mkdir(parents=True, exist_ok=True)
        meta = self.path / _META
        if meta.exists():
            info = _read_meta(meta)
            if info.get("format") != FORMAT:
                raise ValueError(f"store={str(path)!r}: unknown sweep store format {info.get('format')!r}")
            if info.get("fn") != fn_name:
                raise ValueError(f"store={str(path)!r} holds a sweep of {info.get('fn')}, not of {fn_name}; "
                                 "use another folder (or delete this one) for another function or other fixed "
                                 "arguments")
        else:
            _write_atomic(meta, json.dumps({"format": FORMAT, "fn": fn_name}).encode())

    def file(self, key: str) -> Path:
        return self.path / f"{key}.npz"

    def load(self, key: str, point: Mapping[str, Any]) -> Optional[Outcome]:
        """The stored outcome of the point, or None (not stored, or unreadable: warned)."""
        path = self.file(key)
        if not path.exists():
            return None
        try:
            with open(path, "rb") as fh, np.load(fh, allow_pickle=False) as f:  # fh: closed also on BadZipFile
                meta = json.loads(str(f["__point__"][()]))
                if meta["parameters"] != _parameters(point):
                    return None  # another point with the same hash prefix: recompute
                return meta["error"], {name: f[f"f{i}"] for i, name in enumerate(meta["fields"])}
        except Exception as exc:  # noqa: BLE001 -- a damaged file is recomputed, not fatal
            warnings.warn(f"sweep store: the point file {str(path)!r} is damaged ({type(exc).__name__}: {exc}); "
                          "the point is computed again and the file replaced", stacklevel=3)
            return None

    def save(self, key: str, point: Mapping[str, Any], outcome: Outcome) -> None:
        error, fields = outcome
        meta = {"parameters": _parameters(point), "error": error, "fields": list(fields)}
        arrays: Dict[str, np.ndarray] = {f"f{i}": a for i, a in enumerate(fields.values())}
        arrays["__point__"] = np.array(json.dumps(meta, allow_nan=True))
        tmp = self.file(key).with_name(f".{key}.{os.getpid()}.tmp")
        try:
            with open(tmp, "wb") as fh:
                np.savez(fh, **arrays)
            os.replace(tmp, self.file(key))
        finally:
            if tmp.exists():
                tmp.unlink()


def _read_meta(meta: Path) -> dict:
    """The description ``sweep.json`` of a store; a ValueError naming it if it is damaged."""
    try:
        info = json.loads(meta.read_bytes().decode("utf-8"))
    except (OSError, ValueError) as exc:  # JSONDecodeError, UnicodeDecodeError are ValueErrors
        info = exc
    if not isinstance(info, dict):
        why = f"{type(info).__name__}: {info}" if isinstance(info, Exception) else f"a JSON {type(info).__name__}"
        raise ValueError(
            f"the sweep store's description {str(meta)!r} is damaged ({why}; it should hold the format and the "
            f"function's name): give the sweep another store folder, or delete the file to keep the folder's "
            f"points (they are then taken as the points of this sweep's fn)") from None
    return info


def _parameters(point: Mapping[str, Any]) -> dict:
    return {n: key_value(n, v) for n, v in point.items()}


def _write_atomic(path: Path, data: bytes) -> None:
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_bytes(data)
    os.replace(tmp, path)
