"""``sweep``: a function over a grid of parameter values, in parallel, resumable."""
from __future__ import annotations

import contextlib
import os
import pickle
from concurrent.futures import Executor, ProcessPoolExecutor
from typing import TYPE_CHECKING, Any, Callable, Dict, List, Optional, Sequence, Union

from . import executors
from .grid import check_values, function_identity, function_name, point_key, points
from .outcome import Outcome
from .store import PointStore
from .._blas import pin as pin_blas
from .._progress import Progress, logger

if TYPE_CHECKING:  # imported lazily: `import pipeflex` loads neither
    import distributed
    import xarray

#: The spellings of ``executor`` that run the points in this process, one after another.
SERIAL = ("serial",)


class SweepIncomplete(RuntimeError):
    """Some points of a sweep could not be run: the executor failed, not ``fn`` (a worker
    process of a pool of yours died: BrokenProcessPool; a Dask task killed its workers:
    KilledWorker). A worker of the default pool that dies does not make it: the points
    queued on that pool run again, each alone, and one whose process dies again fails
    with "WorkerDied: worker died: exit code ...".

    The finished points are kept (in the store, if one was given: re-running the sweep
    computes only the rest).

    Attributes:
        dataset: the sweep's Dataset with the finished points; the others hold NaN and
            the error "not computed: <reason>" (``attrs["n_unfinished"]`` counts them).
        unfinished: the parameters (dicts) of the points not computed.
        reasons: the distinct reasons, e.g. ["BrokenProcessPool: A process in the process
            pool was terminated abruptly ..."].
    """

    def __init__(self, message: str, *, dataset, unfinished: List[dict], reasons: List[str]):
        super().__init__(message)
        self.dataset = dataset
        self.unfinished = unfinished
        self.reasons = reasons


