"""The outcomes of a sweep's points as an ``xarray.Dataset``."""
from __future__ import annotations

from typing import Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np
import xarray as xr

from ..results import field_info, variables
from .outcome import RESULT_CLASS, Outcome

ERROR = "error"

#: Units and long names of swept parameters named as pipeflex's own inputs (PipeSection's
#: fields, the scenes' keywords); other parameters get their name as long name, no units.
PARAMETERS = {
    "EI": ("N m^2", "bending stiffness EI"),
    "EIz": ("N m^2", "bending stiffness EI_z"),
    "EA": ("N", "axial stiffness EA"),
    "GJ": ("N m^2", "torsional stiffness GJ"),
    "pipe_mass": ("kg/m", "pipe mass per length"),
    "fluid_mass": ("kg/m", "fluid mass per length"),
    "kv": ("1", "momentum-flux factor"),
    "mass_flow": ("kg/s", "mass flow"),
    "flow_speed": ("m/s", "flow speed"),
    "length": ("m", "length"),
    "n_elements": (None, "number of elements"),
    "mass_ratio": ("1", "mass ratio (fluid over pipe and fluid)"),
}
#: labels of the named axes whose entries have names
_LABELS = {"component": ("x", "y", "z")}


def _parameter_attrs(name: str) -> dict:
    units, long_name = PARAMETERS.get(name, (None, name))
    return ({"units": units} if units else {}) | {"long_name": long_name}


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
            if name == RESULT_CLASS:
                continue
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
    ``zip``); complex fields are split into ``<field>_real`` and ``<field>_imag`` (netCDF
    has no complex numbers). Points without a value (failed, not computed) hold NaN
    (numbers; ints and bools then become floats) or "" (strings).

    The fields of a pipeflex result get the units, long names and named axes (``time``,
    ``node``, ``component``, ``mode`` ...) of :data:`pipeflex.results.FIELDS`; other
    fields their name as long name, and axes ``<field>_dim_<k>``."""
    names = list(parameters)
    if grid == "product":
        dims = tuple(names)
        shape = tuple(len(v) for v in parameters.values())
        coords = {n: (n, _as_coordinate(v), _parameter_attrs(n)) for n, v in parameters.items()}
    else:
        dims, shape = ("point",), (len(outcomes),)
        coords = {n: ("point", _as_coordinate(v), _parameter_attrs(n)) for n, v in parameters.items()}
    ok = [o is not None and not o[0] for o in outcomes]
    reserved = set(names) | set(dims) | {ERROR}
    kinds = {str(o[1][RESULT_CLASS]) for good, o in zip(ok, outcomes) if good and RESULT_CLASS in o[1]}
    kind = kinds.pop() if len(kinds) == 1 else None
    specs = _field_specs(outcomes, reserved)
    axes = _axes(kind, {name: fshape for name, (fshape, _) in specs.items()}, reserved)
    for axis, labels in _LABELS.items():
        if any(axis in d for d in axes.values()) and axis not in reserved and \
                all(len(labels) == specs[n][0][k] for n, d in axes.items() for k, a in enumerate(d) if a == axis):
            coords[axis] = (axis, np.array(labels, dtype=object), {"long_name": "global axis"})
    data_vars = {}
    for name, (fshape, dtypes) in specs.items():
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
        info = field_info(kind, name)[0] if kind else {"long_name": name}
        data_vars.update(variables(name, values, dims + axes[name], info))
    errors = np.empty(len(outcomes), dtype=object)
    for i, o in enumerate(outcomes):
        errors[i] = o[0] if o is not None else f"not computed: {unfinished.get(i, 'unknown reason')}"
    data_vars[ERROR] = (dims, errors.reshape(shape), {"long_name": "error of the point (empty if it succeeded)"})
    n_failed = sum(1 for o in outcomes if o is not None and o[0])
    attrs = {**attrs, "n_points": len(outcomes), "n_failed": n_failed}
    if kind:
        attrs["result"] = kind
    if unfinished:
        attrs["n_unfinished"] = len(unfinished)
    return xr.Dataset(data_vars, coords=coords, attrs=attrs)


def _axes(kind: Optional[str], shapes: Mapping[str, tuple], reserved: set) -> Dict[str, tuple]:
    """The names of each field's own axes: those of the result's table where every field
    naming an axis gives it one length and no parameter or field takes the name; else
    ``<field>_dim_<k>``."""
    named, taken = {}, reserved | set(shapes)
    for name, fshape in shapes.items():
        own = field_info(kind, name)[1] if kind else None
        if own is not None and len(own) == len(fshape) and not set(own) & taken:
            named[name] = own
    lengths: Dict[str, set] = {}
    for name, own in named.items():
        for axis, n in zip(own, shapes[name]):
            lengths.setdefault(axis, set()).add(n)
    clash = {axis for axis, ns in lengths.items() if len(ns) > 1}
    return {name: named[name] if name in named and not set(named[name]) & clash
            else tuple(f"{name}_dim_{k}" for k in range(len(fshape))) for name, fshape in shapes.items()}
