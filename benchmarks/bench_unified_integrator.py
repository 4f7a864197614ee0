"""Benchmark: the one generalised-alpha integrator against the two it replaced.

Runs the same scenes with whatever pipeflex is on PYTHONPATH and writes the outputs and
wall times (best of `--repeat`) to JSON; `--compare A B` prints the two side by side.
Before/after: build the earlier commit in a worktree, then

    PYTHONPATH=/path/to/old/python .venv/bin/python benchmarks/bench_unified_integrator.py --out old.json
    .venv/bin/python benchmarks/bench_unified_integrator.py --out new.json
    .venv/bin/python benchmarks/bench_unified_integrator.py --compare old.json new.json

Scenes: the peer's cantilever (8 elements, EA = 1e5 N, 30 kg/s, tip at t = 2 s,
h = 1 ms and 0.1 ms, newton_tol 1e-10, work=False); seed 004's FFRF cantilever (2 and
8 bodies x 20 elements, 2 s at 1 ms), curved pipe (8 bodies, E = 9.585 GPa, 4 s at 1 ms,
final angular velocity) and concrete printer (0 and 3 m/s, 0.34 s at 0.2 ms, nozzle).
Each with the integrator defaults of the version run.
"""
import argparse
import json
import os
import sys
import time


sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))


def timed(fn, repeat):
    best, out = float("inf"), None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def run(repeat):
    import bench_limit_cycle as blc
    from pipeflex.seeds.seed004 import studies as fs

    res = {}
    model, tip_node, state = blc.scene()
    for h in (1e-3, 1e-4):
        w, (y, st) = timed(lambda: blc.tip(model, tip_node, state, step=h, work=False, newton_tol=1e-10), repeat)
        res[f"element cantilever, tip [m], h = {h:g} s"] = [y, w, st["newton_iterations"], st["jacobians"]]
    for nb in (2, 8):
        w, tr = timed(lambda: fs.ffrf_cantilever_tip(n_bodies=nb), repeat)
        res[f"FFRF cantilever {nb} bodies, tip [m]"] = [float(tr.y[-1]), w, None, None]
    w, (s, r, _) = timed(lambda: fs.curved_pipe_run(9.585e9, step=1e-3), repeat)
    omega = fs.final_angular_velocity(r.t, r.node_angular_velocity(*s.info["base"])[:, 1])
    res["FFRF curved pipe, final omega [rad/s]"] = [float(omega), w, r.stats["newton_iterations"], r.stats["jacobians"]]
    for v in (0.0, 3.0):
        w, (s, r, path) = timed(lambda: fs.printer_run(v), repeat)
        res[f"FFRF printer {v:g} m/s, nozzle x [m]"] = [float(path[-1][0]), w, r.stats["newton_iterations"],
                                                       r.stats["jacobians"]]
    return res


def compare(a_path, b_path):
    a, b = json.load(open(a_path)), json.load(open(b_path))
    print(f"{'scene':44s} {'before':>14s} {'after':>14s} {'diff':>9s} {'before [s]':>10s} {'after [s]':>9s} "
          f"{'ratio':>6s}  iterations/matrices before -> after")
    for k in a:
        x, y = a[k], b[k]
        print(f"{k:44s} {x[0]:14.9f} {y[0]:14.9f} {abs(y[0] - x[0]):9.2e} {x[1]:10.3f} {y[1]:9.3f} "
              f"{y[1] / x[1]:6.2f}  {x[2]}/{x[3]} -> {y[2]}/{y[3]}")


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out")
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--compare", nargs=2)
    args = p.parse_args()
    if args.compare:
        compare(*args.compare)
    else:
        out = run(args.repeat)
        print(json.dumps(out, indent=1))
        if args.out:
            json.dump(out, open(args.out, "w"), indent=1)
