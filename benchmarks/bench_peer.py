"""Benchmark: work-precision and where each method fails, on three scenes, pipeflex beside the peer.

Scenes (docs/performance.md, "Peer benchmark over three scenes"):

1. ``limit_cycle``: the flutter limit cycle of seed 000's Fig. 3 cantilever
   (``bench_limit_cycle.scene``: 8 elements, 30 kg/s from t = 0, from the static deflection);
   quantity: the tip's lateral displacement at 2 s; reference ``bench_limit_cycle.reference``.
2. ``spin_up``: seed 002's spin-up of the rotating cantilever (Table 1, ref. 21: L = 8 m,
   2 ANCF elements, Omega = 4 rad/s reached in T = 15 s by eq. 13); quantity: the tip's
   deflection in the rotating frame at 20 s; reference: generalised-alpha (rho_inf = 1) at
   2.5e-4 and 1.25e-4 s with a tight Newton tolerance, Richardson-extrapolated.
3. ``critical_flow``: the flutter flow of the cantilevered pipe at beta = M / (M + m) = 0.2
   and 0.5 (``pf.critical_mass_flow`` at 2 ... 32 elements) against the continuous pipe
   (``pipeflex.references.continuous_pipe.critical``).

Accuracy targets 1e-2 ... 1e-8 (quick: 1e-2 ... 1e-4) are relative: the error over the model's
size L (transients) or over the reference flow. Transients run ``pf.simulate(model, t_end,
rtol=...)`` alone and generalised-alpha at fixed steps; for each target the cheapest run meeting
it: the loosest rtol, the largest step (meeting it there and at every smaller step: no lucky zero
crossing of the error), the coarsest mesh; timing noise does not pick it. Solve times are the
median of ``--repeat``, one BLAS thread (the variables below are set before numpy loads).

"Where each method fails", per scene and method (generalised-alpha at rho_inf 0, 0.5, 0.8, 1;
the rtol control; IDA): the largest step a short run takes without a convergence failure or
growth of the energy (bisected, without and with flow), the relative energy drift per period
over a long free vibration without flow, and for the critical-flow scene the mass flows and
EA / EI ratios at which static Newton solves and ``pf.critical_mass_flow`` stop converging
(``pf.ConvergenceError`` caught and reported).

The peer (Exudyn, ``import exudyn``) is optional: its side of each scene is in
``benchmarks/peer/`` (``exudyn_scene.py`` for scene 1; ``exudyn_spin_up.py`` and
``exudyn_critical_flow.py`` for scenes 2 and 3; the spin-up with 16 of the peer's cable elements, which 2
do not resolve).
Without exudyn one line says so and its columns read "not measured here".

Run: .venv/bin/python benchmarks/bench_peer.py [--repeat 5] [--quick] [--json out.json]
"""
import os

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # one BLAS thread: set before numpy is imported

import argparse  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

import pipeflex as pf  # noqa: E402
from pipeflex.references import continuous_pipe  # noqa: E402
from pipeflex.seeds.seed002 import scenes as seed002_scenes  # noqa: E402
from pipeflex.seeds.seed002.studies import tip_deflection  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import bench_limit_cycle as blc  # noqa: E402

TARGETS = (1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8)
RHOS = (0.0, 0.5, 0.8, 1.0)
NOT_MEASURED = "not measured here"


class Transient:
    """A transient scene: model, initial state, end time, the quantity of interest and its flow."""

    def __init__(self, name, model, state, t_end, quantity, mass_flow, period):
        self.name, self.model, self.state, self.t_end = name, model, state, t_end
        self.quantity, self.mass_flow, self.period = quantity, mass_flow, period
        self.L = model.length_scale

    def run(self, t_end=None, **options):
        """(quantity at t_end, stats, solve seconds) of one pf.simulate run."""
        t0 = time.perf_counter()
        res = pf.simulate(self.model, self.t_end if t_end is None else t_end, state=self.state, n_outputs=2,
                          progress=False, **options)
        return self.quantity(res), res.stats, time.perf_counter() - t0


