"""Benchmark: the 3D pipe element's kernels, microseconds per element.

Residual, hand-derived weighted tangent (wK, wC, wM = 1, 0.5, 0.25), the AD tangent it
replaced (kept as the tests' reference), mass matrix and fluid forces, timed in C++ over
many calls (_core._bench_pipe_kernels: a Python call costs about 1 us, as much as the
residual). Each figure is the minimum over a few runs (shared machine).
Targets: tangent <= 5 us, residual <= 1 us. Then the same through the assembler, per element
of a moving cantilever with flow (_core.assemble: the integrators' route; the residual alone
evaluates each node's rotation kinematics once for both of its elements).
Run: .venv/bin/python benchmarks/bench_kernels.py [--quick]
"""
import argparse
import time

import numpy as np

import pipeflex as pf
from pipeflex import _core

KERNELS = ("residual", "tangent", "tangent_ad", "mass_matrix", "fluid_forces")


def element(kind, rotary):
    sec = pf.PipeSection(EI=7.0, EIz=11.0, EA=3e3, GJ=5.0, GAy=900.0, GAz=700.0, pipe_mass=1.3,
                         fluid_mass=0.7, kv=1.1, rotary_inertia=(0.02, 0.01, 0.015) if rotary else (0, 0, 0))
    b = pf.ModelBuilder()
    n0 = b.add_node((0.1, -0.2, 0.3))
    if kind == "straight":
        b.add_line(n0, (1.1, 0.3, 0.5), 1, sec)
    else:
        b.add_arc(n0, center=(0.1, 0.8, 0.3), angle=np.pi / 2, normal=(0, 0, 1), n_elements=1, section=sec)
    b.clamp(n0)
    m = b.build()
    x = m.positions
    return m.core.pipe(0), np.concatenate([x[0], np.zeros(3), x[1], np.zeros(3)])


def state(q0, phi, rng):
    q = q0.copy()
    if phi:
        q[3:6] = 0.3 * rng.standard_normal(3)
        q[9:12] = 0.3 * rng.standard_normal(3)
    return q, rng.standard_normal(12), rng.standard_normal(12)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="fewer calls and runs")
    args = ap.parse_args()
    repeats, runs = (2000, 3) if args.quick else (20000, 7)
    rng = np.random.default_rng(0)
    ld = _core.LoadState()
    ld.mass_flow, ld.mass_flow_rate, ld.gravity = 2.5, -0.7, [0.0, 0.0, -9.81]
    frames = (_core.rotation_exp([0.4, -1.0, 2.0]), _core.rotation_exp([-2.5, 0.3, 0.1]))
    cases = [("straight", False, False), ("straight", False, True), ("curved", True, False), ("curved", True, True)]
    print(f"us per element (min of {runs} runs of {repeats} calls)")
    print(f"{'element':<10}{'rotary':>7}{'phi':>6}" + "".join(f"{k:>14}" for k in KERNELS) + f"{'AD/hand':>9}")
    for kind, rotary, phi in cases:
        data, q0 = element(kind, rotary)
        q, v, a = state(q0, phi, rng)
        best = {k: np.inf for k in KERNELS}
        for _ in range(runs):
            t = _core._bench_pipe_kernels(data, *frames, ld, q, v, a, repeats)
            for k in KERNELS:
                best[k] = min(best[k], t[k] * 1e6)
        print(f"{kind:<10}{str(rotary):>7}{'0' if not phi else 'rand':>6}"
              + "".join(f"{best[k]:>14.2f}" for k in KERNELS) + f"{best['tangent_ad'] / best['tangent']:>9.1f}")
    assembled(rng, 3 if args.quick else 7)


def assembled(rng, runs, n_elements=2048):
    """us per element of the assembled residual, and of residual and tangent, on a moving cantilever."""
    model = pf.scenes.cantilever_pipe(n_elements=n_elements, polar_inertia=1e-3, mass_flow=4.0)
    s = model.initial_state()
    for which, scale in (("q", 1e-3), ("v", 0.5), ("a", 2.0)):
        _core.add_increment(model.core, s, scale * rng.standard_normal(model.n_dofs), which)
    load = model.load_state(mass_flow=4.0)
    print(f"\nassembled, us per element ({n_elements} elements, min of {runs} runs of 20 calls)")
    for label, w, matrix in (("residual", (0.0, 0.0, 0.0), False), ("residual + tangent", (1.0, 0.5, 0.25), True)):
        best = np.inf
        for _ in range(runs):
            t0 = time.perf_counter()
            for _ in range(20):
                _core.assemble(model.core, s, load, 1.0, *w, matrix)
            best = min(best, (time.perf_counter() - t0) / 20)
        print(f"{label:<20}{best / n_elements * 1e6:>10.2f}")


if __name__ == "__main__":
    main()
