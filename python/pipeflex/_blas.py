"""One BLAS thread for small problems.

The analyses factorise and solve many small dense matrices (tens to hundreds of
coordinates). A threaded BLAS splits each call over its threads, whose start-up and
spin-waits cost more than the arithmetic: with OpenBLAS's two threads the steady rotation
of the sprinkler took 70-110 ms on a busy 2-core machine, and 21-25 ms with one
(docs/performance.md). Public analyses of models below SMALL_MODEL coordinates therefore
run with one BLAS thread; larger ones keep the user's setting. Without threadpoolctl
nothing changes.
"""
from __future__ import annotations

import contextlib
import functools

#: models with fewer reduced coordinates than this run their analyses on one BLAS thread
SMALL_MODEL = 500

_controller = None


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
    controller = _get_controller()
    if not controller:
        return contextlib.nullcontext()
    return controller.limit(limits=1, user_api="blas")


def small_problems_single_threaded(func):
    """Decorator of a public analysis whose first argument is a model (or a result with
    ``K``): one BLAS thread below SMALL_MODEL coordinates."""
    @functools.wraps(func)
    def wrapper(*args, **kwargs):
        with limited(_size(args[0]) if args else None):
            return func(*args, **kwargs)
    return wrapper