def limit_cycle_scene():
    model, tip, state = blc.scene()
    # first bending period without flow: 2 pi / (1.875^2 sqrt(EI / (m L^4))), EI = 10 N m^2, m = 10 kg/m
    period = 2 * np.pi / (1.875104**2 * np.sqrt(10.0 / 10.0))
    sc = Transient("limit_cycle", model, state, blc.T_END, lambda r: float(r.x[-1, tip, 1]), 30.0, period)
    sc.reference, sc.reference_spread = blc.reference(model, tip, state)
    return sc


def spin_up_scene():
    model = seed002_scenes.spin_up_beam(reference="ref21", n_elements=2, omega=4.0)
    period = 2 * np.pi / (1.875104**2 * model.info["omega0"])
    sc = Transient("spin_up", model, None, 20.0, lambda r: float(tip_deflection(model, r)[-1]), None, period)
    tight = dict(integrator="generalized_alpha", rho_inf=1.0, newton_tol=1e-13, max_newton=30, work=False)
    y = [sc.run(step=h, **tight)[0] for h in (5e-4, 2.5e-4, 1.25e-4)]
    r1, r2 = y[1] + (y[1] - y[0]) / 3, y[2] + (y[2] - y[1]) / 3
    sc.reference, sc.reference_spread = r2, abs(r2 - r1)
    return sc


def median_time(f, repeat):
    times, out = [], None
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = f()
        times.append(time.perf_counter() - t0)
    return out, float(np.median(times))


def fmt(row, key, spec):
    return "-" if row is None or row.get(key) is None else format(row[key], spec)


def peer_cells(peer, key, spec):
    """The peer's cheapest run for a target as two cells (its ``key``, solve seconds): "not measured here",
    "-" (none meets the target) or the run's values."""
    if isinstance(peer, str):
        return peer, ""
    return fmt(peer, key, spec), fmt(peer, "solve", ".4f")


def work_precision(sc, steps, rtols, repeat, targets):
    """Fixed-step generalised-alpha and rtol-controlled runs; per target the largest qualifying step and the
    loosest rtol meeting it."""
    rows = []
    for h in steps:
        (y, stats, _), sec = median_time(lambda: sc.run(integrator="generalized_alpha", step=h, work=False), repeat)
        rows.append(dict(method="fixed step", step=h, error=abs(y - sc.reference) / sc.L, steps=stats["steps"],
                         solve=sec))
    for rtol in rtols:
        (y, stats, _), sec = median_time(lambda: sc.run(rtol=rtol), repeat)
        rows.append(dict(method="rtol", rtol=rtol, error=abs(y - sc.reference) / sc.L, steps=stats["steps"],
                         solve=sec))
    cheapest = []
    for target in targets:
        row = dict(target=target, peer=NOT_MEASURED)
        fixed = [r for r in rows if r["method"] == "fixed step"]
        ok = [r for r in fixed if all(q["error"] <= target for q in fixed if q["step"] <= r["step"])]
        row["fixed step"] = max(ok, key=lambda r: r["step"]) if ok else None
        ok = [r for r in rows if r["method"] == "rtol" and r["error"] <= target]
        row["rtol"] = max(ok, key=lambda r: r["rtol"]) if ok else None
        cheapest.append(row)
    return dict(reference=sc.reference, reference_spread=sc.reference_spread, length_scale=sc.L, runs=rows,
                cheapest=cheapest)


def critical_flow(betas, meshes, repeat, targets):
    """pf.critical_mass_flow at increasing meshes against the continuous pipe, per beta."""
    EI, L, total = 10.0, 1.0, 10.0
    out = {}
    for beta in betas:
        M = beta * total
        u_cr, _ = continuous_pipe.critical(beta)
        exact = u_cr * np.sqrt(EI * M) / L  # mdot = M U, U = u sqrt(EI / M) / L
        rows = []
        for n in meshes:
            model = pf.scenes.cantilever_pipe(n_elements=n, EI=EI, pipe_mass=total - M, fluid_mass=M)
            pf.critical_mass_flow(model)  # warm-up
            r, sec = median_time(lambda: pf.critical_mass_flow(model), repeat)
            rows.append(dict(n_elements=n, mass_flow=r.mass_flow, error=abs(r.mass_flow - exact) / exact, solve=sec))
        cheapest = []
        for target in targets:
            ok = [r for r in rows if r["error"] <= target]
            cheapest.append(dict(target=target, pipeflex=min(ok, key=lambda r: r["n_elements"]) if ok else None,
                                 peer=NOT_MEASURED))
        out[str(beta)] = dict(beta=beta, reference=exact, runs=rows, cheapest=cheapest)
    return out


