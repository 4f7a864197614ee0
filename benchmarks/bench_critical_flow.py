"""Benchmark: critical mass flows of seed 000 Table 2 (cantilever, 2..32 elements).

Targets: the five flows together < 1 s; one 32-element flow < 0.2 s.
Prints the median of repeated runs and the ratio to the target.
Run: .venv/bin/python benchmarks/bench_critical_flow.py [--repeat N]
"""
import argparse
import statistics
import time

import pipeflex as pf


def timed(f, repeat):
    f()  # warm-up (imports, first-call overheads)
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        f()
        times.append(time.perf_counter() - t)
    return statistics.median(times), min(times)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    models = {n: pf.scenes.cantilever_pipe(n_elements=n) for n in (2, 4, 8, 16, 32)}
    rows = []
    for n, m in models.items():
        med, best = timed(lambda: pf.critical_mass_flow(m), args.repeat)
        r = pf.critical_mass_flow(m)
        rows.append((n, med, best, r.evaluations))
        print(f"{n:3d} elements: median {med * 1e3:7.1f} ms  (min {best * 1e3:6.1f} ms, "
              f"{r.evaluations} eigen-evaluations, mdot_cr = {r.mass_flow:.9f} kg/s)")
    total_med, total_best = timed(lambda: [pf.critical_mass_flow(m) for m in models.values()], args.repeat)
    one = rows[-1][1]
    print(f"five flows together: median {total_med:.3f} s (min {total_best:.3f} s); "
          f"target 1 s -> ratio {total_med / 1.0:.2f}")
    print(f"one 32-element flow: median {one:.3f} s; target 0.2 s -> ratio {one / 0.2:.2f}")


if __name__ == "__main__":
    main()
