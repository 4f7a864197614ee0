"""One BLAS thread per process, set once.

The analyses factorise and solve many small dense matrices (tens to hundreds of
coordinates) and run ARPACK on Krylov vectors of a few thousand entries. A threaded BLAS
splits each call over its threads, whose start-up and spin-waits cost more than the
arithmetic: with OpenBLAS's two threads the steady rotation of the sprinkler took
70-110 ms on a busy 2-core machine, and 21-25 ms with one; ARPACK ran twice as slow
(docs/performance.md). Large models gain nothing from more threads either (the sparse
and band factorisations call no threaded BLAS).

So the first public analysis of a process pins BLAS to one thread for the rest of the
process (:func:`pin`), and nothing changes it back. The thread count is process-global:
saving and restoring it around each call raced between threads (one thread's restore
let another's BLAS run threaded, whose results then varied in the last bits from run to
run). A user who sets the count (``OPENBLAS_NUM_THREADS``, ``OMP_NUM_THREADS``, ... in
the environment) keeps it.

Where the process's only threaded BLAS is OpenBLAS (found in /proc/self/maps on Linux),
its own ``openblas_set_num_threads`` sets the count: threadpoolctl's import and scan of
every loaded library took 10-12 ms, most of the first analysis call of a short script.
Elsewhere threadpoolctl does it; without threadpoolctl nothing changes.
"""
from __future__ import annotations

import ctypes
import functools
import os
import sys
import threading
from typing import Optional

#: environment variables by which a user sets the BLAS thread count (pipeflex then keeps it)
USER_SETTINGS = ("OPENBLAS_NUM_THREADS", "GOTO_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS",
                 "BLIS_NUM_THREADS", "VECLIB_MAXIMUM_THREADS")

# threaded BLAS libraries other than OpenBLAS (their names in the process's mappings)
_OTHER_BLAS = ("mkl", "blis", "flexiblas", "accelerate")
# OpenBLAS's thread-count entry points: plain, 64-bit-integer builds (numpy and scipy wheels
# suffix them) and scipy-openblas wheels (prefix)
_PREFIXES = ("openblas_", "scipy_openblas_")
_SUFFIXES = ("", "64_")

_lock = threading.Lock()
_controller = None
_openblas = None  # (len(sys.modules) when looked, [(path, get, set) of each OpenBLAS] or None: threadpoolctl's)
_looked = -1  # len(sys.modules) when pin last looked for libraries (a library comes with a module)
_pinned = set()  # the paths of the OpenBLAS libraries set to one thread ("threadpoolctl": all by it)
_forced = False  # pinned by a sweep's worker: also over a user's setting


def _get_controller():
    global _controller
    if _controller is None:
        try:
            from threadpoolctl import ThreadpoolController
        except ImportError:
            _controller = False
        else:
            _controller = ThreadpoolController()
    return _controller


def _thread_functions(path):
    """(get, set) of the OpenBLAS at ``path``, or None if it exports neither spelling."""
    lib = ctypes.CDLL(path)  # mapped already: the loader's handle, nothing loads
    for prefix in _PREFIXES:
        for suffix in _SUFFIXES:
            get = getattr(lib, f"{prefix}get_num_threads{suffix}", None)
            put = getattr(lib, f"{prefix}set_num_threads{suffix}", None)
            if get is not None and put is not None:
                get.restype, put.restype, put.argtypes = ctypes.c_int, None, [ctypes.c_int]
                return get, put
    return None


def _find_openblas():
    """[(path, get, set)] of each OpenBLAS mapped into this process, or None where only
    threadpoolctl can tell (no /proc/self/maps, another threaded BLAS, an unknown build)."""
    try:
        with open("/proc/self/maps") as maps:
            fields = [line.split(None, 5) for line in maps]
    except OSError:
        return None
    paths = {f[5].strip() for f in fields if len(f) == 6 and ".so" in f[5]}
    found = []
    for path in sorted(paths):
        name = os.path.basename(path).lower()
        if any(other in name for other in _OTHER_BLAS):
            return None
        if "openblas" in name:
            try:
                functions = _thread_functions(path)
            except OSError:
                return None
            if functions is None:
                return None
            found.append((path,) + functions)
    return found or None


def _openblas_functions():
    """The OpenBLAS thread functions, found again when modules were imported since the
    last look (scipy, loaded on first use, may bring its own OpenBLAS)."""
    global _openblas
    if _openblas is None or (_openblas[1] is not None and _openblas[0] != len(sys.modules)):
        _openblas = (len(sys.modules), _find_openblas())
    return _openblas[1]


def user_setting() -> Optional[str]:
    """The environment variable by which the user set the BLAS thread count, or None."""
    return next((name for name in USER_SETTINGS if os.environ.get(name, "").strip()), None)


def pin(*, force: bool = False) -> None:
    """BLAS on one thread in this process from now on, unless the user set the thread
    count in the environment (:func:`user_setting`) and ``force`` is False (``force``: a
    sweep's worker process, one per core). Cheap after the first call: the libraries are
    looked for again only when modules were imported since (scipy, loaded on first use,
    may bring its own OpenBLAS), and each is set once, never restored."""
    global _looked, _forced
    if _looked == len(sys.modules) and (_forced or not force):
        return
    with _lock:
        _forced = _forced or force
        if not _forced and user_setting():
            _looked = len(sys.modules)
            return
        functions = _openblas_functions()
        if functions:
            for path, _, put in functions:
                if path not in _pinned:  # once: a count the user sets later stays
                    put(1)
                    _pinned.add(path)
        elif "threadpoolctl" not in _pinned:
            controller = _get_controller()
            if controller:
                controller.limit(limits=1, user_api="blas")
                _pinned.add("threadpoolctl")
        _looked = len(sys.modules)


def pinned(func):
    """Decorator of a public analysis: :func:`pin` before it runs."""
    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        pin()
        return func(*args, **kwargs)
    return wrapper
