"""Running the points: in-process, on a concurrent.futures executor, or on a Dask cluster.

Each runner is a generator of ``(index, outcome, reason)``: ``outcome`` for a point that
ran (its own exception included), or ``outcome=None`` and the ``reason`` (the executor's
exception, e.g. BrokenProcessPool, KilledWorker) for a point that could not be run. A
KeyboardInterrupt (Ctrl-C, or raised by fn) cancels what has not started and propagates.
"""
from __future__ import annotations

import multiprocessing
import os
import signal
from collections import deque
from concurrent.futures import FIRST_COMPLETED, BrokenExecutor, Executor, ProcessPoolExecutor, wait
from typing import Any, Callable, Dict, Iterable, Iterator, List, Optional, Tuple

from .outcome import Outcome, WorkerDied, error_text, evaluate, evaluate_pinned, init_pool_worker
from .._progress import logger

Report = Tuple[int, Optional[Outcome], Optional[str]]
Todo = Iterable[Tuple[int, dict]]


def cores() -> int:
    """Cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


def default_pool(workers: int) -> ProcessPoolExecutor:
    """One process per worker, one BLAS thread each, Ctrl-C left to the parent; the
    workers die with this process (the parent-death signal follows the thread that forks
    them: this one, which submits the points; a pool spawning workers later would not)."""
    return ProcessPoolExecutor(max_workers=workers, initializer=init_pool_worker, initargs=(os.getpid(),))


def stop_pool(pool: ProcessPoolExecutor) -> None:
    """End a pool of ours at once (after Ctrl-C): its workers are killed, not awaited, and
    its threads (the manager, the queue's feeder) joined, so that nothing is left running."""
    processes = list((getattr(pool, "_processes", None) or {}).values())
    manager = getattr(pool, "_executor_manager_thread", None)  # shutdown forgets it
    call_queue = getattr(pool, "_call_queue", None)  # and this
    for proc in processes:
        proc.kill()
    pool.shutdown(wait=False, cancel_futures=True)
    # the manager thread sees the killed workers, fails the pending futures and closes the
    # call queue (joining its feeder thread); then it ends
    if manager is not None:
        manager.join(timeout=10.0)
    # a manager that ended another way (an exception in its clean-up under load) leaves the
    # queue's feeder thread waiting for items: closing the queue ends it
    feeder = getattr(call_queue, "_thread", None)
    if feeder is not None and feeder.is_alive():
        call_queue.close()
        feeder.join(timeout=5.0)
    for proc in processes:
        proc.join(timeout=1.0)


def run_pool(fn: Callable, todo: Todo, workers: int) -> Iterator[Report]:
    """The default pool of ``workers`` processes. When a worker dies (a crash in compiled
    code, os._exit, the out-of-memory killer), the pool breaks and the points that were
    queued on it run again one by one, each alone in a process of its own
    (:func:`run_alone`): a point whose process dies again fails with the cause
    (:class:`~pipeflex.sweeps.outcome.WorkerDied`), the others give their results. The
    rest of the points then go on in a new pool, so every point ends computed or failed."""
    queue = deque(todo)
    while queue:
        n = min(workers, len(queue))
        pool = default_pool(n)
        suspects: List[Tuple[int, dict]] = []
        try:
            yield from run_executor(pool, fn, queue, 4 * n, suspects=suspects)
        except BaseException:
            stop_pool(pool)
            raise
        pool.shutdown(wait=True)
        if suspects:
            logger.info("sweep: a worker process died; running the %d points it may have been running again, "
                        "each alone", len(suspects))
        for index, point in suspects:
            yield index, run_alone(fn, point), None


def run_alone(fn: Callable, point: dict) -> Outcome:
    """``fn(**point)`` in a new process of its own (one BLAS thread, dies with this one);
    its outcome, or the failure :class:`~pipeflex.sweeps.outcome.WorkerDied` with the
    process's exit code if it died."""
    context = multiprocessing.get_context()
    receive, send = context.Pipe(duplex=False)
    proc = context.Process(target=_alone, args=(fn, point, send, os.getpid()), name="pipeflex-sweep-point",
                           daemon=True)
    proc.start()
    send.close()  # ours: the child's end stays open in the child only, so its death is EOF here
    try:
        try:
            kind, value = receive.recv()
        except EOFError:
            kind, value = None, None
        proc.join()
    except BaseException:  # Ctrl-C: the point's process goes too
        proc.kill()
        proc.join()
        raise
    finally:
        receive.close()
    if kind == "outcome":
        return value
    if kind == "raise":  # KeyboardInterrupt or SystemExit raised by fn: the sweep stops, as in a pool
        raise value
    cause = worker_exit(proc.exitcode)
    logger.warning("sweep: the point %s killed its worker process when it ran alone (%s); it is recorded as "
                   "failed", point, cause)
    return error_text(WorkerDied(
        f"worker died: {cause}, running this point alone (retried after a pool worker died): fn crashed or "
        "ended its process at these parameters (a crash in compiled code, os._exit, out of memory)")), {}


def worker_exit(code: Optional[int]) -> str:
    """'exit code -11 (SIGSEGV)', 'exit code 3' for a process's exit code."""
    if code is not None and code < 0:
        try:
            return f"exit code {code} ({signal.Signals(-code).name})"
        except ValueError:
            pass
    return f"exit code {code}"


def _alone(fn: Callable, point: dict, send, parent: int) -> None:
    init_pool_worker(parent)
    try:
        message = ("outcome", evaluate(fn, point))
    except BaseException as exc:  # noqa: BLE001 -- KeyboardInterrupt, SystemExit: the parent re-raises
        message = ("raise", exc)
    send.send(message)
    send.close()


def run_serial(fn: Callable, todo: Todo) -> Iterator[Report]:
    for index, point in todo:
        yield index, evaluate(fn, point), None


def run_executor(executor: Executor, fn: Callable, todo: Todo, window: int, *,
                 suspects: Optional[List[Tuple[int, dict]]] = None) -> Iterator[Report]:
    """At most ``window`` points queued on the executor at a time. With a list
    ``suspects``, a broken executor (a worker died) reports nothing for the points it had:
    they go into ``suspects``, and the points not yet submitted stay in ``todo`` (a deque)."""
    queue = todo if isinstance(todo, deque) else deque(todo)
    pending: Dict[Any, int] = {}
    points: Dict[int, dict] = {}
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
                points[index] = point
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
                        if suspects is not None:
                            suspects.append((index, points[index]))
                            continue
                    yield index, None, error_text(exc)
                except BaseException as exc:  # KeyboardInterrupt raised by fn in a worker
                    stop = stop or exc
                else:
                    yield index, outcome, None
            if stop is not None:
                yield from _finished(pending)
                raise stop
        if suspects is None:
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
