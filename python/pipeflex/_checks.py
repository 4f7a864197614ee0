"""Input validation helpers: every message names the parameter and the rule."""
from __future__ import annotations

import math

import numpy as np


def finite(name: str, value) -> float:
    if isinstance(value, (str, bytes)):  # float("3") would accept text
        raise ValueError(f"{name} must be a real number, got {value!r}")
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a real number, got {value!r}") from None
    if not math.isfinite(x):
        raise ValueError(f"{name} must be finite, got {x}")
    return x


def positive(name: str, value) -> float:
    x = finite(name, value)
    if x <= 0.0:
        raise ValueError(f"{name} must be > 0, got {x}")
    return x


def non_negative(name: str, value) -> float:
    x = finite(name, value)
    if x < 0.0:
        raise ValueError(f"{name} must be >= 0, got {x}")
    return x


def vector3(name: str, value) -> np.ndarray:
    try:
        v = np.asarray(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a 3-vector of real numbers, got {value!r}") from None
    if v.shape != (3,):
        raise ValueError(f"{name} must be a 3-vector, got shape {v.shape}")
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{name} must be finite, got {v}")
    return v


def unit_vector(name: str, value) -> np.ndarray:
    v = vector3(name, value)
    n = np.linalg.norm(v)
    if n < 1e-12:
        raise ValueError(f"{name} must be a non-zero vector, got {v}")
    return v / n


def row_norms(v: np.ndarray) -> np.ndarray:
    """Euclidean norms of the rows of ``v`` (n, 3), summed in order x, y, z, as the scalar
    formula of one element (a line's or an arc's element data then agree with those of
    its elements added one by one to round-off; bit for bit only where numpy's
    vectorised and scalar paths round alike, which depends on the CPU and numpy)."""
    return np.sqrt(v[:, 0] * v[:, 0] + v[:, 1] * v[:, 1] + v[:, 2] * v[:, 2])


def unit_vectors(name: str, value: np.ndarray) -> np.ndarray:
    """The rows of ``value`` (n, 3) as unit vectors, as :func:`unit_vector` of each; the
    message names the first row that is not finite or is zero."""
    v = np.asarray(value, dtype=float)
    if v.ndim != 2 or v.shape[1] != 3:
        raise ValueError(f"{name} must be an (n, 3) array of 3-vectors, got shape {v.shape}")
    bad = np.flatnonzero(~np.all(np.isfinite(v), axis=1))
    if bad.size:
        raise ValueError(f"{name} must be finite, got {v[bad[0]]} (row {bad[0]})")
    n = row_norms(v)
    zero = np.flatnonzero(~(n >= 1e-12))
    if zero.size:
        raise ValueError(f"{name} must be a non-zero vector, got {v[zero[0]]} (row {zero[0]})")
    return v / n[:, None]


def _integer(name: str, value, low: int, rule: str) -> int:
    x = 0.5 if isinstance(value, bool) else finite(name, value)  # True is not a count
    if x != int(x) or x < low:
        raise ValueError(f"{name} must be a {rule} integer, got {value!r}")
    return int(x)


def non_negative_int(name: str, value) -> int:
    return _integer(name, value, 0, "non-negative")


def positive_int(name: str, value) -> int:
    return _integer(name, value, 1, "positive")


#: Bounds of the physical magnitudes a model accepts (section stiffnesses and masses
#: per length, lengths): beyond them squares and products of the model's numbers
#: underflow or overflow double precision, and the analyses answer with round-off
#: (e.g. no instability found for EI = 1e-300 N m^2) or OverflowError.
MAGNITUDE = {"N m^2": (1e-20, 1e20), "N": (1e-20, 1e30), "kg/m": (1e-20, 1e20), "m": (1e-6, 1e6)}

#: Most elements one model may have (the builder's lists and the dense analyses grow
#: with it; the largest tested model has 8192 elements, docs/performance.md).
MAX_ELEMENTS = 100_000


def magnitude(name: str, value, unit: str) -> float:
    """``value`` > 0 within :data:`MAGNITUDE` [unit] (a physical magnitude in SI units)."""
    x = positive(name, value)
    low, high = MAGNITUDE[unit]
    if not low <= x <= high:
        raise ValueError(f"{name} must be in [{low:g}, {high:g}] {unit} (SI units; beyond, the model's numbers "
                         f"leave double precision), got {x:g} {unit}")
    return x


def element_count(name: str, value, existing: int = 0) -> int:
    """A positive number of elements ``value`` that keeps the model (with ``existing``
    elements) within :data:`MAX_ELEMENTS`."""
    n = positive_int(name, value)
    if existing + n > MAX_ELEMENTS:
        raise ValueError(f"{name} = {n} would give the model {existing + n} elements; at most {MAX_ELEMENTS}")
    return n


#: Largest gravity component [m/s^2] (10^5 g): beyond, the weight overflows the
#: convergence tests' force level, or g was not given in m/s^2.
MAX_GRAVITY = 1e6


def gravity(name: str, value) -> np.ndarray:
    """A gravity vector [m/s^2] with components of at most :data:`MAX_GRAVITY`."""
    g = vector3(name, value)
    if np.abs(g).max() > MAX_GRAVITY:
        raise ValueError(f"{name} must have components of at most {MAX_GRAVITY:g} m/s^2 (SI units), got {g}")
    unit_slip(f"|{name}|", float(np.linalg.norm(g)), "m/s^2", "gravity")
    return g


def output_count(name: str, value, n_nodes: int) -> int:
    """A positive number of output times whose result (18 values per node and 5 energies
    per time, 8 bytes each) fits in the core's ``MAX_OUTPUT_BYTES``; checked before the
    output times are laid out (the core checks the same bound again)."""
    from . import _core

    n = positive_int(name, value)
    size = 8.0 * n * (18.0 * n_nodes + 5.0)
    if size > _core.MAX_OUTPUT_BYTES:
        raise ValueError(f"{name} = {n} output times of {n_nodes} nodes need {size / 2**30:.6g} GiB; at most "
                         f"{_core.MAX_OUTPUT_BYTES / 2**30:g} GiB (fewer outputs, or split the run)")
    return n


def flow_map_bytes(n_steps: float, n_dofs: int) -> float:
    """About the memory [bytes] one generalised-alpha flow map with its tangent keeps:
    the trajectory (n_dofs doubles per step) and each step's linearisation, dense K and C
    below ``_core.DENSE_LU_BELOW`` coordinates (16 n^2 bytes per step), else sparse (about
    720 n bytes per step for a chain of elements; measured)."""
    from . import _core

    n = float(n_dofs)
    tangent = 16.0 * n * n if n_dofs < _core.DENSE_LU_BELOW else 720.0 * n
    return float(n_steps) * (8.0 * n + tangent) + 8.0 * n


def flow_map_steps(name: str, value, n_dofs: int) -> int:
    """A positive number of flow-map (shooting) steps per period whose trajectory and
    tangent (:func:`flow_map_bytes`) fit in the core's ``MAX_OUTPUT_BYTES``; checked
    before the run (beyond it the core fails with a bare ``std::bad_alloc``)."""
    from . import _core

    n = positive_int(name, value)
    size = flow_map_bytes(n, n_dofs)
    if size > _core.MAX_OUTPUT_BYTES:
        most = int((_core.MAX_OUTPUT_BYTES - flow_map_bytes(0, n_dofs)) // (flow_map_bytes(1, n_dofs)
                                                                            - flow_map_bytes(0, n_dofs)))
        raise ValueError(f"{name} = {n} steps per period of {n_dofs} coordinates would keep about "
                         f"{size / 2**30:.6g} GiB in memory (the trajectory and each step's linearisation, for "
                         f"the Newton iteration and the multipliers); at most {_core.MAX_OUTPUT_BYTES / 2**30:g} GiB, "
                         f"i.e. {name} <= {most} here: use fewer steps (a few hundred per period resolve a "
                         f"smooth cycle)")
    return n


