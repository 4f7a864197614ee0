"""Benchmark: one generalised-alpha step of the swinging cantilever against its size (target:
under 0.1 s at 8192 elements).

The scene and the measure of bench_analyses_scaling.py's "gen-alpha step" row: the
cantilever pipe (pf.scenes.cantilever_pipe, polar inertia 1e-4 kg m) with N elements,
started swinging (0.2 rad/s about the clamp), h = 1 ms, the integrator's defaults; the
step's cost is (run of 10 steps - run of 5 steps) / 5, so that building the integrator
(initial acceleration, the LU's analysis) and the output cancel. Reported per step: the
wall time (best of --repeat), the process CPU time (best of --repeat; steadier than the
wall time when other processes share the cores), and the Newton iterations and iteration
matrices of steps 6 to 10.
Run: .venv/bin/python benchmarks/bench_galpha_step.py [--sizes 512 2048 8192] [--repeat 5]
"""
import argparse
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import pipeflex as pf  # noqa: E402
from bench_analyses_scaling import swinging  # noqa: E402


def run(model, state, k):
    return pf.simulate(model, k * 1e-3, state=state, step=1e-3, n_outputs=2, progress=False,
                       integrator="generalized_alpha", work=False)


def timed(model, state, k, repeat):
    wall = cpu = float("inf")
    out = None
    for _ in range(repeat):
        w0, c0 = time.perf_counter(), time.process_time()
        out = run(model, state, k)
        wall = min(wall, time.perf_counter() - w0)
        cpu = min(cpu, time.process_time() - c0)
    return wall, cpu, out.stats


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", type=int, nargs="+", default=[512, 2048, 8192])
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    print(f"load average {os.getloadavg()[0]:.2f}; OPENBLAS_NUM_THREADS="
          f"{os.environ.get('OPENBLAS_NUM_THREADS', 'unset')}")
    print(f"{'elements':>8s} {'wall/step [ms]':>15s} {'CPU/step [ms]':>14s} {'iterations/step':>16s} "
          f"{'matrices/step':>14s}")
    for n in args.sizes:
        m = pf.scenes.cantilever_pipe(n_elements=n, polar_inertia=1e-4)
        sw = swinging(m)
        w5, c5, s5 = timed(m, sw, 5, args.repeat)
        w10, c10, s10 = timed(m, sw, 10, args.repeat)
        its = (s10["newton_iterations"] - s5["newton_iterations"]) / 5
        jac = (s10["jacobians"] - s5["jacobians"]) / 5
        print(f"{n:8d} {1e3 * (w10 - w5) / 5:15.3g} {1e3 * (c10 - c5) / 5:14.3g} {its:16.1f} {jac:14.1f}",
              flush=True)


if __name__ == "__main__":
    main()
