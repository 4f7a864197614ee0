"""The outcomes of a sweep's points as an ``xarray.Dataset``."""
from __future__ import annotations

from typing import Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np
import xarray as xr

from .outcome import Outcome

ERROR = "error"


def _as_coordinate(values: list) -> np.ndarray:
    a = np.asarray(values)
    return a.astype(object) if a.dtype.kind == "U" else a


def _field_specs(outcomes: Sequence[Optional[Outcome]], reserved: set) -> Dict[str, Tuple[tuple, list]]:
    """Field name -> (shape of one point's array, the points' dtypes), in order of appearance."""
    specs: Dict[str, Tuple[tuple, list]] = {}
    for o in outcomes:
        if o is None or o[0]:
            continue
        for name, a in o[1].items():
            if name in reserved:
                raise ValueError(f"fn returned a field named {name!r}, which the Dataset uses for a parameter, "
                                 "a dimension or the errors; rename the field")
            if name not in specs:
                specs[name] = (a.shape, [])
            elif specs[name][0] != a.shape:
                raise ValueError(f"fn returned the field {name!r} with the shapes {specs[name][0]} and {a.shape} "
                                 "at different points; a sweep needs one shape per field")
            specs[name][1].append(a.dtype)
    return specs


def build(grid: str, parameters: Mapping[str, list], outcomes: List[Optional[Outcome]],
          unfinished: Mapping[int, str], attrs: dict) -> xr.Dataset:
    """Variables over the grid's dimensions (the parameters for ``product``, ``point`` for
    ``zip``); a field's own axes are ``<field>_dim_<k>``; complex fields are split into
    ``<field>_real`` and ``<field>_imag`` (netCDF has no complex numbers). Points without
    a value (failed, not computed) hold NaN (numbers; ints and bools then become floats)
    or "" (strings)."""
    names = list(parameters)
    if grid == "product":
        dims = tuple(names)
        shape = tuple(len(v) for v in parameters.values())
        coords = {n: (n, _as_coordinate(v)) for n, v in parameters.items()}
    else:
        dims, shape = ("point",), (len(outcomes),)
        coords = {n: ("point", _as_coordinate(v)) for n, v in parameters.items()}
    ok = [o is not None and not o[0] for o in outcomes]
    reserved = set(names) | set(dims) | {ERROR}
    data_vars = {}
    for name, (fshape, dtypes) in _field_specs(outcomes, reserved).items():
        try:
            dtype = np.result_type(*dtypes)
        except TypeError:
            raise ValueError(f"fn returned the field {name!r} as {sorted({str(d) for d in dtypes})} at different "
                             "points; a sweep needs one kind (numbers or strings) per field") from None
        complete = all(good and name in o[1] for good, o in zip(ok, outcomes))
        if dtype.kind == "U":
            dtype, fill = np.dtype(object), ""
        elif dtype.kind == "c":
            fill = complex(np.nan, np.nan)
        else:
            if dtype.kind in "biu" and not complete:
                dtype = np.dtype(np.float64)
            fill = np.nan if dtype.kind == "f" else 0
        values = np.full((len(outcomes),) + fshape, fill, dtype=dtype)
        for i, (good, o) in enumerate(zip(ok, outcomes)):
            if good and name in o[1]:
                a = o[1][name]
                values[i, ...] = a.astype(object) if dtype.kind == "O" else a  # [i, ...]: str items, not 0-d arrays
        values = values.reshape(shape + fshape)
        vdims = dims + tuple(f"{name}_dim_{k}" for k in range(len(fshape)))
        if dtype.kind == "c":
            data_vars[f"{name}_real"] = (vdims, np.ascontiguousarray(values.real))
            data_vars[f"{name}_imag"] = (vdims, np.ascontiguousarray(values.imag))
        else:
            data_vars[name] = (vdims, values)
    errors = np.empty(len(outcomes), dtype=object)
    for i, o in enumerate(outcomes):
        errors[i] = o[0] if o is not None else f"not computed: {unfinished.get(i, 'unknown reason')}"
    data_vars[ERROR] = (dims, errors.reshape(shape))
    n_failed = sum(1 for o in outcomes if o is not None and o[0])
    attrs = {**attrs, "n_points": len(outcomes), "n_failed": n_failed}
    if unfinished:
        attrs["n_unfinished"] = len(unfinished)
    return xr.Dataset(data_vars, coords=coords, attrs=attrs)
