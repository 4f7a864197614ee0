"""Benchmark: pipeflex.sweep serial, on a local process pool and on a Dask LocalCluster.

A 64-point critical-flow sweep (a 1 m cantilever pipe, 8 elements, over EI) in-process
(executor="serial"), on 2 local worker processes and on a 2-worker Dask LocalCluster
(threads_per_worker=1; cluster start-up not timed, workers warmed up by one sweep), and
the overhead per point of a trivial fn (the wall time of a sweep of it / points). The
three executors take turns, round after round, so that a changing load on the machine
falls on all of them alike.

Targets: 2 workers >= 1.8x faster than serial on 2
cores; overhead < 5 ms per point; the LocalCluster within 1.3x of the process pool.
Timings are the best of --repeat runs (the median in brackets); the load average before
and after says how busy the machine was (other work on the cores lowers the speed-up).
Run: .venv/bin/python benchmarks/bench_sweep.py [--points 64] [--elements 8] [--repeat 3]
"""
import argparse
import os
import statistics
import time

import numpy as np

import pipeflex as pf


def critical_flow(EI: float, n_elements: int = 8) -> pf.CriticalFlow:
    """Critical mass flow of a 1 m cantilever pipe (8 kg/m pipe, 2 kg/m fluid)."""
    sec = pf.PipeSection(EI=EI, pipe_mass=8.0, fluid_mass=2.0, EA=1e10 * EI)
    b = pf.ModelBuilder()
    inlet = b.add_node((0.0, 0.0, 0.0))
    b.add_line(inlet, (1.0, 0.0, 0.0), n_elements, sec)
    b.clamp(inlet)
    return pf.critical_mass_flow(b.build())


def trivial(a: float) -> float:
    return a


def blas_threads(a: float) -> int:
    from threadpoolctl import threadpool_info

    return max([p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"] or [0])


def interleaved(runs, repeat):
    """Run each of ``runs`` (name -> callable) once per round, ``repeat`` rounds, so that a
    changing load on the machine falls on all alike; name -> (best, median, last result)."""
    times = {k: [] for k in runs}
    last = {}
    for _ in range(repeat):
        for k, run in runs.items():
            t = time.perf_counter()
            last[k] = run()
            times[k].append(time.perf_counter() - t)
    return {k: (min(v), statistics.median(v), last[k]) for k, v in times.items()}


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--points", type=int, default=64)
    ap.add_argument("--elements", type=int, default=8)
    ap.add_argument("--trivial", type=int, default=2000, help="points of the overhead sweep")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    from functools import partial

    from dask.distributed import Client, LocalCluster
    from threadpoolctl import threadpool_info

    fn = partial(critical_flow, n_elements=args.elements)
    EI = np.geomspace(1.0, 100.0, args.points)
    tiny = np.arange(float(args.trivial))

    def sweep(f, values, **kw):  # trivial and blas_threads take "a", the critical flow "EI"
        return pf.sweep(f, progress=False, **kw, **{"EI" if f is fn else "a": values})

    load_before = os.getloadavg()
    t = time.perf_counter()
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                      silence_logs=40) as cluster, Client(cluster) as client:
        startup = time.perf_counter() - t
        sweep(fn, EI[:4], client=client)  # warm-up: the workers import pipeflex
        rows = interleaved({"serial": lambda: sweep(fn, EI, executor="serial"),
                            "pool": lambda: sweep(fn, EI, workers=2),
                            "dask": lambda: sweep(fn, EI, client=client)}, args.repeat)
        over = {k: v[0] for k, v in interleaved({"serial": lambda: sweep(trivial, tiny, executor="serial"),
                                                 "pool": lambda: sweep(trivial, tiny, workers=2),
                                                 "dask": lambda: sweep(trivial, tiny, client=client)},
                                                args.repeat).items()}
        pool_blas = set(sweep(blas_threads, [0.0, 1.0, 2.0, 3.0], workers=2).value.values.ravel().tolist())
        dask_blas = set(sweep(blas_threads, [0.0, 1.0, 2.0, 3.0], client=client).value.values.ravel().tolist())
    load_after = os.getloadavg()

    same = all(rows[k][2].identical(rows["serial"][2]) for k in ("pool", "dask"))
    main_blas = [(p["internal_api"], p["num_threads"]) for p in threadpool_info() if p["user_api"] == "blas"]
    print(f"{args.points}-point critical-flow sweep, cantilever with {args.elements} elements, "
          f"{os.cpu_count()} cores; best of {args.repeat} (median)")
    print(f"load average before {load_before[0]:.2f} {load_before[1]:.2f} {load_before[2]:.2f}, "
          f"after {load_after[0]:.2f} {load_after[1]:.2f} {load_after[2]:.2f}")
    print(f"BLAS threads: main process {main_blas}, pool workers {sorted(pool_blas)}, "
          f"Dask workers {sorted(dask_blas)}; Dask cluster start-up {startup:.2f} s (not timed below)")
    print()
    print(f"| executor | wall time | per point | overhead per point (trivial fn, {args.trivial} points) |")
    print("| --- | ---: | ---: | ---: |")
    names = {"serial": "serial (in-process)", "pool": "2 local worker processes",
             "dask": "Dask LocalCluster, 2 workers"}
    for k, (best, med, _) in rows.items():
        print(f"| {names[k]} | {best:.2f} s ({med:.2f} s) | {best / args.points * 1e3:.1f} ms | "
              f"{over[k] / args.trivial * 1e6:.0f} us |")
    speedup = rows["serial"][0] / rows["pool"][0]
    dask_ratio = rows["dask"][0] / rows["pool"][0]
    worst = max(over["pool"], over["dask"]) / args.trivial
    print()
    print(f"speed-up, 2 workers over serial: {speedup:.2f}x (target >= 1.8x) "
          f"{'ok' if speedup >= 1.8 else 'MISSED'}")
    print(f"overhead per point: {worst * 1e3:.3f} ms at most (target < 5 ms) {'ok' if worst < 5e-3 else 'MISSED'}")
    print(f"Dask LocalCluster / process pool: {dask_ratio:.2f} (target <= 1.3) "
          f"{'ok' if dask_ratio <= 1.3 else 'MISSED'}")
    print(f"the three Datasets identical: {same}")


if __name__ == "__main__":
    main()
