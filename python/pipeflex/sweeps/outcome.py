"""What one point gives: ``fn(**point)`` run inside a worker, its return value turned into
named numpy arrays, an exception into its text."""
from __future__ import annotations

import numbers
import os
import signal
from typing import Any, Callable, Dict, Mapping, Tuple

import numpy as np

from .. import _blas
from ..results import Result

#: (error, fields): error "" if the point succeeded (else "ExceptionType: message", and
#: fields {}); fields: name -> numpy array (0-d for scalars).
Outcome = Tuple[str, Dict[str, np.ndarray]]

_KINDS = "biufcU"  # bool, int, unsigned, float, complex, str
#: the field naming the class of a pipeflex result fn returned (its fields' units and
#: dimensions: pipeflex.results.FIELDS); not a variable of the Dataset
RESULT_CLASS = "__result__"
_pinned_pid = None


def limit_blas_threads() -> None:
    """Pin this process's BLAS to one thread (pipeflex._blas.pin_one_thread), so that one
    worker per core does not oversubscribe the cores. A no-op without OpenBLAS's own call
    and without threadpoolctl. Usable as the ``initializer`` of a user's
    ProcessPoolExecutor."""
    global _pinned_pid
    if _pinned_pid == os.getpid():
        return
    _blas.pin_one_thread()
    _pinned_pid = os.getpid()


def one_blas_thread():
    """A context in which this process's BLAS runs one thread (restored after; threads of
    a ThreadPoolExecutor and the serial executor run in it): pipeflex._blas.one_thread."""
    return _blas.one_thread()


def init_pool_worker() -> None:
    """Initializer of the default process pool: one BLAS thread; Ctrl-C is handled by the
    parent (which stops the pool), not by each worker."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    limit_blas_threads()


def as_array(name: str, value: Any) -> np.ndarray:
    a = np.asarray(value)
    if a.dtype.kind == "S":
        a = a.astype(str)
    if a.dtype.kind not in _KINDS:
        raise TypeError(f"fn returned the field {name!r} as a {type(value).__name__} ({a.dtype} values): a sweep "
                        "takes numbers, numpy arrays of numbers, and strings")
    return a


def fields_of(value: Any) -> Dict[str, np.ndarray]:
    """The named arrays of what fn returned: a dict, a scalar (named "value") or array, or a
    pipeflex :class:`~pipeflex.results.Result` (its number, string and array fields)."""
    if isinstance(value, Result):
        out = {RESULT_CLASS: np.array(type(value).__name__)}
        for name, v in value.to_dict().items():
            if isinstance(v, (numbers.Number, str, np.generic)) or (
                    isinstance(v, np.ndarray) and v.dtype.kind in _KINDS):
                out[name] = as_array(name, v)
        return out
    if isinstance(value, Mapping):
        out = {}
        for name, v in value.items():
            if not isinstance(name, str):
                raise TypeError(f"fn returned a dict with the key {name!r}: field names must be strings")
            if name == RESULT_CLASS:
                raise ValueError(f"fn returned a dict with the key {name!r}, which a sweep keeps for the class of "
                                 "a pipeflex result; rename the field")
            if v is not None:
                out[name] = as_array(name, v)
        return out
    if isinstance(value, (numbers.Number, str, np.generic, np.ndarray)):
        return {"value": as_array("value", value)}
    raise TypeError(f"fn returned a {type(value).__name__}: return a dict of numbers/arrays, a number, "
                    "or a pipeflex result")


def evaluate(fn: Callable, point: Mapping[str, Any]) -> Outcome:
    """Run ``fn(**point)``; an exception (not KeyboardInterrupt/SystemExit) becomes the error."""
    try:
        return "", fields_of(fn(**point))
    except Exception as exc:  # noqa: BLE001 -- any failure of the point is recorded, the sweep goes on
        return error_text(exc), {}


def evaluate_pinned(fn: Callable, point: Mapping[str, Any]) -> Outcome:
    """:func:`evaluate` on a Dask worker: one BLAS thread (set once per worker process)."""
    limit_blas_threads()
    return evaluate(fn, point)


def error_text(exc: BaseException) -> str:
    msg = str(exc).strip()
    return f"{type(exc).__name__}: {msg}" if msg else type(exc).__name__
