"""Benchmark: seed-004 floating-frame (FFRF) bodies against seed 000's element.

1. Wall time of each seed-004 scene (median of repeats, scene build and static solve
   included) and of its seed-000 counterpart:
   - FFRF cantilever (sec. 8.1), 2 and 8 bodies x 20 elements, boundary modes: static
     deflection under the 1.5 N tip force, then 2 s at h = 1 ms with mdot = 30 kg/s
     (``pipeflex.seeds.seed004.studies.ffrf_cantilever_tip``); seed 000: 8 elements, same run
     (``pipeflex.seeds.seed004.studies.element_cantilever_tip``).
   - Curved pipe (sec. 8.2), 8 bodies x 20 elements, boundary modes, E = 9.585 GPa, 4 s
     from rest at h = 1 ms (``pipeflex.seeds.seed004.studies.curved_pipe_run``); seed 000: the same tube
     (``pipeflex.seeds.seed004.studies.element_curved_pipe``'s model) from 8 curved elements, 4 s at h = 1 ms
     by generalised-alpha.
   - Concrete printer (sec. 8.3), flow 0 / 3 / 6 m/s: static solve, then 0.34 s at
     h = 0.2 ms (``pipeflex.seeds.seed004.studies.printer_run``).
2. The speed requirement: "the curved pipe (8 bodies, CB boundary modes) must simulate
   its full run at least as fast as the foundation element with 8 elements at the same
   output accuracy". Output: the final angular velocity, mean |omega| over the last 0.5 s
   of a 4 s run (401 outputs, ``pipeflex.seeds.seed004.studies.final_angular_velocity``). For each model and
   a step sweep: the time-discretisation error against the model's own reference
   (generalised-alpha at h and h/2, Richardson-extrapolated; the FFRF's with a Newton
   tolerance of 1e-9), and the deviation from the converged seed-000 value (32 and 64
   curved elements, steady-rotation solver, Richardson-extrapolated). For each tolerance
   (relative) the cheapest step whose error -- and that of every finer step in the sweep
   -- is within it; target: FFRF / seed-000 wall time <= 1 at 1e-4. Both models with
   rho_inf = 0.8; seed 000 without the work bookkeeping (``work=False``).
3. Where the FFRF integrator's time goes: steps, Newton iterations and factorisations per
   step, microseconds per step, and the cost of one tangent against one residual.
Run: .venv/bin/python benchmarks/bench_ffrf.py [--quick]   (--quick: E = 9.585 GPa only,
coarser references, one repeat; under a minute on 2 cores)
"""
import argparse
import os
import statistics
import time

import numpy as np

import pipeflex as pf
from pipeflex import ConvergenceError, scenes
from pipeflex.seeds.seed004 import references as ref004, studies as fs
from pipeflex.multibody import simulate as mb_simulate
from pipeflex.multibody import static_equilibrium as mb_static

T_END = 4.0        # curved pipe: simulated time [s]
N_OUT = 401        # outputs (every 10 ms): the output is their mean over the last 0.5 s
RHO_INF = 0.8      # numerical damping of both integrators (the seed-004 study's value)
E_SCENE = 9.585e9  # Young's modulus of the timed curved-pipe scene [Pa]


def median_time(fn, repeat):
    """(median wall time [s], last return value) of ``repeat`` calls."""
    times, out = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), out


def ffrf_output(system, step, tol=1e-7):
    res = mb_simulate(system, T_END, step=step, n_outputs=N_OUT, rho_inf=RHO_INF, newton_tol=tol)
    return fs.final_angular_velocity(res.t, res.node_angular_velocity(*system.info["base"])[:, 1]), res


def element_output(model, step):
    res = pf.simulate(model, T_END, integrator="generalized_alpha", step=step, n_outputs=N_OUT, progress=False,
                      rho_inf=RHO_INF, work=False)
    return fs.final_angular_velocity(res.t, res.omega[:, 0, 2]), res


def richardson(run, step):
    """Second-order Richardson extrapolation of run(h) from h and h/2."""
    a, b = run(step), run(step / 2)
    return b + (b - a) / 3.0, abs(b - a) / 3.0


