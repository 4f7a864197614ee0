"""The fuzz driver's watchdog (tests/fuzz/run_fuzz.py): a case that never returns is
recorded as a hang, one that kills its worker as a crash, whatever becomes of the stack
dump; the run goes on with the cases left.

The cases come from a fake cases module (no pipeflex model), so each check takes about
the short ``case_timeout`` plus a worker start."""
from __future__ import annotations

import sys
import textwrap
import time
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent / "fuzz"))
import run_fuzz  # noqa: E402  (tests/fuzz/run_fuzz.py: make fuzz)

pytestmark = pytest.mark.skipif(sys.platform != "linux", reason="the watchdog reads /proc and uses SIGUSR1")

CASE_TIMEOUT = 1.0  # s

FAKE_MODELS = textwrap.dedent('''
    """Fake fuzz cases: each family misbehaves in one way."""
    import json
    import os
    import re
    import signal
    import time

    from hypothesis import strategies as st


    class Bug(AssertionError):
        pass


    def cases(family):
        return st.fixed_dictionaries({"family": st.just(family), "i": st.integers(0, 10**6)})


    def dumps(c):
        return json.dumps(c, sort_keys=True)


    def run_case(c):
        f = c["family"]
        if f == "sleep":  # blocked in C with the GIL released
            time.sleep(3600)
        elif f == "spin":  # spinning in C with the GIL held (catastrophic backtracking)
            re.match(r"(a*)*b", "a" * 64)
        elif f == "segv":
            os.kill(os.getpid(), signal.SIGSEGV)
        elif f == "dump_crashes":  # a hang whose stack dump kills the worker
            signal.signal(signal.SIGUSR1, lambda *_: os.kill(os.getpid(), signal.SIGSEGV))
            time.sleep(3600)
        elif f == "bug":
            raise Bug("a wrong result")
        return "ok"
''')


@pytest.fixture
def fake(tmp_path):
    path = tmp_path / "fake_models.py"
    path.write_text(FAKE_MODELS)
    out = tmp_path / "out"
    out.mkdir()

    def drive(family, n=1, family_timeout=60.0):
        t0 = time.monotonic()
        r = run_fuzz.drive(family, n, 0, out, CASE_TIMEOUT, family_timeout, models_path=path)
        return r, time.monotonic() - t0

    return drive


def test_a_case_sleeping_in_c_is_a_hang_with_its_stack(fake):
    r, dt = fake("sleep")
    assert r["counts"] == {"hang": 1}
    (bug,) = r["bugs"]
    assert bug["error"] == "hang (case)"
    assert bug["case"]["family"] == "sleep"
    # the stack the worker dumped on request names the sleeping line; the threads from /proc
    assert "fake_models.py" in bug["traceback"] and "run_case" in bug["traceback"]
    assert "thread " in bug["traceback"]
    assert dt < 30


def test_a_case_spinning_with_the_gil_held_is_a_hang(fake):
    r, dt = fake("spin")
    assert r["counts"] == {"hang": 1}
    assert r["bugs"][0]["error"] == "hang (case)"
    assert dt < 30


def test_a_hang_whose_stack_dump_crashes_the_worker_is_still_a_hang(fake):
    r, dt = fake("dump_crashes")
    assert r["counts"] == {"hang": 1}
    (bug,) = r["bugs"]
    assert bug["error"] == "hang (case)"
    assert "died with exit -11 while dumping" in bug["traceback"]
    assert dt < 30


def test_a_segfault_is_a_crash_and_the_run_goes_on(fake):
    r, dt = fake("segv", n=2)
    # each case kills its worker; the driver restarts it for the case left
    assert r["counts"] == {"crash": 2}
    assert all(b["error"] == "crash (exit -11)" and b["case"]["family"] == "segv" for b in r["bugs"])
    assert "Fatal Python error: Segmentation fault" in r["bugs"][0]["traceback"]
    assert dt < 30


def test_cases_that_return_are_counted_not_timed_out(fake):
    r, _ = fake("ok", n=5)
    assert r["counts"] == {"ok": 5} and r["bugs"] == []
    r, _ = fake("bug", n=2)
    assert r["counts"] == {"bug": 2} and len(r["bugs"]) == 2 and r["bugs"][0]["error"] == "a wrong result"


def test_a_worker_past_the_family_time_limit_is_a_hang(fake):
    # the family limit is shorter than the case timeout: the family's own timer ends it
    r, dt = fake("sleep", family_timeout=0.5 * CASE_TIMEOUT)
    assert r["counts"] == {"hang": 1}
    assert r["bugs"][0]["error"] == "hang (family time limit)"
    assert dt < 30
