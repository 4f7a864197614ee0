"""Benchmark: work-precision on the peer's own scene (issue "One engine", "Peer figures").

The cantilever of Meijaard & Hakvoort's Fig. 3 as the peer comparison fixes it: 8 elements,
L = 1 m, EI = 10 N m^2, EA = 1e5 N, 8 + 2 kg/m, a 1.5 N lateral tip force, 30 kg/s from
t = 0, starting from the static deflection without flow. Quantity of interest: the tip's
lateral displacement at t = 2 s; error against our own converged reference (generalised-
alpha at h = 1e-4, 5e-5 and 2.5e-5 s with a tight Newton tolerance, Richardson-
extrapolated; the two extrapolations agree to ~1e-13 m).

For each accuracy target the cheapest run meeting it is reported, solve time (simulate
only, best of `--repeat`) and process time (a fresh interpreter: import, build, static
solve, simulate). The peer's figures (Exudyn 1.11, -O3, its 2D ALE-ANCF pipe, trapezoidal
rule, dense LU, modified Newton, best tuned setting) are those the issue measured on this
machine kind; the peer is not installed here (PyPI is unreachable).

Run: .venv/bin/python benchmarks/bench_limit_cycle.py [--repeat 5] [--quick]
"""
import argparse
import os
import subprocess
import sys
import time

import numpy as np

import pipeflex as pf

T_END = 2.0
# Peer (issue "One engine", Peer figures): best solve [s] and process [s] per target [m].
PEER = {1e-4: (0.115, 0.32), 1e-6: (0.92, 1.17)}


def scene(n_elements=8, EA=1e5):
    sec = pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0, EA=EA, rotary_inertia=(1e-3, 0.0, 0.0))
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    nodes = b.add_line(n0, (1.0, 0.0, 0.0), n_elements, sec)
    b.clamp(n0)
    b.add_load(nodes[-1], force=(0.0, 1.5, 0.0))
    model = b.build(mass_flow=30.0)
    return model, nodes[-1], pf.static_equilibrium(model, mass_flow=0.0).state


def tip(model, tip_node, state, **options):
    res = pf.simulate(model, T_END, state=state, n_outputs=2, progress=False, integrator="generalized_alpha",
                      **options)
    return float(res.x[-1, tip_node, 1]), res.stats


def reference(model, tip_node, state):
    tight = dict(newton_tol=1e-14, max_newton=30, work=False)
    y = [tip(model, tip_node, state, step=h, **tight)[0] for h in (1e-4, 5e-5, 2.5e-5)]
    r1, r2 = y[1] + (y[1] - y[0]) / 3, y[2] + (y[2] - y[1]) / 3
    return r2, abs(r2 - r1)


# (label, options) of the settings charted; steps are added per run.
SETTINGS = [
    ("default", {}),
    ("tuned: work=False, newton_tol=1e-6", dict(work=False, newton_tol=1e-6)),
]
STEPS = (2e-3, 1.2e-3, 1e-3, 5e-4, 2.5e-4, 1.2e-4, 1e-4)

PROCESS = """
import time; t0 = time.perf_counter()
import sys; sys.path.insert(0, {here!r})
from bench_limit_cycle import scene, tip
m, n, st = scene()
y, _ = tip(m, n, st, step={step!r}, **{options!r})
print(time.perf_counter() - t0)
"""


def process_time(step, options, repeat):
    best = np.inf
    code = PROCESS.format(here=os.path.dirname(os.path.abspath(__file__)), step=step, options=options)
    for _ in range(repeat):
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-c", code], check=True, capture_output=True)
        best = min(best, time.perf_counter() - t0)
    return best


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--quick", action="store_true", help="fewer steps, one repeat")
    args = ap.parse_args()
    repeat = 1 if args.quick else args.repeat
    steps = (1e-3, 1e-4) if args.quick else STEPS
    model, n, st = scene()
    ref, ref_err = reference(model, n, st)
    try:
        from threadpoolctl import threadpool_info
        blas = ", ".join(f"{i['internal_api']} {i['num_threads']}" for i in threadpool_info())
    except ImportError:
        blas = "unknown"
    print(f"reference tip displacement at 2 s = {ref:.12f} m (extrapolations differ by {ref_err:.1e} m)")
    print(f"load average {os.getloadavg()[0]:.2f}; BLAS threads: {blas}")
    print(f"{'setting':38s} {'step [s]':>9s} {'error [m]':>10s} {'solve [s]':>10s} {'steps':>6s} "
          f"{'it/step':>8s} {'tangents':>8s}")
    runs = []
    for label, options in SETTINGS:
        for h in steps:
            best = np.inf
            for _ in range(repeat):
                t0 = time.perf_counter()
                y, stats = tip(model, n, st, step=h, **options)
                best = min(best, time.perf_counter() - t0)
            err = abs(y - ref)
            runs.append((label, options, h, err, best))
            print(f"{label:38s} {h:9.1e} {err:10.2e} {best:10.4f} {stats['steps']:6d} "
                  f"{stats['newton_iterations'] / stats['steps']:8.2f} {stats['jacobians']:8d}")
    print("\ncheapest run per target, against the peer's best tuned setting (ratio < 1: pipeflex faster)")
    print(f"{'target [m]':>10s} {'setting':38s} {'step':>8s} {'solve [s]':>10s} {'process [s]':>11s} "
          f"{'peer solve':>10s} {'peer proc.':>10s} {'solve ratio':>11s} {'proc. ratio':>11s}")
    for target, (peer_solve, peer_process) in PEER.items():
        for label, options in SETTINGS:
            ok = [r for r in runs if r[0] == label and r[3] <= target]
            if not ok:
                print(f"{target:10.0e} {label:38s} {'none of the steps reaches the target':>40s}")
                continue
            _, opts, h, err, solve = min(ok, key=lambda r: r[4])
            proc = process_time(h, opts, repeat)
            print(f"{target:10.0e} {label:38s} {h:8.1e} {solve:10.4f} {proc:11.3f} {peer_solve:10.3f} "
                  f"{peer_process:10.2f} {solve / peer_solve:11.2f} {proc / peer_process:11.2f}")


if __name__ == "__main__":
    main()