def sweep(fn: Callable[..., Any], /, *, grid: str = "product", executor: Union[None, str, Executor] = None,
          client: Optional["distributed.Client"] = None, workers: Optional[int] = None, progress: Optional[bool] = None,
          store: Union[None, str, os.PathLike] = None, retry_failed: bool = False,
          **parameters: Sequence) -> "xarray.Dataset":
    """Run ``fn(**point)`` at every point of a grid of parameter values; an ``xarray.Dataset``.

    Args:
        fn: the function of one point, called with one value of each parameter as keyword
            arguments. It returns a dict of numbers, strings and numpy arrays (one shape per
            field across the points), a number (the variable "value"), or a pipeflex result
            (its number, string and array fields, e.g. :class:`~pipeflex.CriticalFlow`).
            Worker processes (the default pool, Dask) need it picklable: a module-level
            function, or a ``functools.partial`` of one (fixed arguments go there).
        grid: "product" (every combination; the parameters are the Dataset's dimensions,
            in the order given) or "zip" (the i-th values together; one dimension "point",
            the parameters its coordinates).
        executor: None: a local process pool, one worker per core (``workers``), one BLAS
            thread per worker; the workers die with this process, and the points queued on
            a worker that died run again, each alone (a point that dies again fails with
            "WorkerDied: worker died: exit code -11 (SIGSEGV), ..."). "serial": in this
            process, one point after another
            (debugging, baselines). Or any ``concurrent.futures.Executor`` (a
            ThreadPoolExecutor, a pool of yours; it is not shut down).
        client: a ``dask.distributed.Client``: the points run on its cluster.
        workers: processes of the default pool (default: the cores available).
        progress: None (default): a progress bar in a notebook or on a terminal once the
            sweep has taken 3 s, else (a log, CI) a line on the logger ``"pipeflex"``
            every 15 s; True: the bar from the start (or the lines on stderr); False:
            nothing (docs/user_guide.md, Progress and logging). Each point done or failed
            is logged at DEBUG, the sweep's start and end at INFO.
        store: a folder: each finished point is written to it at once, and a re-run with
            the same store computes only the points not in it (an interrupted sweep loses
            no finished point; the grid may grow between runs). It belongs to one ``fn``
            and its fixed (functools.partial) arguments; another's is a ValueError.
        retry_failed: with a store, compute again the points that failed before (else a
            stored failure is kept).
        **parameters: name=list of values (numbers, strings, bools).

    Returns:
        The Dataset: the parameters as coordinates; one variable per field (complex
        fields as ``<field>_real`` and ``<field>_imag``, a field's own axes as
        ``<field>_dim_<k>``); ``error``: "" where the point succeeded, else
        "ExceptionType: message" (the point holds NaN, ints and bools then become
        floats); ``attrs``: ``n_points``, ``n_failed``, ``grid``, ``fn``. It saves with
        ``ds.to_netcdf(path)``.

    Raises:
        ValueError: an unknown ``grid``; "zip" with lists of unequal lengths; no parameter,
            an empty list or (product) a repeated value (also 1, 1.0 and True: equal as
            coordinates); both ``executor`` and ``client``; a damaged ``sweep.json`` in
            ``store``.
        TypeError: ``fn`` not callable, or not picklable for worker processes; a parameter
            that is not a list of numbers/strings/bools; an unknown ``executor``.
        SweepIncomplete: points an executor of yours or Dask could not run (a worker
            process died); the finished ones are kept (attribute ``dataset``, and the store).
        KeyboardInterrupt: Ctrl-C (or raised by ``fn``): the sweep stops; finished points
            are in the store.

    A parameter cannot take the name of one of the options above (``grid``, ``store``, ...):
    rename it in a wrapper of ``fn``.

    Example (docs/sweeps.md has more)::

        import math
        import pipeflex as pf

        def radius(x, y):
            return {"r": math.hypot(x, y), "angle": math.atan2(y, x)}

        ds = pf.sweep(radius, x=[3.0, 5.0], y=[4.0, 12.0])   # on one process per core
        print(ds.r.values)             # [[ 5. 12.36931688] [ 6.40312424 13.]]
        print(ds.r.sel(x=5.0, y=12.0).item(), ds.attrs["n_failed"])   # 13.0 0
    """
    _check_options(fn, executor, client, workers)
    values = {name: check_values(name, v) for name, v in parameters.items()}
    pts = points(grid, values)
    _check_picklable(fn, executor, client)

    fn_name = function_name(fn)
    points_store = None if store is None else PointStore(store, function_identity(fn))
    keys = [point_key(p) for p in pts]
    first: Dict[str, int] = {}  # a point repeated (zip) is computed once
    for i, k in enumerate(keys):
        first.setdefault(k, i)
    outcomes: List[Optional[Outcome]] = [None] * len(pts)
    todo = []
    for k, i in first.items():
        stored = points_store.load(k, pts[i]) if points_store else None
        if stored is not None and not (retry_failed and stored[0]):
            outcomes[i] = stored
        else:
            todo.append((i, pts[i]))

    unfinished: Dict[int, str] = {}
    n_failed = sum(1 for o in outcomes if o is not None and o[0])
    with contextlib.ExitStack() as stack:
        bar = stack.enter_context(_progress_bar(progress, len(first), len(first) - len(todo)))
        logger.info("sweep %s: %d points to compute, %d from the store", fn_name, len(todo), len(first) - len(todo))
        reports = stack.enter_context(_runner(fn, todo, executor, client, workers))
        for i, outcome, reason in reports:
            if outcome is None:
                unfinished[i] = reason
                logger.debug("sweep %s: point %s not computed: %s", fn_name, pts[i], reason)
            else:
                outcomes[i] = outcome
                if points_store:
                    points_store.save(keys[i], pts[i], outcome)
                if outcome[0]:
                    n_failed += 1
                    bar.note(failed=n_failed)
                logger.debug("sweep %s: point %s %s%s", fn_name, pts[i], "failed: " if outcome[0] else "done", outcome[0])
            bar.advance()
    logger.info("sweep %s: %d points, %d failed, %d not computed", fn_name, len(first), n_failed, len(unfinished))
    for i, k in enumerate(keys):
        j = first[k]
        outcomes[i] = outcomes[j]
        if j in unfinished:
            unfinished[i] = unfinished[j]

    from .dataset import build
    ds = build(grid, values, outcomes, unfinished, {"grid": grid, "fn": fn_name})
    if unfinished:
        reasons = sorted(set(unfinished.values()))
        where = ".dataset" + (f" and the store {str(store)!r}" if store is not None else "")
        again = "re-run the sweep with the same store" if store is not None else "re-run the sweep with a store"
        raise SweepIncomplete(
            f"{len(unfinished)} of {len(pts)} points were not computed ({'; '.join(reasons)}); the "
            f"{len(pts) - len(unfinished)} finished points are in {where}: {again} to compute only the rest. "
            f"First not computed: {pts[min(unfinished)]}",
            dataset=ds, unfinished=[pts[i] for i in sorted(unfinished)], reasons=reasons)
    return ds


