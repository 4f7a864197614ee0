"""Sweeps that survive any point: a point that kills its worker process fails alone with
its cause, the pool's workers die with the sweep's process, an interrupted sweep leaves
no thread or process behind, repeated grid values and damaged store files are refused
by name (docs/sweeps.md, Failures)."""
import functools
import json
import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

import pipeflex as pf
import sweep_functions as sf

xr = pytest.importorskip("xarray")

A = [0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0]
TESTS = Path(__file__).parent


def run_script(code: str, **kwargs) -> subprocess.Popen:
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(Path(pf.__file__).parents[1]), str(TESTS)]))
    return subprocess.Popen([sys.executable, "-c", textwrap.dedent(code)], env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, **kwargs)


def alive(pid: int) -> bool:
    """The process exists and is not a zombie."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().split(") ")[1][0] != "Z"
    except (FileNotFoundError, IndexError):
        return False


@pytest.mark.parametrize("how, cause", [("segfault", "exit code -11 (SIGSEGV)"), ("exit", "exit code 3")])
def test_a_point_that_kills_its_worker_fails_alone_with_its_cause_and_the_others_finish(tmp_path, caplog, how,
                                                                                        cause):
    fn = functools.partial(sf.dies_at, at=3.0, how=how)
    ds = pf.sweep(fn, a=A, workers=2, store=tmp_path / "store", progress=False)
    error = ds.error.sel(a=3.0).item()
    assert error.startswith(f"WorkerDied: worker died: {cause}"), error
    assert "the point {'a': 3.0} killed its worker process" in caplog.text
    assert ds.attrs["n_failed"] == 1 and "n_unfinished" not in ds.attrs
    others = [a for a in A if a != 3.0]
    np.testing.assert_array_equal(ds.value.sel(a=others), np.array(others) + 1)
    assert np.isnan(ds.value.sel(a=3.0).item())
    # the failure is stored with the others: a re-run computes nothing and gives the same
    again = pf.sweep(fn, a=A, workers=2, store=tmp_path / "store", progress=False)
    xr.testing.assert_identical(again, ds)


def test_a_dying_point_among_many_does_not_stop_the_rest(tmp_path):
    a = [float(k) for k in range(40)]
    ds = pf.sweep(functools.partial(sf.dies_at, at=17.0), a=a, workers=2, progress=False)
    failed = [x for x in a if ds.error.sel(a=x).item()]
    assert failed == [17.0]


def test_the_pool_workers_die_with_the_sweep_process_on_kill_9(tmp_path):
    log = tmp_path / "log"
    log.mkdir()
    proc = run_script(f"""
        import functools, pipeflex as pf, sweep_functions as sf
        pf.sweep(functools.partial(sf.sleeps, log={str(log)!r}), a=[0.0, 1.0], workers=2, progress=False)
        """)
    try:
        deadline = time.monotonic() + 60
        while len(list(log.iterdir())) < 2 and time.monotonic() < deadline and proc.poll() is None:
            time.sleep(0.1)
        workers = [int(p.name.split("_")[1]) for p in log.iterdir()]
        assert len(workers) == 2, proc.stderr.read() if proc.poll() is not None else "workers did not start"
        proc.kill()
        proc.wait()
        deadline = time.monotonic() + 10
        while any(alive(pid) for pid in workers) and time.monotonic() < deadline:
            time.sleep(0.1)
        assert not [pid for pid in workers if alive(pid)], "workers outlived their parent"
    finally:
        proc.kill()
        for p in log.iterdir():
            pid = int(p.name.split("_")[1])
            if alive(pid):
                os.kill(pid, signal.SIGKILL)


def test_an_interrupted_pool_sweep_leaves_no_thread_or_process(tmp_path):
    log = tmp_path / "log"
    log.mkdir()
    proc = run_script(f"""
        import functools, json, multiprocessing, os, signal, sys, threading, time, traceback
        import pipeflex as pf, sweep_functions as sf
        from pathlib import Path
        before = {{t.name for t in threading.enumerate()}}
        # Ctrl-C once both workers run a point
        def interrupt():
            while len(list(Path({str(log)!r}).iterdir())) < 2:
                time.sleep(0.05)
            os.kill(os.getpid(), signal.SIGINT)
        threading.Thread(target=interrupt, name="ctrl-c", daemon=True).start()
        try:
            pf.sweep(functools.partial(sf.sleeps, log={str(log)!r}), a=[float(k) for k in range(20)], workers=2,
                     progress=False)
        except KeyboardInterrupt:
            pass
        # the queue's feeder thread may take a moment to end on a loaded machine: left means
        # still running 5 s later
        deadline = time.monotonic() + 5.0
        while time.monotonic() < deadline and any(t.name not in before and t.name != "ctrl-c"
                                                  for t in threading.enumerate()):
            time.sleep(0.05)
        # each left thread with where it waits, so that a failure says why
        frames = sys._current_frames()
        left = [t.name + " " + repr(getattr(t, "_target", None)) + " waiting in "
                + "".join(traceback.format_stack(frames[t.ident])[-3:]) for t in threading.enumerate()
                if t.name not in before and t.name != "ctrl-c" and t.ident in frames]
        print(json.dumps([left, [p.pid for p in multiprocessing.active_children()]]))
        """)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 0, err
    threads, children = json.loads(out.splitlines()[-1])
    assert threads == [] and children == []
    workers = [int(p.name.split("_")[1]) for p in log.iterdir()]
    assert not [pid for pid in workers if alive(pid)]


def test_stopping_a_pool_whose_manager_failed_its_clean_up_leaves_no_feeder_thread():
    # the manager thread normally closes the call queue; one that dies in its clean-up (seen
    # once under load) must not leave the queue's feeder thread behind
    proc = run_script("""
        import concurrent.futures.process as cfp, json, threading, time
        from pipeflex.sweeps.executors import default_pool, stop_pool
        def fails(self):
            raise RuntimeError("clean-up failed")
        cfp._ExecutorManagerThread.join_executor_internals = fails
        before = {t.name for t in threading.enumerate()}
        pool = default_pool(2)
        futures = [pool.submit(time.sleep, 5.0) for _ in range(6)]
        time.sleep(0.5)
        stop_pool(pool)
        print(json.dumps([t.name for t in threading.enumerate() if t.name not in before]))
        """)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 0, err
    assert json.loads(out.splitlines()[-1]) == []


@pytest.mark.parametrize("values, shown", [([1, 1.0], "as 1 and 1.0"), ([True, 1], "as True and 1"),
                                           ([0.5, 0.5], "0.5"), ([float("nan"), float("nan")], "nan")])
def test_repeated_grid_values_are_refused_by_name(values, shown):
    with pytest.raises(ValueError, match=rf"parameter 'speed' repeats the value .*{shown}"):
        pf.sweep(sf.quadratic, a=[1.0], speed=values, executor="serial", progress=False)


def test_equal_values_in_a_zip_grid_are_separate_points():
    ds = pf.sweep(sf.fails_on_negative, a=[1, 1.0, 2.0], grid="zip", executor="serial", progress=False)
    assert ds.sizes["point"] == 3


def test_a_damaged_store_description_names_the_file_and_the_remedy(tmp_path):
    store = tmp_path / "store"
    pf.sweep(sf.fails_on_negative, a=[1.0], executor="serial", store=store, progress=False)
    for damage in ("{not json", "[]", "\xff"):
        (store / "sweep.json").write_text(damage, encoding="latin-1")
        with pytest.raises(ValueError, match=r"sweep\.json' is damaged .*another store folder, or delete the file"):
            pf.sweep(sf.fails_on_negative, a=[1.0], executor="serial", store=store, progress=False)


def test_a_damaged_point_file_is_named_and_computed_again(tmp_path):
    store = tmp_path / "store"
    pf.sweep(sf.fails_on_negative, a=[1.0, 2.0], executor="serial", store=store, progress=False)
    damaged = sorted(store.glob("*.npz"))[0]
    damaged.write_bytes(b"PK\x03\x04 not a zip")
    with pytest.warns(UserWarning, match=rf"point file '.*{damaged.name}' is damaged \(BadZipFile"):
        ds = pf.sweep(sf.fails_on_negative, a=[1.0, 2.0], executor="serial", store=store, progress=False)
    np.testing.assert_array_equal(ds.value, [1.0, 4.0])
    with np.load(damaged) as f:  # replaced by the recomputed point
        assert "__point__" in f
