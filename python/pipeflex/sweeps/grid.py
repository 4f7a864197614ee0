"""The points of a sweep: parameter lists checked and combined, and a stable key per point."""
from __future__ import annotations

import functools
import hashlib
import itertools
import json
import numbers
import re
from typing import Any, Dict, Iterable, List, Mapping

import numpy as np

GRIDS = ("product", "zip")


def check_values(name: str, values: Any) -> list:
    """The values of one parameter as a list of scalars (numbers, strings, bools)."""
    if isinstance(values, (str, bytes, Mapping)) or not isinstance(values, Iterable):
        raise TypeError(f"parameter {name!r}: give a list of values, not a {type(values).__name__} "
                        "(a fixed value goes into fn, e.g. with functools.partial)")
    if isinstance(values, np.ndarray) and values.ndim != 1:
        raise ValueError(f"parameter {name!r}: a 1-D list of values is needed, not an array of shape {values.shape}")
    out = list(values.tolist() if isinstance(values, np.ndarray) else values)
    if not out:
        raise ValueError(f"parameter {name!r} has no values (an empty list)")
    for v in out:
        key_value(name, v)
    return out


def key_value(name: str, v: Any):
    """A JSON value standing for the parameter value ``v`` (int and float stay apart)."""
    if isinstance(v, (bool, np.bool_)):
        return bool(v)
    if isinstance(v, numbers.Integral):
        return int(v)
    if isinstance(v, numbers.Real):
        return float(v)
    if isinstance(v, str):
        return v
    raise TypeError(f"parameter {name!r}: the value {v!r} is not a number, string or bool")


def points(grid: str, parameters: Mapping[str, list]) -> List[Dict[str, Any]]:
    """The points, each a dict name -> value; for ``product`` the last parameter varies fastest."""
    if grid not in GRIDS:
        raise ValueError(f"grid must be one of {GRIDS}, not {grid!r}")
    if not parameters:
        raise ValueError("sweep needs at least one parameter (a keyword argument with a list of values)")
    names = list(parameters)
    for taken in ("error", "point"):
        if taken in names and (taken == "error" or grid == "zip"):
            raise ValueError(f"a parameter cannot be named {taken!r}: the Dataset's "
                             f"{'errors' if taken == 'error' else 'dimension of a zip grid'} take that name")
    if grid == "zip":
        lengths = {n: len(v) for n, v in parameters.items()}
        if len(set(lengths.values())) > 1:
            raise ValueError("grid='zip' needs parameter lists of equal length, got "
                             + ", ".join(f"{n}: {k}" for n, k in lengths.items()))
        return [dict(zip(names, vals)) for vals in zip(*parameters.values())]
    for n, v in parameters.items():
        seen: Dict[Any, Any] = {}
        for x in v:
            k = key_value(n, x)
            # a coordinate value: 1, 1.0 and True are one (equal, and equal hashes); NaN is one
            same = "NaN" if isinstance(k, float) and k != k else k
            if same in seen:
                first = seen[same]
                also = "" if repr(first) == repr(x) else f" (as {first!r} and {x!r}, equal as coordinates)"
                raise ValueError(f"parameter {n!r} repeats the value {x!r}{also}: grid='product' needs distinct "
                                 "values; remove the repeat")
            seen[same] = x
    return [dict(zip(names, vals)) for vals in itertools.product(*parameters.values())]


def point_key(point: Mapping[str, Any]) -> str:
    """A stable hash of the point's parameters (names and values, in any order)."""
    text = json.dumps({n: key_value(n, v) for n, v in point.items()}, sort_keys=True, allow_nan=True)
    return hashlib.sha256(text.encode()).hexdigest()[:32]


def function_name(fn) -> str:
    """``module.qualname`` of a function (of the wrapped one for functools.partial)."""
    inner = fn
    while isinstance(inner, functools.partial):
        inner = inner.func
    module = getattr(inner, "__module__", None) or type(inner).__module__
    name = getattr(inner, "__qualname__", None) or type(inner).__qualname__
    return f"{module}.{name}"


def function_identity(fn) -> str:
    """``module.qualname(fixed arguments)``: the name and, for functools.partial, the fixed
    arguments by repr (memory addresses left out, so an object's repr stays the same from
    run to run). A sweep's store belongs to one identity."""
    args, keywords, inner = [], {}, fn
    while isinstance(inner, functools.partial):  # outermost first
        args = list(inner.args) + args
        keywords = {**inner.keywords, **keywords}
        inner = inner.func
    text = ", ".join([repr(a) for a in args] + [f"{k}={v!r}" for k, v in keywords.items()])
    return f"{function_name(fn)}({re.sub(r' at 0x[0-9a-fA-F]+', '', text)})"
