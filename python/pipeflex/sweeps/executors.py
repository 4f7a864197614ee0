"""Running the points: in-process, on a concurrent.futures executor, or on a Dask cluster.

Each runner is a generator of ``(index, outcome, reason)``: ``outcome`` for a point that
ran (its own exception included), or ``outcome=None`` and the ``reason`` (the executor's
exception, e.g. BrokenProcessPool, KilledWorker) for a point that could not be run. A
KeyboardInterrupt (Ctrl-C, or raised by fn) cancels what has not started and propagates.
"""
from __future__ import annotations

import os
from collections import deque
from concurrent.futures import FIRST_COMPLETED, BrokenExecutor, Executor, ProcessPoolExecutor, wait
from typing import Any, Callable, Dict, Iterable, Iterator, Optional, Tuple

from .outcome import Outcome, error_text, evaluate, evaluate_pinned, init_pool_worker

Report = Tuple[int, Optional[Outcome], Optional[str]]
Todo = Iterable[Tuple[int, dict]]


def cores() -> int:
    """Cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


def default_pool(workers: int) -> ProcessPoolExecutor:
    """One process per worker, one BLAS thread each, Ctrl-C left to the parent."""
    return ProcessPoolExecutor(max_workers=workers, initializer=init_pool_worker)


def stop_pool(pool: ProcessPoolExecutor) -> None:
    """End a pool of ours at once (after Ctrl-C): its workers are killed, not awaited."""
    for proc in list((getattr(pool, "_processes", None) or {}).values()):
        proc.terminate()
    pool.shutdown(wait=False, cancel_futures=True)


def run_serial(fn: Callable, todo: Todo) -> Iterator[Report]:
    for index, point in todo:
        yield index, evaluate(fn, point), None


def run_executor(executor: Executor, fn: Callable, todo: Todo, window: int) -> Iterator[Report]:
    """At most ``window`` points queued on the executor at a time."""
    queue = deque(todo)
    pending: Dict[Any, int] = {}
    broken: Optional[str] = None
    try:
        while queue or pending:
            while queue and broken is None and len(pending) < window:
                index, point = queue[0]
                try:
                    future = executor.submit(evaluate, fn, point)
                except RuntimeError as exc:  # a broken or shut-down executor
                    broken = error_text(exc)
                    break
                queue.popleft()
                pending[future] = index
            if not pending:
                break
            try:
                done, _ = wait(pending, return_when=FIRST_COMPLETED)
            except BaseException:  # Ctrl-C: keep what has finished, then stop
                yield from _finished(pending)
                raise
            stop = None
            for future in sorted(done, key=pending.get):
                index = pending.pop(future)
                try:
                    outcome = future.result()
                except Exception as exc:  # noqa: BLE001 -- the executor failed, not fn (evaluate catches fn's)
                    if isinstance(exc, BrokenExecutor):
                        broken = error_text(exc)
                    yield index, None, error_text(exc)
                except BaseException as exc:  # KeyboardInterrupt raised by fn in a worker
                    stop = stop or exc
                else:
                    yield index, outcome, None
            if stop is not None:
                yield from _finished(pending)
                raise stop
        for index, _ in queue:
            yield index, None, broken or "the executor stopped"
    finally:
        for future in pending:
            future.cancel()


def _finished(pending: Dict[Any, int]) -> Iterator[Report]:
    """The points among ``pending`` whose results are in (taken out of ``pending``)."""
    for future in [f for f in pending if f.done() and not f.cancelled()]:
        index = pending.pop(future)
        try:
            outcome = future.result()
        except BaseException:  # noqa: BLE001 -- only results are wanted here
            continue
        yield index, outcome, None


def run_dask(client, fn: Callable, todo: Todo, window: int) -> Iterator[Report]:
    """On a ``dask.distributed.Client``: at most ``window`` points submitted at a time."""
    from distributed import as_completed

    queue = deque(todo)
    pending: Dict[str, Tuple[Any, int]] = {}  # key -> (future, index)
    futures = as_completed(loop=client.loop, raise_errors=False)

    def submit():
        index, point = queue.popleft()
        future = client.submit(evaluate_pinned, fn, point, pure=False)
        pending[future.key] = future, index
        futures.add(future)

    try:
        while queue and len(pending) < window:
            submit()
        for future in _interruptible(futures, pending, queue):
            _, index = pending.pop(future.key)
            try:
                outcome = future.result()
            except Exception as exc:  # noqa: BLE001 -- KilledWorker, a lost connection: not fn's failure
                yield index, None, error_text(exc)
            else:
                yield index, outcome, None
            finally:
                future.release()
            if queue:
                submit()
    finally:
        if pending:
            client.cancel([f for f, _ in pending.values()])


def _interruptible(futures, pending: Dict[str, Tuple[Any, int]], queue: deque):
    """Iterate ``as_completed``; on Ctrl-C, submit no more and first yield the futures
    already finished."""
    iterator = iter(futures)
    while True:
        try:
            future = next(iterator)
        except StopIteration:
            return
        except BaseException:
            queue.clear()
            yield from [f for f, _ in list(pending.values()) if f.status == "finished"]
            raise
        yield future