# -- where each method fails ---------------------------------------------------------------

# a diverging or failed step (ConvergenceError), or IDA's step budget exhausted (ValueError naming max_steps)
FAILURES = (pf.ConvergenceError, ValueError)


def failure(e):
    """A one-line account of a caught failure; a ValueError that is not about max_steps is re-raised."""
    text = str(e).splitlines()[0]
    if isinstance(e, ValueError) and "max_steps" not in text:
        raise e
    return f"{type(e).__name__}: {text[:70]}"


def methods(ida_max_steps):
    m = [(f"generalized_alpha rho_inf={rho}", dict(integrator="generalized_alpha", rho_inf=rho)) for rho in RHOS]
    m.append(("rtol control (rtol=1e-4)", dict(rtol=1e-4)))
    m.append(("ida (rtol=1e-6)", dict(integrator="ida", rtol=1e-6, atol=1e-8, max_steps=ida_max_steps)))
    return m


def stable(sc, t_short, flow, options, bound):
    """(ok, reason): a short run completes, halves no step and its energy stays below ``bound`` [J]
    (ten times the largest energy of an error-controlled run at rtol 1e-6)."""
    try:
        res = pf.simulate(sc.model, t_short, state=sc.state, n_outputs=5, progress=False, mass_flow=flow,
                          **options)
    except pf.ConvergenceError as e:
        return False, f"ConvergenceError: {str(e).splitlines()[0][:80]}"
    if res.stats.get("convergence_failures", 0):
        return False, "Newton failed, step halved"
    if not np.all(np.abs(res.energy) <= bound):
        return False, "energy grew tenfold"
    return True, ""


def energy_bound(sc, t_short, flow):
    res = pf.simulate(sc.model, t_short, state=sc.state, n_outputs=5, progress=False, mass_flow=flow, rtol=1e-6)
    return 10 * float(np.abs(res.energy).max()) + 1e-12


def largest_stable_step(sc, t_short, flow, options, bisections, bound):
    """Bisect (in log h) the largest fixed step at which `stable` holds, from 1e-5 s to t_short / 2."""
    lo, hi = 1e-5, t_short / 2
    ok, why = stable(sc, t_short, flow, dict(options, step=hi), bound)
    if ok:
        return hi, "stable up to the run's half length"
    ok_lo, why_lo = stable(sc, t_short, flow, dict(options, step=lo), bound)
    if not ok_lo:
        return None, why_lo
    for _ in range(bisections):
        mid = np.sqrt(lo * hi)
        ok, w = stable(sc, t_short, flow, dict(options, step=mid), bound)
        lo, hi, why = (mid, hi, why) if ok else (lo, mid, w)
    return lo, why


def energy_drift(sc, n_periods, options):
    """Relative drift of the mechanical energy per period over a free vibration without flow from the initial
    state (the static deflection, load removed): (E_end - E_0) / E_0 / n_periods."""
    t_end = n_periods * sc.period
    step = dict(step=sc.period / 100) if options.get("integrator") == "generalized_alpha" else {}
    t0 = time.perf_counter()
    try:
        res = pf.simulate(sc.model, t_end, state=sc.state, n_outputs=n_periods + 1, progress=False, mass_flow=0.0,
                          load_factor=0.0, **step, **options)
    except FAILURES as e:
        return dict(drift_per_period=None, failed=failure(e))
    e = res.energy
    return dict(drift_per_period=float((e[-1] - e[0]) / e[0] / n_periods), steps=res.stats["steps"],
                solve=time.perf_counter() - t0, failed=None)


