"""The peer comparison of docs/performance.md ("Three scenes", peer column) with `rtol` alone:
pipeflex's `simulate(model, 2.0, rtol=...)` (no other option) on the peer's scene against the
peer's cheapest setting that meets each target (Exudyn 1.11's trapezoidal rule, modified Newton:
relTol 1e-2 at 1.25 ms for 1e-4 m, relTol 1e-3 at 0.25 ms for 1e-6 m; `--deep`: relTol 1e-6 at
12.5 us for 1e-8 m, medians of min(repeat, 3)), alternating in one process, solve times, medians of
`repeat`; the load average before and after.

    PYTHONPATH=<EXUDYN>/main/pythonDev OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/peer_ratio.py [7] [--deep]

Skipped with one line when `import exudyn` fails (benchmarks/peer/exudyn_scene.py says how to build it).
"""
import os
import statistics
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path[:0] = [HERE, os.path.join(HERE, "peer")]

import pipeflex as pf  # noqa: E402

import bench_limit_cycle as b  # noqa: E402

REF_PF = -0.397335948070  # pipeflex's Richardson reference (docs/performance.md, "The peer's scene")


def main():
    try:
        import exudyn_scene as ex
        ex.load()
    except ImportError as e:
        print(f"peer not available ({e}): skipped")
        return
    model, tip_node, state = b.scene()

    def ours(rtol):
        t0 = time.perf_counter()
        r = pf.simulate(model, 2.0, state=state, rtol=rtol, n_outputs=2, progress=False)
        return abs(float(r.x[-1, tip_node, 1]) - REF_PF), time.perf_counter() - t0, r.stats["steps"]

    def peer(h, rel):
        y, s, st = ex.run(h, rel_tol=rel)
        return abs(y - ex.REFERENCE), s, st["steps"]

    repeat = int(next((a for a in sys.argv[1:] if a.isdigit()), 5))
    print(f"load average {os.getloadavg()[0]:.2f}, OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS')}")
    targets = [("1e-4", lambda: ours(1e-4), lambda: peer(1.25e-3, 1e-2), repeat),
               ("1e-6", lambda: ours(1e-6), lambda: peer(2.5e-4, 1e-3), repeat)]
    if "--deep" in sys.argv:  # the peer at 2.5e-5 s misses 1e-8 m (3.9e-8 m): 12.5 us is its cheapest
        targets.append(("1e-8", lambda: ours(1e-8), lambda: peer(1.25e-5, 1e-6), min(repeat, 3)))
    for name, a, p, n in targets:
        if name != "1e-8":
            a(), p()  # warm-up
        A, P = zip(*[(a(), p()) for _ in range(n)])
        ta, tp = statistics.median(x[1] for x in A), statistics.median(x[1] for x in P)
        print(f"target {name} m: pipeflex rtol={name} error {A[0][0]:.2e} ({A[0][2]} steps) {ta:.4f} s | peer error "
              f"{P[0][0]:.2e} ({P[0][2]} steps) {tp:.4f} s | ratio {ta / tp:.3f} (medians of {n})", flush=True)
    print(f"load average {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
