"""Benchmark: every analysis against the model size (the aim: log-log slope <= 1.1 from
8 to 8192 elements).

The cantilever pipe of Meijaard & Hakvoort's Table 2 (pf.scenes.cantilever_pipe, polar inertia 1e-4 kg m) with N
elements: build; static equilibrium at 10 kg/s; linearisation; 6 eigenvalues nearest 0
(sparse shift-invert from SPARSE_MIN_DOFS coordinates on); the static solve of the peer
scene's cantilever under its tip force (tip_loaded); the critical mass flow (up to
--max-critical elements); 5 generalised-alpha steps of 1 ms from a swinging state (per
step); the start of an IDA run (consistent initial values, 1 us of motion) from a smooth
swinging state (smooth_swinging: its step count does not depend on the mesh).
Wall times are the best of --repeat runs; slopes between successive sizes.
Then the floating-frame chain (pf.scenes.ffrf_cantilever_pipe, 4 elements per body, 1.5 N
tip force) with B bodies (--bodies): static equilibrium without flow, and a generalised-
alpha step at 30 kg/s (h = 1 ms; the difference of 50- and 100-step runs over 50).
With --mechanism also a mechanism's static equilibrium: B bodies rigidly joined along x
(4 m, 4 elements each, EI 1e5 N m^2, EA 1e8 N), the first on a ground hinge about z,
under gravity along -z (the hinge's free rotation unloaded: hinged_chain).
Then the rotating ANCF cantilever of seed 002 (pf.scenes.rotating_cantilever, Model A)
with N elements (--ancf): rotating_frequencies at gamma = 0 and 5 with 4 modes per family
(the 4th longitudinal mode lies above ~30 bending ones: ~40 eigenvalues near 0), a
Campbell diagram (gamma 0..8, 9 speeds, 4 branches), and eigenvalues(n_modes=40) of the
beam at rest. An analysis that took more than --budget seconds is skipped at larger N
(the dense path before: ~N^3).
Run: .venv/bin/python benchmarks/bench_analyses_scaling.py [--sizes 8 32 128 512 2048 8192]
     [--bodies 4 16 64 128] [--ancf 10 20 40 80 160 320 640 1280] [--parts pipe chain rotating]
     [--only linearize "IDA start"] [--repeat 5] [--cpu] [--mechanism]
(--only: these rows of the element table; the static equilibrium is solved anyway, as the
state to linearise about.)
"""
import argparse
import math
import os
import time

import numpy as np

import pipeflex as pf
from pipeflex.multibody import MultibodyBuilder, flexible_body, simulate as mb_simulate, static_equilibrium as mb_static


CLOCK = time.perf_counter  # --cpu: time.process_time (a loaded machine: the CPU time taken)


def best(f, repeat):
    t = np.inf
    out = None
    for _ in range(repeat):
        t0 = CLOCK()
        out = f()
        t = min(t, CLOCK() - t0)
    return t, out


def tip_loaded(n, force=1.5):
    """The peer scene's cantilever (bench_limit_cycle.scene) with n elements, its 1.5 N tip
    force deflecting it 0.05 m (4.3 degrees at the tip): a static solve with real Newton iterations (the straight
    pipe under flow alone is an equilibrium already, solved in 0 iterations)."""
    sec = pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0, EA=1e5, rotary_inertia=(1e-3, 0.0, 0.0))
    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    nodes = b.add_line(n0, (1.0, 0.0, 0.0), n, sec)
    b.clamp(n0)
    b.add_load(nodes[-1], force=(0.0, force, 0.0))
    return b.build()


def swinging(model, speed=0.2):
    """The straight cantilever turning rigidly at speed / L [rad/s] about its root, except
    the clamped root node: a kink of the rotation rate in the first element, which excites
    the modes at the mesh's own scale (the stiffer, the finer the mesh)."""
    s = pf.State.from_core(model.initial_state(), model)
    x = np.asarray(model.positions)[:, 0]
    v = s.v.copy()
    v[1::6] = speed * x / x.max()
    v[5::6] = speed / x.max()
    return pf.State(s.q, v, s.a, s.frames, s.ancf)


