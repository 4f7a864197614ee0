"""Benchmark: work-precision on the peer's own scene (docs/performance.md).

The cantilever of Meijaard & Hakvoort's Fig. 3 as the peer comparison fixes it: 8 elements,
L = 1 m, EI = 10 N m^2, EA = 1e5 N, 8 + 2 kg/m, a 1.5 N lateral tip force, 30 kg/s from
t = 0, starting from the static deflection without flow. Quantity of interest: the tip's
lateral displacement at t = 2 s; error against our own converged reference (generalised-
alpha at h = 1e-4, 5e-5 and 2.5e-5 s with a tight Newton tolerance, Richardson-
extrapolated; the two extrapolations agree to ~1e-13 m).

For each accuracy target the cheapest run meeting it is reported, solve time (simulate
only, best of `--repeat`) and process time (a fresh interpreter: import, build, static
solve, simulate). Without `--peer` the peer's figures are those measured on another
machine (Exudyn 1.11, -O3, its 2D ALE-ANCF pipe, trapezoidal rule, dense LU, modified Newton,
relTol 1e-4 / 1e-6).

With `--peer` the peer itself runs beside pipeflex in the same process, alternating (Exudyn 1.11
built from source, `benchmarks/peer/exudyn_scene.py` says how; skipped with one line when
`import exudyn` fails): both codes sweep the same steps around each target, error against each
code's own converged reference; a (setting, step) qualifies for a target when it meets it at
that step and at every smaller step of the sweep (no lucky zero crossing of the error); the
largest qualifying step of each setting is timed again, best of `--repeat` alternating, and
the cheapest of each code as whole processes (`benchmarks/processes/peer_exudyn.py` for the
peer), alternating pairs, one BLAS thread each; ratio pipeflex / peer (< 1: pipeflex faster).

With `--rtol`: `pf.simulate` with no option but rtol (error-controlled steps) at rtol 1e-2 ... 1e-8
(`--rtols 1e-3,1e-5` for some): error, its ratio to rtol L, steps, solve time (median of `--repeat`).

Run: .venv/bin/python benchmarks/bench_limit_cycle.py [--repeat 5] [--quick] [--rtol]
     PYTHONPATH=<EXUDYN>/main/pythonDev .venv/bin/python benchmarks/bench_limit_cycle.py --peer [--repeat 5]
"""
import argparse
import os
import subprocess
import sys
import time

import numpy as np

import pipeflex as pf

T_END = 2.0
# Peer (measured on another machine, see the docstring): best solve [s] and process [s] per target [m].
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
EXTRAPOLATED = "extrapolated: h, h/2, rho_inf=1, newton_tol=1e-9"
DAMPED = "damped: rho_inf=0.6, work=False, newton_tol=1e-6"
SETTINGS = [
    ("default", {}),
    ("tuned: work=False, newton_tol=1e-6", dict(work=False, newton_tol=1e-6)),
    # numerical damping of the unresolved stiff modes: one Newton correction most steps
    (DAMPED, dict(rho_inf=0.6, work=False, newton_tol=1e-6)),
    (EXTRAPOLATED, dict(extrapolate=True, rho_inf=1.0, newton_tol=1e-9, work=False)),
    ("extrapolated, newton_tol=1e-8", dict(extrapolate=True, rho_inf=1.0, newton_tol=1e-8, work=False)),
]
STEPS = (2e-3, 1.2e-3, 1e-3, 5e-4, 2.5e-4, 1.2e-4, 1e-4)
# Richardson extrapolation (pf.simulate(extrapolate=True)) is fourth order: its own, longer
# steps, each dividing T_END (the output must be a whole number of steps).
EXTRAPOLATED_STEPS = (1e-2, 8e-3, 5e-3, 4e-3, 2.5e-3, 2e-3, 1.6e-3, 1.25e-3, 1e-3)


def steps_of(options, steps):
    """The steps a setting sweeps: its own if it extrapolates, else ``steps``."""
    return EXTRAPOLATED_STEPS if options.get("extrapolate") else steps

