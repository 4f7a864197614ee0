"""Module-level functions for tests/test_sweep.py: worker processes (a forked pool, Dask's
spawned workers) import them by name, so they cannot live inside the test functions."""
import json
import os
from pathlib import Path

import numpy as np

import pipeflex as pf


def cantilever(EI: float, n_elements: int = 8, mass_ratio: float = 0.2) -> pf.Model:
    """Cantilever pipe, L = 1 m, pipe + fluid 10 kg/m; mass_ratio = fluid / total [-]."""
    m = 10.0
    sec = pf.PipeSection(EI=EI, pipe_mass=(1 - mass_ratio) * m, fluid_mass=mass_ratio * m, EA=1e10 * EI)
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    b.add_line(n0, (1.0, 0.0, 0.0), n_elements, sec)
    b.clamp(n0)
    return b.build()


def critical_flow(EI: float, n_elements: int = 8, mass_ratio: float = 0.2) -> pf.CriticalFlow:
    """Critical mass flow [kg/s] of :func:`cantilever` (a pipeflex result)."""
    return pf.critical_mass_flow(cantilever(EI, n_elements, mass_ratio))


def quadratic(a: float, b: float = 0.0) -> dict:
    """Scalars, a fixed-shape array, an int and a string."""
    return {"y": a * a + b, "grad": np.array([2 * a, 1.0]), "n": int(a), "label": "neg" if a < 0 else "pos"}


def fails_on_negative(a: float) -> float:
    """a squared, a ValueError for a < 0."""
    if a < 0:
        raise ValueError(f"a = {a} < 0")
    return a * a


def logged(a: float, *, log: str, fail_at: float = None) -> float:
    """a + 1, writing one file per call into the folder ``log``; a ValueError at ``fail_at``.

    ``log/plan.json`` (see :func:`plan`), if present, stops the sweep: {"interrupt_at": a}
    raises KeyboardInterrupt at that point, {"exit_at": a} ends the worker process there
    (os._exit), {"exit_once_at": a} too, the first time only. A plan is outside the
    function's arguments, as a Ctrl-C is outside a sweep.
    """
    path = Path(log, "plan.json")
    todo = json.loads(path.read_text()) if path.exists() else {}
    if a == todo.get("interrupt_at"):
        raise KeyboardInterrupt
    if a == todo.get("exit_at"):
        os._exit(3)
    if a == todo.get("exit_once_at"):  # the plan goes with the process: a point that runs again succeeds
        path.unlink()
        os._exit(3)
    Path(log, f"call_{a!r}_{os.getpid()}_{np.random.default_rng().integers(1 << 62)}").touch()
    if a == fail_at:
        raise ValueError(f"no value at a = {a}")
    return a + 1.0


def plan(log, **todo) -> None:
    """Write (or, without arguments, remove) the plan of :func:`logged` in ``log``."""
    path = Path(log, "plan.json")
    if todo:
        path.write_text(json.dumps(todo))
    elif path.exists():
        path.unlink()


def calls(log: str) -> list:
    """The values of ``a`` :func:`logged` was called with (sorted)."""
    return sorted(float(p.name.split("_")[1]) for p in Path(log).iterdir() if p.name.startswith("call_"))


def blas_threads(a: float) -> int:
    """The BLAS threads of the process that runs the point."""
    from threadpoolctl import threadpool_info

    return max([p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"] or [0])


def ragged(a: int) -> dict:
    """A field whose shape changes with a (not allowed in a sweep)."""
    return {"v": np.zeros(a)}


def dies_at(a: float, *, at: float, how: str = "segfault") -> float:
    """a + 1, except at ``a == at``, where the process dies: "segfault" (SIGSEGV, as a
    crash in compiled code) or "exit" (os._exit(3))."""
    if a == at:
        if how == "exit":
            os._exit(3)
        import faulthandler
        faulthandler.disable()  # no traceback dump on the test's output
        import signal
        os.kill(os.getpid(), signal.SIGSEGV)
    return a + 1.0


def sleeps(a: float, *, log: str) -> float:
    """a, after writing this process's id into the folder ``log`` and sleeping 60 s."""
    import time
    Path(log, f"pid_{os.getpid()}").touch()
    time.sleep(60.0)
    return a
