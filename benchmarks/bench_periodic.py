"""Benchmark: the flutter limit cycle by shooting against the long transient.

The cantilever of Meijaard & Hakvoort's Fig. 3 (8 elements, 3D: 48 coordinates, 96
states; EA = 1e5 N, tip force 1.5 N), the same integrator and step in both:
generalised-alpha, h = 5e-4 s.

- Amplitude: half the peak-to-peak tip displacement (y), each extreme refined by the
  parabola through its sample and the two next to it. The raw samples miss the peak by up
  to (omega h)^2 / 8 = 6e-6 relative at h = 5e-4 s, which decides the 1e-6 rows
  otherwise (both methods alike).
- Reference: the orbit from the settled transient, periodicity defect 1e-10.
- Transient: from the static deflection; the time it needs for an accuracy is the end of
  the first cycle after which every cycle's amplitude stays within it of the reference;
  its wall time is that time times the wall time per simulated second (the cheaper of
  the recorded run and the guess's, which records two outputs).
- Shooting: pf.orbit_guess, a transient with the step k h (``--coarse``; a guess need not
  be accurate) that stops by itself when two successive cycles agree to 1e-3, its time
  counted; then pf.periodic_orbit with the step h, without multipliers, to defects 1e-1,
  3e-2, 1e-2 ... 1e-8; for each accuracy the cheapest (guess + shooting) that reaches it,
  with the defect tolerance that did.
Two flows: Fig. 3's 30 kg/s, whose cycle attracts strongly (in-plane multiplier 0.27 per
period), and 25.5 kg/s near the Hopf point (planar model), where it attracts slowly: there
also the continuation from the Hopf point (no guess needed; multipliers on the branch) and
the orbit at 25.5 kg/s (without multipliers).
Times are CPU times [s] (single-threaded work; wall times beside them), the least of
``--repeat`` runs.
Run: .venv/bin/python benchmarks/bench_periodic.py [--repeat 3] [--coarse 1 4 8]
"""
import argparse
import inspect
import os
import time

import numpy as np

import pipeflex as pf
from pipeflex.seeds.seed000.limit_cycle import limit_cycle_model

H = 5e-4
ACCURACIES = (1e-2, 1e-3, 1e-4, 1e-6)
TOLERANCES = (1e-1, 3e-2, 1e-2, 3e-3, 1e-3, 1e-4, 1e-6, 1e-8)
# without multipliers where periodic_orbit can skip them (so that this script also
# measures the version before, which always computed them)
WALL = []  # the least wall time of each measurement, printed beside its CPU time
LEAN = {"multipliers": False} if "multipliers" in inspect.signature(pf.periodic_orbit).parameters else {}


def extreme(y, i):
    """The extreme of the parabola through y[i - 1], y[i], y[i + 1] (indices modulo len(y))."""
    a, b, c = y[i - 1], y[i], y[(i + 1) % len(y)]
    d = a - 2.0 * b + c
    return b - (c - a) ** 2 / (8.0 * d) if d != 0.0 else b


def half_range(y):
    """Half peak-to-peak of one cycle sampled uniformly (cyclic: no repeated end point)."""
    return 0.5 * (extreme(y, int(np.argmax(y))) - extreme(y, int(np.argmin(y))))


def best(f, repeat):
    """(the least CPU time [s] of ``repeat`` runs, the result). CPU time, not wall time:
    the work is single-threaded (one BLAS thread in the analyses), and on a shared machine
    the wall time of a run doubles with the other jobs (the wall times are printed too)."""
    cpu = wall = np.inf
    out = None
    for _ in range(repeat):
        t0, c0 = time.perf_counter(), time.process_time()
        out = f()
        cpu = min(cpu, time.process_time() - c0)
        wall = min(wall, time.perf_counter() - t0)
    WALL.append(wall)
    return cpu, out