def _check_options(fn, executor, client, workers) -> None:
    if not callable(fn):
        raise TypeError(f"fn must be callable, not a {type(fn).__name__}")
    if executor is not None and client is not None:
        raise ValueError("give either executor= or client= (a Dask client), not both")
    if workers is not None:
        if executor is not None or client is not None:
            raise ValueError("workers= sizes the default process pool; it does not go with executor= or client=")
        if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
            raise ValueError(f"workers must be a positive int, not {workers!r}")
    if isinstance(executor, str) and executor not in SERIAL:
        raise ValueError(f"executor must be None, {' or '.join(map(repr, SERIAL))} or a concurrent.futures.Executor, "
                         f"not {executor!r}")
    if executor is not None and not isinstance(executor, (str, Executor)):
        raise TypeError(f"executor must be None, 'serial' or a concurrent.futures.Executor, "
                        f"not a {type(executor).__name__}")
    if client is not None:
        try:
            from distributed import Client
        except ImportError as exc:
            raise TypeError(f"client= needs dask.distributed ({exc})") from None
        if not isinstance(client, Client):
            raise TypeError(f"client must be a dask.distributed.Client, not a {type(client).__name__}")


def _check_picklable(fn, executor, client) -> None:
    """fn must pickle for the default pool and any ProcessPoolExecutor (pickle), and for
    Dask (cloudpickle, which also takes lambdas and local functions)."""
    if executor is None and client is None or isinstance(executor, ProcessPoolExecutor):
        dumps, where = pickle.dumps, "worker processes"
        # pickle sends a function by name: the workers import it
        advice = ("pickle sends a function by its name, so define it at module level of a script or module "
                  "(fixed arguments with functools.partial, which must pickle too)")
    elif client is not None:
        from distributed.protocol.pickle import dumps
        where = "Dask workers"
        # cloudpickle sends a function of __main__ (a script, a notebook), a lambda or a local
        # function by value, with the globals, defaults and closure values it uses
        advice = ("Dask sends a function of a script or notebook by value, with the globals and arguments it "
                  "uses: one of them cannot be pickled (create it inside fn, or import fn from a module)")
    else:
        return
    try:
        dumps(fn)
    except Exception as exc:  # noqa: BLE001 -- PicklingError, AttributeError (local object), TypeError
        raise TypeError(
            f"fn ({function_name(fn)}) cannot be pickled for the {where} ({type(exc).__name__}: {exc}); {advice}; "
            "or use executor='serial' or a ThreadPoolExecutor") from None


def _progress_bar(progress: Optional[bool], total: int, done: int) -> Progress:
    """The sweep's progress under the package's policy (:mod:`pipeflex._progress`)."""
    return Progress(progress, total, initial=done, unit="point", desc="sweep")


@contextlib.contextmanager
def _runner(fn, todo, executor, client, workers):
    """The (index, outcome, reason) reports of the points; a pool of ours is started and
    ended here (killed on Ctrl-C)."""
    if not todo:
        yield iter(())
    elif isinstance(executor, str):
        pin_blas()
        with contextlib.closing(executors.run_serial(fn, todo)) as reports:
            yield reports
    elif client is not None:
        window = max(64, 4 * sum(client.nthreads().values()))
        with contextlib.closing(executors.run_dask(client, fn, todo, window)) as reports:
            yield reports
    elif executor is not None:
        window = 4 * (getattr(executor, "_max_workers", None) or executors.cores())
        if not isinstance(executor, ProcessPoolExecutor):
            pin_blas()  # its threads run in this process
        with contextlib.closing(executors.run_executor(executor, fn, todo, window)) as reports:
            yield reports
    else:
        n = min(workers or executors.cores(), len(todo))
        with contextlib.closing(executors.run_pool(fn, todo, n)) as reports:
            yield reports
