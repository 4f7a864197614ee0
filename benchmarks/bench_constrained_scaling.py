"""Benchmark: the constrained linearisation against the model size (the aim: log-log
slope <= 1.15 from 256 elements, a coupled arm within 3x the element model at 1024).

The coupled arm: seed 000's cantilever (1 m, EI = 10 N m^2, EA = 1e5 N, 8 + 2 kg/m) of N
elements, floating, its root rigidly joined to the end of a short hub body (0.2 m, 2
elements, 1e4 times as stiff as a body as compliant as the arm) clamped to the ground
(tests/helpers.on_clamped_hub), fed from a still reservoir; beside it the same arm
clamped to the ground, an element model. For each N: ``pf.linearize`` about the static
equilibrium at 10 kg/s (best of --repeat), split for the coupled arm into the core's
``linear_matrices`` (of the coupled system) and the reduction to the constraints' null space
(pipeflex.analysis.constrained: the core's compressed columns as scipy matrices, the sparse
basis, T^T X T); the ratio coupled / element and the log-log slopes between successive
sizes ("core and rest": the coupled time less the reduction's, mostly the core's assembly).
With --critical also ``pf.critical_mass_flow`` of both at the sizes given (one run each).
Wall (or with --cpu CPU) times in microseconds (whole numbers).
Run: OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/bench_constrained_scaling.py
     [--sizes 64 128 256 512 1024 2048 4096] [--repeat 5] [--critical 64 256] [--cpu]
"""
import argparse
import math
import os
import time

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # before numpy's BLAS starts (if not already)

import pipeflex as pf  # noqa: E402
from pipeflex.analysis import constrained  # noqa: E402
from pipeflex.multibody import MultibodyBuilder, flexible_body  # noqa: E402

SEC = pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0, EA=1e5, rotary_inertia=(1e-3, 1e-3, 1e-3))


def arm(n, *, clamped):
    b = pf.ModelBuilder()
    root = b.add_node((0.0, 0.0, 0.0))
    b.add_line(root, (1.0, 0.0, 0.0), n, SEC)
    b.reservoir_inlet(root)
    if clamped:
        b.clamp(root)
    return b.build(mass_flow=10.0, floating=not clamped), root


def coupled_arm(n):
    floating, root = arm(n, clamped=False)
    mb = MultibodyBuilder()
    mu = 3 * 10.0 / 0.2**3
    hub = mb.add_body(flexible_body(length=0.2, n_elements=2,
                                    section=pf.PipeSection(EI=1e4 * mu, pipe_mass=mu, rotary_inertia=(1.0, 1.0, 1.0))),
                      position=(-0.1, 0.0, 0.0))
    mb.fix(hub, "start")
    system = pf.CoupledSystem(floating, mb.build())
    system.rigid(root, hub, "end")
    return system


CLOCK = time.perf_counter  # --cpu: time.process_time (a loaded machine: the CPU time taken)


def best(f, repeat):
    t, out = math.inf, None
    for _ in range(repeat):
        t0 = CLOCK()
        out = f()
        t = min(t, CLOCK() - t0)
    return t, out


def reduction_time(system, state, repeat):
    """The reduction's share of one coupled linearize: from_core, null_space_basis and
    reduce on the core's output (captured from one pf.linearize)."""
    seen = {}
    original = constrained.linearization

    def grab(cls, out, mass_flow, st):
        seen["out"] = out
        return original(cls, out, mass_flow, st)
    constrained.linearization = grab
    try:
        pf.linearize(system, state)
    finally:
        constrained.linearization = original

    def reduction():
        K, C, M, Cq = constrained.from_core(seen["out"])
        return constrained.reduce(constrained.null_space_basis(Cq, K), M, C, K)
    return best(reduction, repeat)[0]


def slopes(sizes, times):
    return [math.log(b / a) / math.log(n1 / n0) for n0, n1, a, b in zip(sizes, sizes[1:], times, times[1:])]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", type=int, nargs="+", default=[64, 128, 256, 512, 1024, 2048, 4096])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--critical", type=int, nargs="*", default=[64, 256],
                    help="sizes at which to time pf.critical_mass_flow (none: skip)")
    ap.add_argument("--cpu", action="store_true", help="CPU time of the process instead of wall time")
    args = ap.parse_args()
    global CLOCK
    if args.cpu:
        CLOCK = time.process_time
    threads = os.environ.get("OPENBLAS_NUM_THREADS", "unset")
    print(f"load average {os.getloadavg()[0]:.2f}; OPENBLAS_NUM_THREADS={threads}; "
          f"{'CPU' if args.cpu else 'wall'} time, best of {args.repeat}")
    rows = []
    for n in args.sizes:
        system = coupled_arm(n)
        st = pf.static_equilibrium(system)
        alone, _ = arm(n, clamped=True)
        st_alone = pf.static_equilibrium(alone).state
        t_el, _ = best(lambda: pf.linearize(alone, st_alone), args.repeat)
        t_cp, lin = best(lambda: pf.linearize(system, st), args.repeat)
        t_red = reduction_time(system, st, args.repeat)
        rows.append((n, lin.basis.shape[0], t_el, t_cp, t_red))
        print(f"  N = {n}: element {t_el * 1e6:.0f} us, coupled {t_cp * 1e6:.0f} us", flush=True)
    sizes = [r[0] for r in rows]
    cols = {"element": [r[2] for r in rows], "coupled": [r[3] for r in rows], "reduction": [r[4] for r in rows],
            "rest": [r[3] - r[4] for r in rows]}
    sl = {k: [float("nan")] + slopes(sizes, v) for k, v in cols.items()}
    print("\n| elements | coordinates | element [us] | slope | coupled [us] | slope | reduction [us] | slope "
          "| core and rest [us] | slope | coupled / element |")
    print("| ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    for i, (n, nq, te, tc, tr) in enumerate(rows):
        print(f"| {n} | {nq} | {te * 1e6:.0f} | {sl['element'][i]:.2f} | {tc * 1e6:.0f} | {sl['coupled'][i]:.2f} "
              f"| {tr * 1e6:.0f} | {sl['reduction'][i]:.2f} | {(tc - tr) * 1e6:.0f} | {sl['rest'][i]:.2f} "
              f"| {tc / te:.1f} |")
    for n in args.critical:
        system, (alone, _) = coupled_arm(n), arm(n, clamped=True)
        t_el, cr_el = best(lambda: pf.critical_mass_flow(alone), 1)
        t_cp, cr = best(lambda: pf.critical_mass_flow(system), 1)
        print(f"critical_mass_flow, {n} elements: element {t_el:.1f} s ({cr_el.mass_flow:.4f} kg/s), "
              f"coupled {t_cp:.1f} s ({cr.mass_flow:.4f} kg/s), ratio {t_cp / t_el:.1f}")


if __name__ == "__main__":
    main()