# The peer's settings (benchmarks/peer/exudyn_scene.run options) and the steps both codes sweep per target.
PEER_SETTINGS = [
    ("peer trapezoidal, mod. Newton, relTol 1e-2", dict(solver="trapezoidal", rel_tol=1e-2)),
    ("peer trapezoidal, mod. Newton, relTol 1e-3", dict(solver="trapezoidal", rel_tol=1e-3)),
    ("peer trapezoidal, mod. Newton, relTol 1e-4", dict(solver="trapezoidal", rel_tol=1e-4)),
    ("peer trapezoidal, mod. Newton, relTol 1e-6", dict(solver="trapezoidal", rel_tol=1e-6)),
    ("peer gen-alpha rho 1, mod. Newton, relTol 1e-2", dict(solver="generalized_alpha", rel_tol=1e-2)),
    ("peer gen-alpha rho 1, mod. Newton, relTol 1e-4", dict(solver="generalized_alpha", rel_tol=1e-4)),
    ("peer trapezoidal, sparse LU, relTol 1e-4", dict(solver="trapezoidal", rel_tol=1e-4, linear_solver="sparse")),
]
SIDE_STEPS = {1e-4: (2.5e-3, 2e-3, 1.6e-3, 1.25e-3, 1e-3, 8e-4, 6.25e-4),
              1e-6: (3.2e-4, 2.5e-4, 2e-4, 1.6e-4, 1.25e-4, 1e-4)}

PROCESS = """
import time; t0 = time.perf_counter()
import sys; sys.path.insert(0, {here!r})
from bench_limit_cycle import scene, tip
m, n, st = scene()
y, _ = tip(m, n, st, step={step!r}, **{options!r})
print(time.perf_counter() - t0)
"""


def process_command(step, options):
    return [sys.executable, "-c", PROCESS.format(here=os.path.dirname(os.path.abspath(__file__)), step=step,
                                                 options=options)]


def peer_process_command(step, options):
    script = os.path.join(os.path.dirname(os.path.abspath(__file__)), "processes", "peer_exudyn.py")
    return [sys.executable, script, repr(step), repr(options.get("rel_tol", 1e-6)),
            options.get("solver", "trapezoidal"), "1" if options.get("modified_newton", True) else "0",
            options.get("linear_solver", "dense")]


def wall(command):
    """Wall seconds of one fresh interpreter, one BLAS thread."""
    t0 = time.perf_counter()
    subprocess.run(command, check=True, capture_output=True, env=dict(os.environ, OPENBLAS_NUM_THREADS="1"))
    return time.perf_counter() - t0


def process_time(step, options, repeat):
    return min(wall(process_command(step, options)) for _ in range(repeat))


def blas_threads():
    try:
        from threadpoolctl import threadpool_info
        return ", ".join(f"{i['internal_api']} {i['num_threads']}" for i in threadpool_info())
    except ImportError:
        return "unknown"


def load_peer():
    """The peer's scene module, or None (one printed line) when exudyn cannot be imported."""
    sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "peer"))
    import exudyn_scene
    try:
        exudyn_scene.load()
    except ImportError as e:
        print(f"peer skipped: exudyn is not importable ({e}); benchmarks/peer/exudyn_scene.py says how to build it")
        return None
    return exudyn_scene


def qualifying(runs, target):
    """Per setting, its largest step meeting the target there and at every smaller step of the sweep:
    (label, options, step, error, seconds) runs."""
    best = {}
    for r in runs:
        same = [q for q in runs if q[0] == r[0] and q[2] <= r[2]]
        if all(q[3] <= target for q in same) and (r[0] not in best or r[2] > best[r[0]][2]):
            best[r[0]] = r
    return list(best.values())


