"""What one point gives: ``fn(**point)`` run inside a worker, its return value turned into
named numpy arrays, an exception into its text."""
from __future__ import annotations

import ctypes
import numbers
import os
import signal
import sys
import threading
import time
from typing import Any, Callable, Dict, Mapping, Optional, Tuple

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
_PR_SET_PDEATHSIG = 1  # linux/prctl.h


class WorkerDied(RuntimeError):
    """The failure of a point whose process died when it ran alone, retried after a
    worker of the pool died with it queued (a crash in compiled code, os._exit, out of
    memory): the point's error reads "WorkerDied: worker died: exit code -11 (SIGSEGV), ..."."""


def limit_blas_threads() -> None:
    """Pin this process's BLAS to one thread from now on (:func:`pipeflex._blas.pin`, also
    over a thread count set in the environment), so that one worker per core does not
    oversubscribe the cores. A no-op without OpenBLAS's own call and without threadpoolctl.
    Usable as the ``initializer`` of a user's ProcessPoolExecutor."""
    _blas.pin(force=True)


def init_pool_worker(parent: Optional[int] = None) -> None:
    """Initializer of the default process pool: one BLAS thread; Ctrl-C is handled by the
    parent (which stops the pool), not by each worker; the worker dies with ``parent``
    (the sweep's process id), even when that is killed (``kill -9``)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if parent is not None:
        die_with_parent(parent)
    limit_blas_threads()


def die_with_parent(parent: int) -> None:
    """End this process when the process ``parent`` ends: on Linux, when ``parent`` is
    the direct parent (the fork start method), by the kernel's parent-death signal
    (SIGKILL); else a daemon thread that looks for ``parent`` every 0.5 s."""
    direct = os.getppid() == parent
    if direct and sys.platform.startswith("linux"):
        try:
            libc = ctypes.CDLL(None, use_errno=True)
            if libc.prctl(_PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0) == 0:
                if os.getppid() != parent:  # the parent died before prctl took effect
                    os._exit(1)
                return
        except (OSError, AttributeError):
            pass

    def alive() -> bool:
        if direct:
            return os.getppid() == parent  # an orphan is reparented
        try:
            os.kill(parent, 0)
        except ProcessLookupError:
            return False
        except PermissionError:
            pass
        return True

    def watch():
        while alive():
            time.sleep(0.5)
        os._exit(1)

    threading.Thread(target=watch, name="pipeflex-parent-watch", daemon=True).start()


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
