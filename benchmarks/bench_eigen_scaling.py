"""Benchmark: cost of a few eigenvalues and of the critical mass flow against model size.

Cantilever with flow (seed 000, Table 2: ``pf.scenes.cantilever_pipe(n_elements=N)``),
N = 8 .. 2048 (and 8192 with ``--big``). For each N: the time of
``pf.eigenvalues(lin, n_modes=8)`` at mdot = 20 kg/s (method "auto": dense below
``SPARSE_MIN_DOFS`` coordinates, sparse shift-invert Arnoldi above), of the dense
all-eigenvalue solve for comparison (N <= 256), and of ``pf.critical_mass_flow``, with
the log-log slope between successive sizes. Not a timed test: prints a table.

Run with one BLAS thread:
    OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_eigen_scaling.py [--big] [--repeat 3]
"""
import argparse
import os
import time

import numpy as np

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy's BLAS starts (if not already)

import pipeflex as pf  # noqa: E402
from pipeflex.analysis.eigen import SPARSE_MIN_DOFS  # noqa: E402
from pipeflex.seeds.seed000 import references as ref000  # noqa: E402


def best_of(f, repeat):
    times, out = [], None
    for _ in range(repeat):
        t = time.perf_counter()
        out = f()
        times.append(time.perf_counter() - t)
    return min(times), out


def slope(ns, ts, i):
    return np.log(ts[i] / ts[i - 1]) / np.log(ns[i] / ns[i - 1]) if i else float("nan")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--big", action="store_true", help="also N = 8192 (about a minute)")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--max", type=int, default=2048, help="largest N (powers of 2 from 8)")
    args = ap.parse_args()
    with open("/proc/loadavg") as f:
        print("load average:", f.read().strip(), "| OPENBLAS_NUM_THREADS =", os.environ.get("OPENBLAS_NUM_THREADS"))
    ns = [n for n in 2 ** np.arange(3, 14) if n <= args.max] + ([8192] if args.big else [])
    rows = []
    for n in ns:
        n = int(n)
        model = pf.scenes.cantilever_pipe(n_elements=n)
        lin = pf.linearize(model, mass_flow=20.0)
        t_few, eig = best_of(lambda: pf.eigenvalues(lin, n_modes=8), args.repeat)
        t_all = best_of(lambda: pf.eigenvalues(lin), 1)[0] if n <= 256 else float("nan")
        rep = args.repeat if n <= 1024 else 1
        path = "sparse" if model.n_dofs >= SPARSE_MIN_DOFS else "dense"
        try:
            t_cr, cr = best_of(lambda: pf.critical_mass_flow(model), rep)
            evals, mc = cr.evaluations, cr.mass_flow
        except pf.ConvergenceError as e:  # round-off of large models: docs/performance.md, "Critical flow at 8192 elements"
            t_cr, evals, mc = float("nan"), 0, float("nan")
            print(f"  N = {n}: critical_mass_flow failed: {str(e)[:110]}...")
        err = (mc - ref000.TABLE2_EXTRAPOLATED) / ref000.TABLE2_EXTRAPOLATED
        rows.append((n, model.n_dofs, path, t_few, t_all, t_cr, evals, mc, err))
        print(f"  N = {n}: done ({t_few * 1e3:.1f} ms, {t_cr:.2f} s)", flush=True)
    t_few = [r[3] for r in rows]
    t_cr = [r[5] for r in rows]
    print()
    print("| N | dofs | path | eigenvalues(n_modes=8) | slope | all (dense) | critical_mass_flow | slope "
          "| evals | mdot_cr [kg/s] | rel. err vs 25.005520 |")
    print("| ---: | ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    for i, (n, nd, path, tf, ta, tc, ev, mc, err) in enumerate(rows):
        all_s = f"{ta * 1e3:.1f} ms" if np.isfinite(ta) else "-"
        print(f"| {n} | {nd} | {path} | {tf * 1e3:.1f} ms | {slope(ns, t_few, i):.2f} | {all_s} | "
              f"{tc:.3f} s | {slope(ns, t_cr, i):.2f} | {ev} | {mc:.9f} | {err:+.2e} |")
    big = [i for i, n in enumerate(ns) if n >= 128]
    if len(big) >= 2:
        for name, ts in (("eigenvalues(n_modes=8)", t_few), ("critical_mass_flow", t_cr)):
            ok = [i for i in big if np.isfinite(ts[i])]
            p = np.polyfit(np.log([ns[i] for i in ok]), np.log([ts[i] for i in ok]), 1)[0]
            print(f"log-log slope for N >= 128, {name}: {p:.2f}")


if __name__ == "__main__":
    main()
