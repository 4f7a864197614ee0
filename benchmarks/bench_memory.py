"""Benchmark: peak memory of every analysis against the model size (the aim: linear in
the model size).

Each (analysis, N) runs in a fresh interpreter; its peak resident set (ru_maxrss) is
compared with the same interpreter's peak just before the analysis (after importing
pipeflex and building the model, whose own growth is the "build" row): the difference is
what the analysis adds. Scene: bench_analyses_scaling.py's cantilever pipe with N elements
(6 N coordinates). Slopes are log-log between successive sizes; below a few MB the
allocator's granularity dominates, so the slopes that matter are those of the large sizes.
Run: .venv/bin/python benchmarks/bench_memory.py [--sizes 128 512 2048 8192]
"""
import argparse
import json
import math
import os
import subprocess
import sys

ANALYSES = ("build", "static", "linearize", "6 eigenvalues", "gen-alpha 5 steps", "IDA start", "steady rotation")

CHILD = r"""
import json, resource, sys
import numpy as np
import pipeflex as pf
sys.path.insert(0, {bench!r})
from bench_analyses_scaling import swinging

def peak():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0  # MB

n, what = {n}, {what!r}
before = peak()
if what == "steady rotation":
    m = pf.scenes.sprinkler(EI=100.0, n_elements=n)
else:
    m = pf.scenes.cantilever_pipe(n_elements=n, polar_inertia=1e-4)
if what != "build":
    st = pf.static_equilibrium(m, mass_flow=10.0) if what not in ("static", "steady rotation") else None
    lin = pf.linearize(m, st.state, mass_flow=10.0) if what == "6 eigenvalues" else None
    before = peak()
    if what == "static":
        pf.static_equilibrium(m, mass_flow=10.0)
    elif what == "linearize":
        pf.linearize(m, st.state, mass_flow=10.0)
    elif what == "6 eigenvalues":
        pf.eigenvalues(lin, n_modes=6, sigma=0.0)
    elif what == "gen-alpha 5 steps":
        pf.simulate(m, 5e-3, state=swinging(m), step=1e-3, n_outputs=2, progress=False,
                    integrator="generalized_alpha", work=False)
    elif what == "IDA start":
        pf.simulate(m, 1e-6, state=swinging(m), integrator="ida", n_outputs=2, progress=False, rtol=1e-3, atol=1e-6)
    elif what == "steady rotation":
        try:
            pf.steady_rotation(m)
        except pf.ConvergenceError:  # the 8192-element sprinkler: its Newton stalls at round-off
            print("null")
            sys.exit(0)
print(json.dumps(peak() - before))
"""


def measure(n, what):
    code = CHILD.format(bench=os.path.dirname(os.path.abspath(__file__)), n=n, what=what)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env={**os.environ, "MPLBACKEND": "Agg"})
    value = json.loads(out.stdout.strip().splitlines()[-1])
    return math.nan if value is None else float(value)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", type=int, nargs="+", default=[128, 512, 2048, 8192])
    ap.add_argument("--analyses", nargs="+", default=list(ANALYSES))
    ap.add_argument("--json", help="write the table here")
    args = ap.parse_args()
    print(f"load average {os.getloadavg()[0]:.2f}; peak RSS added by each analysis [MB]")
    rows = {}
    for what in args.analyses:
        rows[what] = [measure(n, what) for n in args.sizes]
        mb = rows[what]
        slopes = [math.log(max(b, 1e-3) / max(a, 1e-3)) / math.log(m / k) if a == a and b == b else math.nan
                  for (k, a), (m, b) in zip(zip(args.sizes, mb), zip(args.sizes[1:], mb[1:]))]
        print(f"| {what} | " + " | ".join(f"{v:.1f}" for v in mb) + " | " + " ".join(f"{s:.2f}" for s in slopes) + " |",
              flush=True)
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"sizes": args.sizes, "rows": rows}, f, indent=1)


if __name__ == "__main__":
    main()