def side_by_side(es, repeat, ref_pf, ref_peer):
    """Both codes on the same steps per target, alternating. Each setting's largest qualifying step is timed
    again (best of `repeat`, the two codes alternating); the cheapest of each code is run as whole processes
    (alternating pairs of fresh interpreters)."""
    model, n, st = scene()
    print(f"peer reference tip displacement at 2 s = {ref_peer:.12f} m; the two references differ by "
          f"{abs(ref_peer - ref_pf):.2e} m")
    print(f"{'setting':48s} {'step [s]':>9s} {'error [m]':>10s} {'solve [s]':>10s} {'it/step':>8s} {'tangents':>8s}")
    sweeps = {}
    for target, steps in SIDE_STEPS.items():
        runs_pf, runs_peer = [], []
        for label, options in SETTINGS:
            for h in steps_of(options, steps):
                t0 = time.perf_counter()
                y, stats = tip(model, n, st, step=h, **options)
                sec = time.perf_counter() - t0
                runs_pf.append((label, options, h, abs(y - ref_pf), sec))
                print(f"{'pipeflex ' + label:48s} {h:9.2e} {abs(y - ref_pf):10.2e} {sec:10.4f} "
                      f"{stats['newton_iterations'] / stats['steps']:8.2f} {stats['jacobians']:8d}")
        for h in steps:
            for label, options in PEER_SETTINGS:
                y, sec, stats = es.run(h, **options)
                runs_peer.append((label, options, h, abs(y - ref_peer), sec))
                print(f"{label:48s} {h:9.2e} {abs(y - ref_peer):10.2e} {sec:10.4f} "
                      f"{stats['newton_iterations'] / stats['steps']:8.2f} {stats['jacobians']:8d}")
        sweeps[target] = (qualifying(runs_pf, target), qualifying(runs_peer, target))
    print(f"\nload average {os.getloadavg()[0]:.2f}; BLAS threads here: {blas_threads()}; "
          "processes: OPENBLAS_NUM_THREADS=1")
    print(f"each setting's largest qualifying step, solve best of {repeat} (the codes alternating)")
    print(f"{'target':>7s} {'setting':48s} {'step':>8s} {'error':>9s} {'solve [s]':>10s}")
    chosen = {}
    for target, (cand_pf, cand_peer) in sweeps.items():
        best_pf, best_peer = [np.inf] * len(cand_pf), [np.inf] * len(cand_peer)
        for _ in range(repeat):
            for i, r in enumerate(cand_pf):
                t0 = time.perf_counter()
                tip(model, n, st, step=r[2], **r[1])
                best_pf[i] = min(best_pf[i], time.perf_counter() - t0)
            for i, r in enumerate(cand_peer):
                best_peer[i] = min(best_peer[i], es.run(r[2], **r[1])[1])
        for cand, best, code in ((cand_pf, best_pf, "pipeflex "), (cand_peer, best_peer, "")):
            for r, sec in zip(cand, best):
                print(f"{target:7.0e} {code + r[0]:48s} {r[2]:8.2e} {r[3]:9.2e} {sec:10.4f}")
        chosen[target] = [(cand[int(np.argmin(best))], min(best)) if cand else None
                          for cand, best in ((cand_pf, best_pf), (cand_peer, best_peer))]
    print(f"\ncheapest of each code per target: solve as above; process best and median of {repeat} alternating "
          "pairs; ratio pipeflex / peer")
    print(f"{'target':>7s} {'code':8s} {'setting':48s} {'step':>8s} {'error':>9s} {'solve [s]':>10s} "
          f"{'process [s]':>18s}")
    for target, (pf_best, peer_best) in chosen.items():
        if pf_best is None or peer_best is None:
            print(f"{target:7.0e} no qualifying run: pipeflex {pf_best is not None}, peer {peer_best is not None}")
            continue
        (pf_run, solve_pf), (peer_run, solve_peer) = pf_best, peer_best
        proc_pf, proc_peer = [], []
        for _ in range(repeat):
            proc_pf.append(wall(process_command(pf_run[2], pf_run[1])))
            proc_peer.append(wall(peer_process_command(peer_run[2], peer_run[1])))
        for code, r, solve, proc in (("pipeflex", pf_run, solve_pf, proc_pf),
                                     ("peer", peer_run, solve_peer, proc_peer)):
            print(f"{target:7.0e} {code:8s} {r[0]:48s} {r[2]:8.2e} {r[3]:9.2e} {solve:10.4f} "
                  f"{min(proc):8.3f} (med {np.median(proc):5.3f})")
        print(f"{target:7.0e} ratio pipeflex / peer: solve {solve_pf / solve_peer:.2f}, "
              f"process {min(proc_pf) / min(proc_peer):.2f} (medians {np.median(proc_pf) / np.median(proc_peer):.2f}); "
              f"load average {os.getloadavg()[0]:.2f}")


RTOLS = (1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8)
# The peer's cheapest solve [s] per target [m] measured side by side on this scene (docs/performance.md,
# "The peer's scene"): what the rtol runs are held against.
PEER_SIDE_BY_SIDE = {1e-4: 0.049, 1e-6: 0.227}