def stability(sc, flows, t_short, n_periods, bisections, ida_max_steps, drift=True):
    rows = []
    print(f"\n[{sc.name}] where each method fails: largest stable step over {t_short:g} s; energy drift per period "
          f"over {n_periods} periods without flow")
    print(f"{'method':34s} {'flow [kg/s]':>11s} {'largest step [s]':>16s} {'why not larger':40s} {'drift/period':>12s}")
    bounds = {flow: energy_bound(sc, t_short, flow) for flow in flows}
    for label, options in methods(ida_max_steps):
        d = energy_drift(sc, n_periods, options) if drift else dict(drift_per_period=None, failed="n/a")
        for flow in flows:
            row = dict(scene=sc.name, method=label, mass_flow=flow)
            if options.get("integrator") == "generalized_alpha":
                h, why = largest_stable_step(sc, t_short, flow, options, bisections, bounds[flow])
            else:  # error-controlled: does the short run succeed, and which step did it reach?
                try:
                    res = pf.simulate(sc.model, t_short, state=sc.state, n_outputs=2, progress=False,
                                      mass_flow=flow, **options)
                    h = res.stats.get("largest_step")  # IDA reports none: its mean step instead
                    why = f"{res.stats['steps']} steps" + ("" if h else f", mean {t_short / res.stats['steps']:.1e} s")
                except FAILURES as e:
                    h, why = None, failure(e)
            row.update(largest_stable_step=h, reason=why, energy_drift=d)
            rows.append(row)
            dr = d["drift_per_period"]
            dtxt = (f"{dr:12.2e}" if dr is not None else
                    "max_steps" if "max_steps" in d["failed"] else d["failed"][:12])
            print(f"{label:34s} {flow if flow is not None else 0.0:11.3g} "
                  f"{fmt(row, 'largest_stable_step', '.3e'):>16s} "
                  f"{why[:40]:40s} {dtxt}")
    return rows


def newton_limits(flow_factors, stiffness_ratios):
    """The flows and EA / EI ratios at which static Newton solves and critical_mass_flow stop converging."""
    out = dict(static_flow=[], stiffness=[])
    model, _, _ = blc.scene()
    mdot_cr = pf.critical_mass_flow(pf.scenes.cantilever_pipe(n_elements=8)).mass_flow
    print(f"\n[critical_flow] static Newton solves of the loaded cantilever at multiples of "
          f"mdot_cr = {mdot_cr:.4f} kg/s")
    for k in flow_factors:
        try:
            pf.static_equilibrium(model, mass_flow=k * mdot_cr)
            status = "converged"
        except pf.ConvergenceError as e:
            status = f"ConvergenceError: {str(e).splitlines()[0][:70]}"
        out["static_flow"].append(dict(factor=k, mass_flow=k * mdot_cr, status=status))
        print(f"  {k:8g} x mdot_cr: {status}")
    print("[critical_flow] EA / EI [1/m^2]: static solve (no flow) and critical_mass_flow")
    for ratio in stiffness_ratios:
        row = dict(ratio=ratio)
        for what, f in (("static", lambda mm: pf.static_equilibrium(mm, mass_flow=0.0)),
                        ("critical_mass_flow", lambda mm: pf.critical_mass_flow(mm).mass_flow)):
            try:
                mm = blc.scene(EA=10.0 * ratio)[0]
                v = f(mm)
                row[what] = "converged" if what == "static" else f"{v:.6f} kg/s"
            except pf.ConvergenceError as e:
                row[what] = f"ConvergenceError: {str(e).splitlines()[0][:60]}"
        out["stiffness"].append(row)
        print(f"  {ratio:8.0e}: static {row['static']}; critical {row['critical_mass_flow']}")
    return out


def load_peer():
    """The peer's scene modules, or None (one printed line) when exudyn cannot be imported."""
    sys.path.insert(0, os.path.join(HERE, "peer"))
    import exudyn_scene
    try:
        exudyn_scene.load()
    except ImportError as e:
        print(f"peer skipped: exudyn is not importable ({e}); its columns read '{NOT_MEASURED}'")
        return None
    return exudyn_scene