def transient_cycles(model, tip, st, t_end, repeat):
    """(wall per simulated second, [(end of cycle [s], amplitude [m])], final state)."""
    wall, r = best(lambda: pf.simulate(model, t_end, state=st, step=H, n_outputs=int(round(t_end / H)) + 1,
                                       progress=False, integrator="generalized_alpha"), repeat)
    y = r.x[:, tip, 1]
    mean = 0.5 * (y[-2000:].max() + y[-2000:].min())
    up = np.flatnonzero((y[:-1] < mean) & (y[1:] >= mean))
    cycles = [(r.t[b], half_range(y[a:b])) for a, b in zip(up[:-1], up[1:])]
    period = float(np.diff(r.t[up[-5:]]).mean())
    return wall / t_end, cycles, r.final_state, period


def settled_time(cycles, amp, tol):
    return next((t for t, a in cycles if all(abs(b / amp - 1) <= tol for tt, b in cycles if tt >= t)), None)


def orbit_amplitude(orbit, tip):
    return half_range(orbit.x[:-1, tip, 1])


def guess_and_shoot(model, tip, st, steps, amp, coarse, repeat):
    """{k: [(defect tolerance, CPU time of guess + shooting [s], amplitude error)]} for
    pf.orbit_guess with the step k h, then pf.periodic_orbit at each tolerance."""
    shooting = {}
    for factor in coarse:
        wall_guess, guess = best(lambda: pf.orbit_guess(model, node=tip, step=factor * H, state=st), repeat)
        print(f"guess: pf.orbit_guess with step {factor:g} h (settled to 1e-3 per cycle at t = {guess.time:g} s): "
              f"{wall_guess:.3f} s (wall {WALL[-1]:.3f} s), amplitude error {abs(guess.amplitude / amp - 1):.1e}")
        runs = []
        for tol in TOLERANCES:
            wall, o = best(lambda: pf.periodic_orbit(model, period=guess.period, state=guess.state, steps=steps,
                                                     tol=tol, **LEAN), repeat)
            err = abs(orbit_amplitude(o, tip) / amp - 1)
            runs.append((tol, wall_guess + wall, err))
            print(f"  shooting to a defect of {tol:.0e}: {wall:.3f} s (wall {WALL[-1]:.3f} s), {o.iterations} iterations, "
                  f"{o.stats['flow_maps']} flow maps, amplitude error {err:.1e}")
        shooting[factor] = runs
    return shooting


def table(cycles, amp, per_second, t_end, shooting, coarse, continuation=None):
    """Per accuracy: the transient's motion and CPU time, then each method's time and
    the ratio transient / method (the cheapest defect tolerance that reaches it)."""
    head = f" {'continuation [s]':>17s} {'ratio':>6s}" if continuation is not None else ""
    head += "".join(f" {'guess ' + format(f, 'g') + ' h: tol, s':>20s} {'ratio':>6s}" for f in coarse)
    print(f"{'accuracy':>9s} {'transient: t [s]':>17s} {'cpu [s]':>9s}{head}")
    for acc in ACCURACIES:
        settled = settled_time(cycles, amp, acc)
        wall_t = np.inf if settled is None else settled * per_second
        row = f"{acc:9.0e} {'> ' + str(t_end) if settled is None else format(settled, '.2f'):>17s} {wall_t:9.3f}"
        if continuation is not None:
            row += f" {continuation:17.3f} {wall_t / continuation:6.2f}"
        for key in coarse:
            fits = [(w, tol) for tol, w, e in shooting[key] if e <= acc]
            w, tol = min(fits) if fits else (np.nan, np.nan)
            row += f" {format(tol, '.0e') + ', ' + format(w, '.3f'):>20s} {wall_t / w:6.2f}"
        print(row)