def rtol_sweep(model, n, st, ref, repeat, rtols=RTOLS):
    """pf.simulate with no option but rtol (error-controlled generalised-alpha; below
    EXTRAPOLATE_BELOW extrapolated over the controlled mesh halved ``halvings`` times): the
    error against the reference and its ratio to the request rtol L (L = 1 m here), the
    estimate the result reports, the steps (all runs), the solve time (median of ``repeat``),
    and the ratio to the peer's cheapest solve measured side by side for the tightest target
    the run meets."""
    print(f"\nrtol alone (median of {repeat}; load average {os.getloadavg()[0]:.2f}; BLAS threads: {blas_threads()})")
    print(f"{'rtol':>7s} {'error [m]':>10s} {'/ rtol L':>8s} {'estimate [m]':>12s} {'steps':>7s} {'halvings':>8s} "
          f"{'h min':>9s} {'h max':>9s} {'solve [s]':>10s} {'/ peer cheapest':>24s}")
    L = model.length_scale
    # the hand-tuned settings that set the targets (docs/performance.md), timed alongside: on
    # a loaded machine the ratios to them are what carries over
    for label, h, options in ((DAMPED, 1e-3, SETTINGS[2][1]), ("extrapolated, newton_tol=1e-8", 2.5e-3,
                                                                SETTINGS[4][1])):
        times = []
        for _ in range(repeat):
            t0 = time.perf_counter()
            y, _ = tip(model, n, st, step=h, **options)
            times.append(time.perf_counter() - t0)
        print(f"{'tuned':>7s} {abs(y - ref):10.2e} {'':8s} {label + f', {h:g} s':>45s} {float(np.median(times)):10.4f}")
    for rtol in rtols:
        times = []
        for _ in range(repeat):
            t0 = time.perf_counter()
            res = pf.simulate(model, T_END, state=st, n_outputs=2, progress=False, rtol=rtol)
            times.append(time.perf_counter() - t0)
        solve = float(np.median(times))
        err, s = abs(float(res.x[-1, n, 1]) - ref), res.stats
        peer = [(t, v) for t, v in sorted(PEER_SIDE_BY_SIDE.items()) if err <= t]
        vs = f"{solve / peer[0][1]:.2f} of {peer[0][1]:.3f} s ({peer[0][0]:.0e} m)" if peer else "-"
        halvings = (res.metadata.get("extrapolated") or {}).get("halvings", 0)
        print(f"{rtol:7.0e} {err:10.2e} {err / (rtol * L):8.2f} {s['error_estimate']:12.2e} {s['steps']:7d} "
              f"{halvings:8d} {s['smallest_step']:9.2e} {s['largest_step']:9.2e} {solve:10.4f} {vs:>24s}", flush=True)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--quick", action="store_true", help="fewer steps, one repeat")
    ap.add_argument("--peer", action="store_true", help="the peer (exudyn) beside pipeflex, alternating")
    ap.add_argument("--rtol", action="store_true", help="only the rtol sweep (error-controlled steps)")
    ap.add_argument("--rtols", default=None, help="with --rtol: comma-separated rtols (default 1e-2 ... 1e-8)")
    ap.add_argument("--peer-reference", action="store_true",
                    help="with --peer: recompute the peer's reference (about 40 s) instead of the recorded one")
    args = ap.parse_args()
    repeat = 1 if args.quick else args.repeat
    steps = (1e-3, 1e-4) if args.quick else STEPS
    model, n, st = scene()
    ref, ref_err = reference(model, n, st)
    print(f"reference tip displacement at 2 s = {ref:.12f} m (extrapolations differ by {ref_err:.1e} m)")
    print(f"load average {os.getloadavg()[0]:.2f}; BLAS threads: {blas_threads()}")
    if args.rtol:
        rtol_sweep(model, n, st, ref, repeat,
                   RTOLS if args.rtols is None else tuple(float(r) for r in args.rtols.split(",")))
        return
    if args.peer:
        es = load_peer()
        if es is not None:
            ref_peer = es.reference()[0] if args.peer_reference else es.REFERENCE
            side_by_side(es, repeat, ref, ref_peer)
        return
    print(f"{'setting':38s} {'step [s]':>9s} {'error [m]':>10s} {'solve [s]':>10s} {'steps':>6s} "
          f"{'it/step':>8s} {'tangents':>8s}")
    runs = []
    for label, options in SETTINGS:
        for h in steps_of(options, steps):
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
