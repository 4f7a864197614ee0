"""Benchmark: cost of a generalised-alpha step against the number of elements.

Cantilever pipe (seed 000 sec. 3.2, rho I_p = 1e-4 kg m, mdot = 20 kg/s), h = 1 ms,
started with a lateral velocity 0.2 m/s x / L (a nonlinear swing: from rest the
straight pipe would not move and Newton would converge in one iteration on one matrix). Per-step cost = (wall(2 k steps) - wall(k steps)) / k, which removes the set-up
(initial acceleration, output). Prints the log-log slope between successive sizes and
over all sizes: a banded iteration matrix should give a slope near 1.
Run: OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_scaling.py [--sizes 8 32 ...] [--steps 20]
"""
import argparse
import math
import os
import time

import numpy as np

import pipeflex as pf


def swinging(model, speed=0.2):
    """The reference state with lateral velocity speed x / L [m/s] (and the matching turn rate)."""
    s = model.initial_state()
    x = np.asarray(model.positions)[:, 0]
    L = x.max()
    v = np.zeros(6 * model.n_nodes)
    v[1::6] = speed * x / L
    v[5::6] = speed / L
    s.v = v
    return s


def wall(model, n_steps, h):
    st = swinging(model)
    t0 = time.perf_counter()
    r = pf.simulate(model, n_steps * h, integrator="generalized_alpha", step=h, n_outputs=2, work=False, state=st)
    return time.perf_counter() - t0, r.stats


def per_step(n_elements, k, h=1e-3, repeat=1):
    m = pf.scenes.cantilever_pipe(n_elements=n_elements, polar_inertia=1e-4, mass_flow=20.0)
    best = math.inf
    for _ in range(repeat):
        t1, _ = wall(m, k, h)
        t2, stats = wall(m, 2 * k, h)
        best = min(best, max(t2 - t1, 1e-9) / k)
    return best, stats


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", type=int, nargs="+", default=[8, 32, 128, 512, 2048, 8192])
    ap.add_argument("--steps", type=int, default=20, help="k: runs of k and 2 k steps")
    ap.add_argument("--repeat", type=int, default=3, help="best of (small sizes)")
    args = ap.parse_args()
    print(f"OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS', 'unset')}, "
          f"load average {open('/proc/loadavg').read().split()[:3]}")
    print(f"{'elements':>8s} {'DOF':>6s} {'per step [ms]':>14s} {'jacobians':>9s} {'Newton it.':>10s} {'slope':>6s}")
    rows = []
    for n in args.sizes:
        c, stats = per_step(n, args.steps, repeat=args.repeat if n <= 512 else 1)
        slope = ""
        if rows:
            slope = f"{math.log(c / rows[-1][1]) / math.log(n / rows[-1][0]):6.2f}"
        rows.append((n, c))
        print(f"{n:8d} {6 * n:6d} {1e3 * c:14.3f} {stats['jacobians']:9d} {stats['newton_iterations']:10d} {slope:>6s}",
              flush=True)
    if len(rows) > 1:
        (n0, c0), (n1, c1) = rows[0], rows[-1]
        print(f"log-log slope {n0} -> {n1} elements: {math.log(c1 / c0) / math.log(n1 / n0):.2f}")


if __name__ == "__main__":
    main()