def rho_inf_with_multipliers(value) -> float:
    """rho_inf of generalised-alpha for equations with multipliers (index 3): in [0, 1)."""
    rho = non_negative("rho_inf", value)
    if rho >= 1:
        raise ValueError(f"rho_inf must be in [0, 1) (index-3 constraints need numerical damping), got {rho}")
    return rho


#: Plausible ranges [SI] of inputs where a unit slip is common: outside them a
#: :class:`~pipeflex.errors.UnitWarning` names the likely slip (the value is used as
#: given). Wide on purpose (docs/conventions.md, Units): (low, high, hint below, hint above).
PLAUSIBLE = {
    "diameter": (None, 5.0, "", "did you give millimetres? ({x:g} mm = {milli:g} m)"),
    "modulus": (1e5, 1e13, "did you give GPa or MPa? ({x:g} GPa = {giga:g} Pa)",
                "stiffer than any solid (diamond: 1.2e12 Pa): check the units"),
    "density": (50.0, 25000.0, "did you give g/cm^3? ({x:g} g/cm^3 = {kilo:g} kg/m^3)",
                "denser than any solid (osmium: 22590 kg/m^3): check the units"),
    "fluid_density": (None, 25000.0, "", "denser than any liquid (mercury: 13546 kg/m^3): check the units"),
    "bulk_modulus": (1e4, 1e12, "did you give GPa or MPa? ({x:g} GPa = {giga:g} Pa; water: 2.2e9 Pa)",
                     "stiffer than any fluid (water: 2.2e9 Pa): check the units"),
    "gravity": (None, 100.0, "", "did you give mm/s^2? ({x:g} mm/s^2 = {milli:g} m/s^2)"),
}


def _stacklevel_outside_package() -> int:
    """The ``stacklevel`` of ``warnings.warn`` called from the caller of this function
    that points at the first frame outside pipeflex (the user's line)."""
    import os
    import sys

    root = os.path.dirname(os.path.abspath(__file__))
    frame, level = sys._getframe(1), 1
    while frame is not None and frame.f_code.co_filename.startswith(root):
        frame, level = frame.f_back, level + 1
    return level


def unit_slip(name: str, value: float, unit: str, kind: str) -> float:
    """``value`` [unit], with a :class:`~pipeflex.errors.UnitWarning` if it lies outside
    :data:`PLAUSIBLE` ``[kind]``, naming the parameter, the value and the likely slip."""
    import warnings

    from .errors import UnitWarning

    low, high, below, above = PLAUSIBLE[kind]
    x = abs(value)
    small, large = low is not None and 0 < x < low, high is not None and x > high
    if small or large:
        bound, hint = (f"below {low:g}", below) if small else (f"above {high:g}", above)
        advice = hint.format(x=x, milli=x * 1e-3, kilo=x * 1e3, giga=x * 1e9)
        warnings.warn(f"{name} = {value:g} {unit} is {bound} {unit}, implausible in SI units: {advice}",
                      UnitWarning, stacklevel=_stacklevel_outside_package())
    return value