def smooth_swinging(model, speed=0.2):
    """A lateral velocity speed (x / L)^2 [m/s] with its slope as the rotation rate:
    smooth and compatible with the clamp (no rate at the root, no kink). The cubic
    elements represent it exactly, so it excites no mode at the mesh's scale: IDA's
    steps over the first microsecond do not depend on the mesh (11 from 128 to 8192
    elements, against 11 to 41 from the kinked start of swinging())."""
    s = pf.State.from_core(model.initial_state(), model)
    x = np.asarray(model.positions)[:, 0]
    L = x.max()
    v = s.v.copy()
    v[1::6] = speed * (x / L) ** 2
    v[5::6] = 2.0 * speed * x / L ** 2
    return pf.State(s.q, v, s.a, s.frames, s.ancf)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", type=int, nargs="+", default=[8, 32, 128, 512, 2048, 8192])
    ap.add_argument("--max-critical", type=int, default=2048)
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--bodies", type=int, nargs="+", default=[4, 16, 64, 128])
    ap.add_argument("--ancf", type=int, nargs="+", default=[10, 20, 40, 80, 160, 320, 640, 1280])
    ap.add_argument("--budget", type=float, default=60.0)
    ap.add_argument("--parts", nargs="+", default=["pipe", "chain", "rotating"],
                    choices=["pipe", "chain", "rotating"])
    ap.add_argument("--only", nargs="+", default=None, help="rows of the element table to run")
    ap.add_argument("--mechanism", action="store_true", help="also the hinged chain's static equilibrium")
    ap.add_argument("--cpu", action="store_true",
                    help="CPU time of the process instead of wall time (with one BLAS thread, on a shared machine)")
    args = ap.parse_args()
    global CLOCK
    if args.cpu:
        CLOCK = time.process_time
    print(f"load average {os.getloadavg()[0]:.2f}; OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS', 'unset')}; "
          f"{'CPU' if args.cpu else 'wall'} time")
    if "pipe" in args.parts:
        pipe(args, ap)
    if "chain" in args.parts:
        ffrf_chain(args)
    if "rotating" in args.parts:
        rotating(args)


def pipe(args, ap):
    names = ("build", "static", "static (tip load)", "linearize", "6 eigenvalues", "critical flow", "gen-alpha step", "IDA start")
    unknown = set(args.only or ()) - set(names)
    if unknown:
        ap.error(f"unknown rows {sorted(unknown)}; choose from {names}")

    def want(name):
        return args.only is None or name in args.only
    rows = {}
    for n in args.sizes:
        r = {}
        r["build"], m = best(lambda: pf.scenes.cantilever_pipe(n_elements=n, polar_inertia=1e-4), args.repeat)
        r["static"], st = best(lambda: pf.static_equilibrium(m, mass_flow=10.0), args.repeat if want("static") else 1)
        if want("static (tip load)"):
            loaded = tip_loaded(n)
            r["static (tip load)"], _ = best(lambda: pf.static_equilibrium(loaded), args.repeat)
        if want("linearize") or want("6 eigenvalues"):
            r["linearize"], lin = best(lambda: pf.linearize(m, st.state, mass_flow=10.0), args.repeat)
        if want("6 eigenvalues"):
            r["6 eigenvalues"], _ = best(lambda: pf.eigenvalues(lin, n_modes=6, sigma=0.0), args.repeat)
        if want("critical flow") and n <= args.max_critical:
            try:
                r["critical flow"], _ = best(lambda: pf.critical_mass_flow(m), 1)
            except pf.ConvergenceError as e:  # round-off of large models: docs/performance.md, "Critical flow at 8192 elements"
                print(f"  N = {n}: critical_mass_flow failed: {str(e)[:110]}...")
        sw = swinging(m)

        def steps(k):
            return pf.simulate(m, k * 1e-3, state=sw, step=1e-3, n_outputs=2, progress=False,
                               integrator="generalized_alpha", work=False)
        if want("gen-alpha step"):
            t5, _ = best(lambda: steps(5), args.repeat)
            t10, _ = best(lambda: steps(10), args.repeat)
            r["gen-alpha step"] = max(t10 - t5, 1e-9) / 5
        if want("IDA start"):
            # from the smooth start: the kinked one's mesh-scale modes take more steps over
            # the same 1 us on finer meshes (16 at 512 elements, 41 at 8192), which is the
            # scene's content, not the solver's cost (smooth_swinging)
            smooth = smooth_swinging(m)
            r["IDA start"], ida = best(lambda: pf.simulate(m, 1e-6, state=smooth, integrator="ida", n_outputs=2,
                                                             progress=False, rtol=1e-3, atol=1e-6), args.repeat)
            r["IDA / Newton it"] = r["IDA start"] / ida.stats["newton_iterations"]
        r = {k: v for k, v in r.items() if want(k) or (k == "IDA / Newton it" and want("IDA start"))}
        rows[n] = r
        print(f"{n:6d} elements: " + ", ".join(f"{k} {v:.3g} s" for k, v in r.items()), flush=True)
    table(rows, [k for k in names if want(k)] + (["IDA / Newton it"] if want("IDA start") else []))