def section_scenes(repeat):
    print(f"== 1. scene wall times (median of {repeat}; build + static solve + integration) ==")
    rows = []
    for nb in (2, 8):
        w, tr = median_time(lambda: fs.ffrf_cantilever_tip(n_bodies=nb), repeat)
        rows.append((f"FFRF cantilever, {nb} bodies x 20 el., 2 s, h = 1 ms", tr.size, w))
    w_ce, tr = median_time(lambda: fs.element_cantilever_tip(n_elements=8), repeat)
    rows.append(("seed-000 cantilever, 8 elements, 2 s, h = 1 ms", tr.size, w_ce))
    w_cp, (s, res_cp, _) = median_time(lambda: fs.curved_pipe_run(E_SCENE, step=1e-3), repeat)
    rows.append(("FFRF curved pipe, 8 bodies x 20 el., 4 s, h = 1 ms", s.n_dofs, w_cp))
    m = fs.element_curved_model(E_SCENE)
    w_se, _ = median_time(lambda: element_output(m, 1e-3), repeat)
    rows.append(("seed-000 curved pipe, 8 elements, 4 s, h = 1 ms", m.n_dofs, w_se))
    printer = {}
    for v in fs.PRINTER_FLOW_SPEEDS:
        w, (s_p, res_p, _) = median_time(lambda: fs.printer_run(v), repeat)
        printer[v] = res_p
        rows.append((f"FFRF concrete printer, {v:g} m/s, 0.34 s, h = 0.2 ms", s_p.n_dofs, w))
    print(f"{'scene':52s} {'DOF':>10s} {'wall [s]':>9s}")
    for name, size, w in rows:
        print(f"{name:52s} {size:10d} {w:9.3f}")
    print(f"ratio FFRF / seed 000: cantilever 8 bodies {rows[1][2] / w_ce:.2f}, 2 bodies {rows[0][2] / w_ce:.2f}; "
          f"curved pipe (both h = 1 ms) {w_cp / w_se:.2f}")
    return res_cp, printer


def section_accuracy(E_values, steps, ref_step_ffrf, ref_step_element, repeat, tolerances):
    print(f"\n== 2. curved pipe: wall time at equal accuracy of the final angular velocity "
          f"(median of {repeat}) ==")
    verdicts = {}
    for E in E_values:
        s = scenes.ffrf_curved_pipe(E=E)
        m = fs.element_curved_model(E)
        steady8 = fs.element_curved_pipe(E, n_elements=8)
        c32, c64 = fs.element_curved_pipe(E, n_elements=32), fs.element_curved_pipe(E, n_elements=64)
        conv = c64 + (c64 - c32) / 3.0
        ref_f, est_f = richardson(lambda h: ffrf_output(s, h, tol=1e-9)[0], ref_step_ffrf)
        ref_e, est_e = richardson(lambda h: element_output(m, h)[0], ref_step_element)
        print(f"\nE = {E / 1e9:g} GPa. References: FFRF {ref_f:.7f} rad/s (+-{est_f:.0e}; seed 004 Table 1 FFRF "
              f"{ref004.TABLE1_FFRF[E]}), seed 000 8 elements {ref_e:.7f} (+-{est_e:.0e}; steady solver "
              f"{steady8:.7f}), seed 000 converged {conv:.5f} (32 el. {c32:.5f}, 64 el. {c64:.5f}; Table 1 "
              f"Spacar {ref004.TABLE1_SPACAR[E]})")
        print(f"model error at h -> 0 vs converged seed 000: FFRF {(ref_f - conv) / conv:+.2%}, "
              f"seed 000 8 elements {(ref_e - conv) / conv:+.2%}")
        print(f"{'model':9s} {'h [ms]':>7s} {'omega [rad/s]':>14s} {'rel. time err.':>14s} "
              f"{'rel. dev. conv.':>15s} {'wall [s]':>9s} {'it/step':>7s} {'fact/step':>9s}")
        runs = {"FFRF": [], "seed 000": []}
        for name, fn, ref in (("FFRF", lambda h: ffrf_output(s, h), ref_f),
                              ("seed 000", lambda h: element_output(m, h), ref_e)):
            for h in steps:
                try:
                    w, (val, res) = median_time(lambda: fn(h), repeat)
                except ConvergenceError as e:
                    print(f"{name:9s} {h * 1e3:7.3f} failed: {str(e)[:70]}")
                    runs[name].append((h, np.inf, np.nan))
                    continue
                st = res.stats
                it = st["newton_iterations"] / st["steps"]
                fa = st["jacobians"] / st["steps"]
                err = abs(val - ref) / ref
                runs[name].append((h, err, w))
                print(f"{name:9s} {h * 1e3:7.3f} {val:14.7f} {err:14.1e} {(val - conv) / conv:+15.2%} {w:9.3f} "
                      f"{it:7.2f} {fa:9.3f}")
        for tol in tolerances:
            best = {}
            for name, rs in runs.items():
                ok = []
                for h, err, w in sorted(rs):  # finest step first
                    if not err <= tol:
                        break
                    ok.append((w, h))
                best[name] = min(ok) if ok else None
            if best["FFRF"] and best["seed 000"]:
                (wf, hf), (we, he) = best["FFRF"], best["seed 000"]
                ratio = wf / we
                print(f"tolerance {tol:.0e}: FFRF h = {hf * 1e3:g} ms {wf:.3f} s, seed 000 h = {he * 1e3:g} ms "
                      f"{we:.3f} s -> ratio FFRF / seed 000 = {ratio:.2f}")
                verdicts[(E, tol)] = ratio
            else:
                print(f"tolerance {tol:.0e}: not reached by " +
                      ", ".join(k for k, v in best.items() if v is None) + " in the sweep")
    key = (E_SCENE, 1e-4)
    if key in verdicts:
        r = verdicts[key]
        print(f"\nrequirement (E = 9.585 GPa, 1e-4): ratio {r:.2f} -> {'met' if r <= 1 else 'NOT met'} "
              f"(target <= 1)")
    return verdicts


