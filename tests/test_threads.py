"""Analyses on several threads give the serial results, bit for bit: pipeflex pins BLAS
to one thread once per process and never changes the count per call (pipeflex._blas;
docs/performance.md, BLAS threads).

Bit equality is the claim here: the same code on the same BLAS setting, only run from
four threads at once, must not depend on the scheduling."""
import json
import os
import subprocess
import sys
import textwrap
import threading
from pathlib import Path

import pytest

import pipeflex as pf

SIZES = [8, 16, 24, 32, 48, 64]


def fields(r):
    return (r.mass_flow, r.frequency, r.eigenvalue, r.mode.tobytes())


def test_critical_flows_on_four_threads_are_bit_identical_to_serial():
    models = {n: pf.scenes.cantilever_pipe(n_elements=n) for n in SIZES}
    serial = {n: fields(pf.critical_mass_flow(models[n])) for n in SIZES}
    shared = models[16]
    for _ in range(3):
        results, errors = {}, []

        def run(k):
            try:
                # different models, and one model shared by all four threads
                for n in SIZES[k::4] + [16]:
                    results[(k, n)] = fields(pf.critical_mass_flow(shared if n == 16 else models[n]))
            except Exception as exc:  # noqa: BLE001 -- reported below
                errors.append(exc)

        threads = [threading.Thread(target=run, args=(k,)) for k in range(4)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        assert not errors
        differ = sorted({n for (k, n), got in results.items() if got != serial[n]})
        assert differ == [], f"results on 4 threads differ from serial for n_elements={differ}"


def blas_threads_after(code: str, **env) -> list:
    """The BLAS libraries' thread counts after ``code`` ran in a new interpreter."""
    pytest.importorskip("threadpoolctl")
    base = {k: v for k, v in os.environ.items() if k not in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS",
                                                              "MKL_NUM_THREADS", "GOTO_NUM_THREADS",
                                                              "BLIS_NUM_THREADS", "VECLIB_MAXIMUM_THREADS")}
    out = subprocess.run([sys.executable, "-c", textwrap.dedent(f"""
        import json
        import pipeflex as pf
        {code}
        from threadpoolctl import threadpool_info
        print(json.dumps([p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"]))
        """)], env=dict(base, PYTHONPATH=str(Path(pf.__file__).parents[1]), **env), capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout.splitlines()[-1])


def test_an_analysis_pins_blas_to_one_thread_for_the_process_and_leaves_it_so():
    before = blas_threads_after("")
    if max(before, default=1) < 2:
        pytest.skip("BLAS runs one thread here already")
    # a small and a large model: the count stays one after each call, not restored
    after = blas_threads_after("pf.critical_mass_flow(pf.scenes.cantilever_pipe(n_elements=4)); "
                               "pf.linearize(pf.scenes.cantilever_pipe(n_elements=128))")
    assert after == [1] * len(before)


def test_a_thread_count_set_by_the_user_is_kept():
    assert blas_threads_after("pf.critical_mass_flow(pf.scenes.cantilever_pipe(n_elements=4))",
                              OPENBLAS_NUM_THREADS="2") == [2] * len(blas_threads_after("", OPENBLAS_NUM_THREADS="2"))