def peer_runs(peer, steps, meshes, result):
    """The peer's fixed-step sweeps (trapezoidal, modified Newton, relTol 1e-6) and its critical flows; its
    largest qualifying step (coarsest mesh) per target goes into each scene's "peer" column. Runs only where
    exudyn imports (benchmarks/peer/exudyn_scene.py says how to build it)."""
    import exudyn_critical_flow
    import exudyn_spin_up
    sides = dict(limit_cycle=(lambda h: peer.run(h, "trapezoidal", 1e-6)[:2], peer.REFERENCE, 1.0),
                 spin_up=(lambda h: exudyn_spin_up.run(h)[:2], exudyn_spin_up.reference()[0], exudyn_spin_up.L))
    for name, (run, ref, L) in sides.items():
        rows = [dict(step=h, error=abs(y - ref) / L, solve=sec) for h in steps[name] for y, sec in [run(h)]]
        result["scenes"][name]["peer_runs"] = rows
        for row in result["scenes"][name]["cheapest"]:
            ok = [r for r in rows if all(q["error"] <= row["target"] for q in rows if q["step"] <= r["step"])]
            row["peer"] = max(ok, key=lambda r: r["step"]) if ok else None
    for beta, scene in result["scenes"]["critical_flow"].items():
        rows = [dict(n_elements=n, error=abs(m - scene["reference"]) / scene["reference"], solve=sec)
                for n in meshes for m, sec in [exudyn_critical_flow.critical_mass_flow(n, float(beta))]]
        scene["peer_runs"] = rows
        for row in scene["cheapest"]:
            ok = [r for r in rows if r["error"] <= row["target"]]
            row["peer"] = min(ok, key=lambda r: r["n_elements"]) if ok else None


def print_transient(name, scene, peer_method):
    """One scene's table: every run of both codes (error over L, steps, solve seconds), then the cheapest run
    of each method per target."""
    print(f"\n[{name}] reference {scene['reference']:.12g} m (extrapolations differ by "
          f"{scene['reference_spread']:.1e} m), L = {scene['length_scale']:g} m")
    print(f"{'code':>8s} {'method':>18s} {'step/rtol':>10s} {'error/L':>9s} {'steps':>7s} {'solve [s]':>10s}")
    runs = [("pipeflex", r["method"], r.get("step", r.get("rtol")), r) for r in scene["runs"]]
    runs += [("peer", peer_method, r["step"], r) for r in scene.get("peer_runs", ())]
    for code, method, x, r in runs:
        print(f"{code:>8s} {method:>18s} {x:10.1e} {r['error']:9.2e} {fmt(r, 'steps', 'd'):>7s} {r['solve']:10.4f}")
    print("cheapest run per target:")
    print(f"{'':7s} {'pipeflex fixed step':>25s} {'pipeflex rtol':>22s} {'peer fixed step':>29s}")
    print(f"{'target':>7s} {'h [s]':>12s} {'solve [s]':>12s} {'rtol':>10s} {'solve [s]':>11s} {'h [s]':>18s} "
          f"{'solve [s]':>10s}")
    for row in scene["cheapest"]:
        f, r = row["fixed step"], row["rtol"]
        peer_x, peer_solve = peer_cells(row["peer"], "step", ".1e")
        print(f"{row['target']:7.0e} {fmt(f, 'step', '.1e'):>12s} {fmt(f, 'solve', '.4f'):>12s} "
              f"{fmt(r, 'rtol', '.0e'):>10s} {fmt(r, 'solve', '.4f'):>11s} {peer_x:>18s} {peer_solve:>10s}")