def section_cost(res_cp, printer, quick):
    print("\n== 3. where the FFRF integrator's time goes ==")
    rows = []
    for nb in (2, 8):
        s = scenes.ffrf_cantilever_pipe(n_bodies=nb, tip_force=fs.CANTILEVER_TIP_FORCE)
        st = mb_static(s, mass_flow=0.0).state
        res = mb_simulate(s, 2.0, step=1e-3, state=st, mass_flow=s.bodies[0].section.fluid_mass * 15.0,
                          n_outputs=401)
        rows.append((f"cantilever, {nb} bodies", s.n_coordinates, s.n_constraints, res.stats))
    rows.append(("curved pipe, 8 bodies, E = 9.585 GPa", res_cp.n_coordinates,
                 res_cp.n_constraints, res_cp.stats))
    for v, r in printer.items():
        rows.append((f"printer, {v:g} m/s", r.n_coordinates, r.n_constraints, r.stats))
    print(f"{'run':38s} {'N':>4s} {'m':>3s} {'steps':>6s} {'it/step':>7s} {'fact/step':>9s} {'us/step':>8s}")
    for name, n, nc, st in rows:
        print(f"{name:38s} {n:4d} {nc:3d} {st['steps']:6d} {st['newton_iterations'] / st['steps']:7.2f} "
              f"{st['jacobians'] / st['steps']:9.3f} {st['wall_time'] / st['steps'] * 1e6:8.1f}")
    # one tangent (body kernels, joint reactions differenced) against one residual
    s = scenes.ffrf_curved_pipe(E=E_SCENE)
    st = s.initial_state()
    w_t, _ = median_time(lambda: s.evaluate(st, mass_flow=0.0, wK=1.0, wC=1.0, wM=1.0), 20)
    w_r, _ = median_time(lambda: s.evaluate(st, mass_flow=0.0, tangent=False), 20)
    print(f"curved pipe: one tangent evaluation ~ {w_t * 1e6:.0f} us, one residual ~ {w_r * 1e6:.0f} us "
          f"(Python call included); {res_cp.stats['jacobians']} factorisations and "
          f"{res_cp.stats['newton_iterations']} iterations in the 4 s run")


def newton_tolerance_check():
    print("\n== Newton tolerance at small steps (curved pipe, E = 9.585 GPa, h = 0.3125 ms) ==")
    s = scenes.ffrf_curved_pipe(E=E_SCENE)
    for tol in (1e-7, 1e-8):
        val, res = ffrf_output(s, 3.125e-4, tol=tol)
        w = res.node_angular_velocity(*s.info["base"])[:, 1]
        sel = res.t >= T_END - 0.5
        print(f"tol = {tol:.0e}: omega = {val:.7f} rad/s, std of omega over the last 0.5 s {np.std(w[sel]):.1e} "
              f"rad/s, max constraint drift {res.drift.max():.1e} m/s, {res.stats['wall_time']:.2f} s")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="E = 9.585 GPa only, coarser references, one repeat")
    args = ap.parse_args()
    t0 = time.perf_counter()
    print(f"load average at start: {os.getloadavg()[0]:.2f}")
    if args.quick:
        res_cp, printer = section_scenes(repeat=1)
        section_accuracy((E_SCENE,), steps=(5e-3, 2.5e-3, 1.25e-3), ref_step_ffrf=1.25e-3,
                         ref_step_element=6.25e-4, repeat=1, tolerances=(1e-3, 1e-4))
    else:
        res_cp, printer = section_scenes(repeat=5)
        section_accuracy((0.9585e9, E_SCENE, 95.85e9), steps=(1e-2, 5e-3, 2.5e-3, 1.25e-3, 6.25e-4),
                         ref_step_ffrf=6.25e-4, ref_step_element=3.125e-4, repeat=3,
                         tolerances=(1e-3, 1e-4, 1e-5))
    section_cost(res_cp, printer, args.quick)
    if not args.quick:
        newton_tolerance_check()
    print(f"\ntotal {time.perf_counter() - t0:.0f} s; load average at end: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
