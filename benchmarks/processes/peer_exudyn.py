# the peer's side of peer_1e4.py (needs exudyn, see benchmarks/peer/exudyn_scene.py for building it from source):
# Exudyn 1.11's ALE-ANCF pipe on the same scene, static start, 2 s with the flow; whole process.
# Arguments: step [s] (default 1.25 ms), Newton relative tolerance (1e-4), solver (trapezoidal), modified Newton (1),
# linear solver (dense)
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "peer"))
import exudyn_scene as es  # noqa: E402

a = sys.argv[1:]
y, _, _ = es.run(float(a[0]) if a else 1.25e-3, a[2] if len(a) > 2 else "trapezoidal",
                 rel_tol=float(a[1]) if len(a) > 1 else 1e-4, modified_newton=a[3] != "0" if len(a) > 3 else True,
                 linear_solver=a[4] if len(a) > 4 else "dense")
print(y)