def compare(mdot, t_end, coarse, repeat):
    """Transient against guess + shooting at one mass flow: the table rows."""
    model, tip = limit_cycle_model(n_elements=8, EA=1e5, mass_flow=mdot)
    st = pf.static_equilibrium(model, mass_flow=0.0).state
    per_second, cycles, final, period = transient_cycles(model, tip, st, t_end, repeat)
    steps = int(round(period / H))
    ref = pf.periodic_orbit(model, period=period, state=final, steps=steps, tol=1e-10)
    amp = orbit_amplitude(ref, tip)
    others = np.delete(np.abs(ref.multipliers), ref.trivial)
    # the transient's cost per simulated second: the cheaper of the run with every step
    # recorded and one recording two outputs (as the guess does)
    wall_plain, _ = best(lambda: pf.simulate(model, 3.0, state=st, step=H, n_outputs=2, progress=False,
                                             integrator="generalized_alpha"), repeat)
    per_second = min(per_second, wall_plain / 3.0)
    print(f"\nmdot = {mdot} kg/s: orbit amplitude {amp:.9f} m, period {ref.period:.9f} s; largest multiplier "
          f"{others.max():.4f} (out of plane); transient {per_second * period:.4f} s of CPU time per period")
    shooting = guess_and_shoot(model, tip, st, steps, amp, coarse, repeat)
    table(cycles, amp, per_second, t_end, shooting, coarse)


def near_hopf(mdot, t_end, coarse, repeat):
    """Near the Hopf point the cycle attracts slowly: the transient against the
    continuation from the Hopf point (which needs no guess) and against a coarse transient
    (pf.orbit_guess) + shooting, planar model."""
    model, tip = limit_cycle_model(n_elements=8, EA=1e5, mass_flow=mdot, planar=True)
    st = pf.static_equilibrium(model, mass_flow=0.0).state

    def shoot():
        hopf = pf.critical_mass_flow(model)
        br = pf.continue_orbits(model, start=hopf, mass_flow_end=mdot, amplitude=2e-2, steps=400, max_points=40)
        k = int(np.argmin(np.abs(br.mass_flow - mdot)))
        return br, pf.periodic_orbit(model, period=float(br.period[k]), state=br.starts[k], mass_flow=mdot,
                                     steps=int(round(float(br.period[k]) / H)), **LEAN)

    wall_orbit, (br, orbit) = best(shoot, repeat)
    amp = orbit_amplitude(orbit, tip)
    per_second, cycles, _, _ = transient_cycles(model, tip, st, t_end, 1)
    k = int(np.argmin(np.abs(br.mass_flow - mdot)))
    print(f"\nmdot = {mdot} kg/s (planar model): continuation from the Hopf point ({len(br.mass_flow)} orbits, "
          f"{br.stats['flow_maps']} flow maps) and the orbit at {mdot} kg/s ({orbit.stats['flow_maps']} flow maps, "
          f"without multipliers): amplitude {amp:.9f} m; largest multiplier {br.max_multiplier[k]:.4f} at "
          f"{br.mass_flow[k]:.3f} kg/s on the branch")
    steps = int(round(float(orbit.period) / H))
    shooting = guess_and_shoot(model, tip, st, steps, amp, coarse, repeat)
    table(cycles, amp, per_second, t_end, shooting, coarse, continuation=wall_orbit)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5, help="best of this many runs")
    ap.add_argument("--coarse", nargs="+", type=float, default=[1.0, 4.0, 8.0],
                    help="the shooting's guesses: pf.orbit_guess with the step k h")
    ap.add_argument("--skip-hopf", action="store_true", help="only the 30 kg/s comparison")
    args = ap.parse_args()
    try:
        from threadpoolctl import threadpool_info
        blas = ", ".join(f"{i['internal_api']} {i['num_threads']} threads" for i in threadpool_info())
    except ImportError:
        blas = "threadpoolctl missing"
    print(f"load average {os.getloadavg()[0]:.2f}; BLAS: {blas} (the analyses of models below 500 coordinates "
          f"use one)")
    compare(30.0, 12.0, args.coarse, args.repeat)   # Fig. 3: a strongly attracting cycle
    if not args.skip_hopf:
        near_hopf(25.5, 60.0, args.coarse, args.repeat)          # near the Hopf point: the transient settles slowly


if __name__ == "__main__":
    main()