def print_critical(beta, scene):
    """One critical-flow table per beta: each mesh's flow by both codes, then the coarsest mesh per target."""
    print(f"\n[critical_flow] beta = {beta}: continuous pipe mdot_cr = {scene['reference']:.10f} kg/s")
    peer = {r["n_elements"]: r for r in scene.get("peer_runs", ())}
    print(f"{'elements':>8s} {'pipeflex mdot_cr [kg/s]':>24s} {'rel. error':>10s} {'solve [s]':>10s} "
          f"{'peer rel. error':>16s} {'peer solve [s]':>15s}")
    for r in scene["runs"]:
        p = peer.get(r["n_elements"])
        print(f"{r['n_elements']:8d} {r['mass_flow']:24.10f} {r['error']:10.2e} {r['solve']:10.4f} "
              f"{fmt(p, 'error', '.2e') if peer else NOT_MEASURED:>16s} {fmt(p, 'solve', '.4f') if peer else '':>15s}")
    print(f"{'target':>7s} {'pipeflex elements':>18s} {'solve [s]':>10s} {'peer elements':>18s} {'solve [s]':>10s}")
    for c in scene["cheapest"]:
        peer_n, peer_solve = peer_cells(c["peer"], "n_elements", "d")
        print(f"{c['target']:7.0e} {fmt(c['pipeflex'], 'n_elements', 'd'):>18s} "
              f"{fmt(c['pipeflex'], 'solve', '.4f'):>10s} {peer_n:>18s} {peer_solve:>10s}")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--quick", action="store_true", help="targets 1e-2 ... 1e-4, fewer runs, one repeat")
    ap.add_argument("--json", default=None, help="write every table to this JSON file")
    args = ap.parse_args()
    quick = args.quick
    repeat = 1 if quick else args.repeat
    targets = TARGETS[:3] if quick else TARGETS
    rtols = tuple(t for t in targets)
    peer = load_peer()
    meta = dict(load_average=os.getloadavg()[0], blas_threads=blc.blas_threads(),
                openblas_num_threads=os.environ.get("OPENBLAS_NUM_THREADS"), repeat=repeat, quick=quick,
                peer="measured" if peer is not None else NOT_MEASURED)
    print(f"load average {meta['load_average']:.2f}; BLAS threads: {meta['blas_threads']} "
          f"(OPENBLAS_NUM_THREADS={meta['openblas_num_threads']}); median of {repeat}")
    lc, su = limit_cycle_scene(), spin_up_scene()
    result = dict(meta=meta, scenes={})
    lc_steps = (2e-3, 1e-3, 5e-4) if quick else (2e-3, 1e-3, 5e-4, 2.5e-4, 1.25e-4)
    su_steps = (1e-2, 5e-3) if quick else (1e-2, 5e-3, 2.5e-3, 1.25e-3, 6.25e-4)
    result["scenes"]["limit_cycle"] = work_precision(lc, lc_steps, rtols, repeat, targets)
    result["scenes"]["spin_up"] = work_precision(su, su_steps, rtols, repeat, targets)
    result["scenes"]["critical_flow"] = critical_flow((0.2, 0.5), (2, 4, 8) if quick else (2, 4, 8, 16, 32),
                                                      repeat, targets)
    if peer is not None:
        peer_runs(peer, dict(limit_cycle=lc_steps, spin_up=su_steps), (2, 4, 8) if quick else (2, 4, 8, 16, 32),
                  result)
    # one table per scene, both codes' rows (the peer's sweeps ran above)
    print_transient("limit_cycle", result["scenes"]["limit_cycle"], "trapezoidal")
    print_transient("spin_up", result["scenes"]["spin_up"], "gen.-alpha")
    for beta, scene in result["scenes"]["critical_flow"].items():
        print_critical(beta, scene)
    n_periods, bisections, ida_max = (2, 3, 20000) if quick else (10, 6, 200000)
    # the critical-flow scene's transients: the loaded 8-element cantilever (beta = 0.2) just below its flutter flow
    cf = Transient("critical_flow", lc.model, lc.state, lc.t_end, lc.quantity, None, lc.period)
    mdot_cr = result["scenes"]["critical_flow"]["0.2"]["reference"]
    rows = stability(lc, (0.0, 30.0), 0.5, n_periods, bisections, ida_max)
    rows += stability(su, (None,), 2.0, n_periods, bisections, ida_max, drift=False)  # the hub does work
    rows += stability(cf, (0.9 * mdot_cr,), 0.5, n_periods, bisections, ida_max, drift=False)  # drift: as scene 1
    result["stability"] = rows
    result["scenes"]["critical_flow"]["newton_limits"] = newton_limits(
        (1, 2, 5, 10, 20) if quick else (1, 2, 5, 10, 20, 50, 100, 1000),
        (1e2, 1e4, 1e8) if quick else (1e0, 1e2, 1e4, 1e6, 1e8, 1e10, 1e12))
    meta["load_average_end"] = os.getloadavg()[0]
    print(f"\nload average at the end {meta['load_average_end']:.2f}; peer columns: {meta['peer']}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(result, f, indent=1, default=str)


if __name__ == "__main__":
    main()