def ffrf_chain(args):
    chain = {}
    for nb in args.bodies:
        s = pf.scenes.ffrf_cantilever_pipe(n_bodies=nb, elements_per_body=4, tip_force=1.5)
        r = {}
        r["FFRF static"], st = best(lambda: mb_static(s, mass_flow=0.0), args.repeat)

        def run(k):
            return mb_simulate(s, k * 1e-3, step=1e-3, state=st.state, mass_flow=30.0, n_outputs=2)
        t50, _ = best(lambda: run(50), args.repeat)
        t100, _ = best(lambda: run(100), args.repeat)
        r["FFRF step"] = max(t100 - t50, 1e-9) / 50
        if args.mechanism:
            h = hinged_chain(nb)
            r["hinged static"], _ = best(lambda: mb_static(h), args.repeat)
        chain[nb] = r
        print(f"{nb:6d} bodies ({s.n_coordinates} coordinates): " + ", ".join(f"{k} {v:.3g} s" for k, v in r.items()),
              flush=True)
    table(chain, ("FFRF static", "FFRF step") + (("hinged static",) if args.mechanism else ()), unit="bodies")


def hinged_chain(n):
    """n bodies rigidly joined along x (4 m), the first on a ground hinge about z, gravity
    along -z: a mechanism whose free rotation the loads leave alone."""
    sec = pf.PipeSection(EI=1e5, EA=1e8, pipe_mass=8.0, fluid_mass=2.0)
    body = flexible_body(length=4.0 / n, n_elements=4, section=sec)
    b = MultibodyBuilder()
    ids = [b.add_body(body, position=(4.0 / n * (k + 0.5), 0.0, 0.0)) for k in range(n)]
    b.hinge(ids[0], "start", (0.0, 0.0, 1.0))
    for k in range(n - 1):
        b.rigid(ids[k], "end", ids[k + 1], "start")
    b.set_gravity((0.0, 0.0, -9.81))
    return b.build()


def rotating(args):
    names = ("rotating 2 rates", "campbell 9 speeds", "40 eigenvalues")
    rows, over = {}, set()
    for n in args.ancf:
        beam = pf.scenes.rotating_cantilever(n_elements=n)
        lin = pf.linearize(beam, beam.initial_state())
        runs = {
            "rotating 2 rates": lambda: pf.rotating_frequencies(beam, gamma=[0.0, 5.0], n_modes=4),
            "campbell 9 speeds": lambda: pf.campbell(beam, gamma=np.linspace(0.0, 8.0, 9), n_modes=4),
            "40 eigenvalues": lambda: pf.eigenvalues(lin, n_modes=40),
        }
        r = {}
        for name, f in runs.items():
            if name in over:
                continue
            r[name], out = best(f, args.repeat)
            if r[name] > args.budget:
                over.add(name)
            if name == "rotating 2 rates":  # a wrong but fast run shows here
                r["w_T1, w_L4 at gamma 5"] = (out.transverse[1, 0], out.longitudinal[1, 3])
        rows[n] = r
        print(f"{n:6d} elements ({beam.n_dofs} coordinates): " + ", ".join(
            f"{k} {v:.4g} s" if not isinstance(v, tuple) else f"{k} {v[0]:.6f}, {v[1]:.4f}" for k, v in r.items()),
            flush=True)
    table(rows, names)


def table(rows, names, unit="elements"):
    sizes = list(rows)
    print(f"\n{unit:16s} " + " ".join(f"{n:>9d}" for n in sizes) + "   slopes")
    for name in names:
        vals = [rows[n].get(name) for n in sizes]
        slopes = [f"{math.log(b / a) / math.log(n1 / n0):.2f}" for (n0, a), (n1, b) in
                  zip(zip(sizes, vals), zip(sizes[1:], vals[1:])) if a and b]
        print(f"{name:16s} " + " ".join(f"{v:9.2e}" if v else f"{'-':>9s}" for v in vals) + "   " + " ".join(slopes))


if __name__ == "__main__":
    main()
