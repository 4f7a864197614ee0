"""One BLAS thread for small problems.

The analyses factorise and solve many small dense matrices (tens to hundreds of
coordinates). A threaded BLAS splits each call over its threads, whose start-up and
spin-waits cost more than the arithmetic: with OpenBLAS's two threads the steady rotation
of the sprinkler took 70-110 ms on a busy 2-core machine, and 21-25 ms with one
(docs/performance.md). Public analyses of models below SMALL_MODEL coordinates therefore
run with one BLAS thread; larger ones keep the user's setting.

Where the process's only threaded BLAS is OpenBLAS (found in /proc/self/maps on Linux),
its own ``openblas_set_num_threads`` sets the count: threadpoolctl's import and scan of
every loaded library took 10-12 ms, most of the first analysis call of a short script.
Elsewhere threadpoolctl does it; without threadpoolctl nothing changes.
"""
from __future__ import annotations

import contextlib
import ctypes
import functools
import os
import sys

#: models with fewer reduced coordinates than this run their analyses on one BLAS thread
SMALL_MODEL = 500

# threaded BLAS libraries other than OpenBLAS (their names in the process's mappings)
_OTHER_BLAS = ("mkl", "blis", "flexiblas", "accelerate")
# OpenBLAS's thread-count entry points: plain, 64-bit-integer builds (numpy and scipy wheels
# suffix them) and scipy-openblas wheels (prefix)
_PREFIXES = ("openblas_", "scipy_openblas_")
_SUFFIXES = ("", "64_")

_controller = None
_openblas = None  # (len(sys.modules) when looked, [(get, set) of each OpenBLAS] or None: threadpoolctl's task)


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
    """[(get, set)] of each OpenBLAS mapped into this process, or None where only
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
            found.append(functions)
    return found or None


def _openblas_functions():
    """The OpenBLAS thread functions, found again when modules were imported since the
    last look (scipy, loaded on first use, may bring its own OpenBLAS)."""
    global _openblas
    if _openblas is None or (_openblas[1] is not None and _openblas[0] != len(sys.modules)):
        _openblas = (len(sys.modules), _find_openblas())
    return _openblas[1]


@contextlib.contextmanager
def _openblas_one_thread(functions):
    before = [get() for get, _ in functions]
    try:
        for (_, put), n in zip(functions, before):
            if n != 1:
                put(1)
        yield
    finally:
        for (_, put), n in zip(functions, before):
            if n != 1:
                put(n)


def _size(obj):
    for get in (lambda o: o.n_dofs, lambda o: o.K.shape[0], lambda o: o.model.n_dofs):
        try:
            return int(get(obj))
        except (AttributeError, TypeError, IndexError):
            continue
    return None


def limited(size):
    """A context in which BLAS runs on one thread if ``size`` (coordinates) is small."""
    if size is None or size >= SMALL_MODEL:
        return contextlib.nullcontext()
    return one_thread()


def one_thread():
    """A context in which BLAS runs on one thread, e.g. around ARPACK: its level-2 BLAS
    on Krylov vectors of a few thousand entries took twice as long on two threads
    (shift-invert Arnoldi of a 1024-element pipe's block: 54 against 27 ms), and no
    slower up to 8192 elements."""
    functions = _openblas_functions()
    if functions:
        return _openblas_one_thread(functions)
    controller = _get_controller()
    if not controller:
        return contextlib.nullcontext()
    return controller.limit(limits=1, user_api="blas")


def pin_one_thread() -> None:
    """BLAS on one thread in this process from now on (a sweep's worker: one per core), by
    OpenBLAS's own call where it can, else threadpoolctl; nothing without either."""
    functions = _openblas_functions()
    if functions:
        for _, put in functions:
            put(1)
        return
    controller = _get_controller()
    if controller:
        controller.limit(limits=1, user_api="blas")


def small_problems_single_threaded(func):
    """Decorator of a public analysis whose first argument is a model (or a result with
    ``K``): one BLAS thread below SMALL_MODEL coordinates."""
    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        with limited(_size(args[0]) if args else None):
            return func(*args, **kwargs)
    return wrapper
