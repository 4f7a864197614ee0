"""Benchmark: the flutter limit cycle by shooting against the long transient (issue
"Continuation of the flutter limit cycles", item 4).

The cantilever of Meijaard & Hakvoort's Fig. 3 (8 elements, 3D: 48 coordinates, 96
states; EA = 1e5 N, tip force 1.5 N, 30 kg/s), the same integrator and step in both:
generalised-alpha, h = 5e-4 s.
- transient: from the static deflection; the cycle's amplitude after each period is
  compared with the orbit's; the wall time to reach a given accuracy is the run's wall
  time per simulated second times the time it needs.
- shooting: pf.periodic_orbit from the transient's state at an early time (a rough guess),
  to a periodicity defect of 1e-8.
Two flows: Fig. 3's 30 kg/s, whose cycle attracts strongly (the transient wins), and
25.5 kg/s near the Hopf point, where it attracts slowly (shooting wins).
- continuation: a branch of 40 orbits of the planar model (400 steps per period) from
  the Hopf point.
Run: .venv/bin/python benchmarks/bench_periodic.py
"""
import os
import time

import numpy as np

import pipeflex as pf
from pipeflex.seeds.seed000.limit_cycle import limit_cycle_model

H = 5e-4


def compare(mdot, t_end, t_guess):
    """Transient against shooting at one mass flow: the table rows."""
    model, tip = limit_cycle_model(n_elements=8, EA=1e5, mass_flow=mdot)
    st = pf.static_equilibrium(model, mass_flow=0.0).state
    t0 = time.perf_counter()
    r = pf.simulate(model, t_end, state=st, step=H, n_outputs=int(t_end / H) + 1, progress=False,
                    integrator="generalized_alpha")
    wall_per_second = (time.perf_counter() - t0) / t_end
    guess = pf.simulate(model, t_guess, state=st, step=H, n_outputs=2, progress=False,
                        integrator="generalized_alpha").final_state
    y = r.x[:, tip, 1]
    mean = 0.5 * (y[-2000:].max() + y[-2000:].min())
    up = np.flatnonzero((y[:-1] < mean) & (y[1:] >= mean))
    period = float(np.diff(r.t[up[-5:]]).mean())
    t0 = time.perf_counter()
    orbit = pf.periodic_orbit(model, period=period, state=guess, steps=int(round(period / H)))
    wall_orbit = time.perf_counter() - t0
    amp = orbit.amplitude[tip, 1]
    others = np.delete(np.abs(orbit.multipliers), orbit.trivial)
    in_plane = sorted(others)[-2] if others.max() > 1 else others.max()
    # amplitude of each cycle of the transient: half the range between upward mean crossings
    cycles = [(r.t[b], 0.5 * (y[a:b].max() - y[a:b].min())) for a, b in zip(up[:-1], up[1:])]
    print(f"\nmdot = {mdot} kg/s: orbit amplitude {amp:.9f} m, period {orbit.period:.9f} s, defect "
          f"{orbit.residual:.1e}, {orbit.iterations} Newton iterations, {orbit.stats['flow_maps']} flow maps from the "
          f"state at t = {t_guess} s; largest multiplier {others.max():.4f} (out of plane), next {in_plane:.4f}")
    table(cycles, amp, t_end, wall_per_second, wall_orbit)


def near_hopf(mdot, t_end):
    """Near the Hopf point the cycle attracts slowly: the transient against the
    continuation from the Hopf point (which needs no guess), planar model."""
    model, tip = limit_cycle_model(n_elements=8, EA=1e5, mass_flow=mdot, planar=True)
    st = pf.static_equilibrium(model, mass_flow=0.0).state
    t0 = time.perf_counter()
    hopf = pf.critical_mass_flow(model)
    br = pf.continue_orbits(model, start=hopf, mass_flow_end=mdot, amplitude=2e-2, steps=400, max_points=40)
    k = int(np.argmin(np.abs(br.mass_flow - mdot)))
    orbit = pf.periodic_orbit(model, period=float(br.period[k]), state=br.starts[k], mass_flow=mdot,
                              steps=int(round(float(br.period[k]) / H)))
    wall_orbit = time.perf_counter() - t0
    amp = orbit.amplitude[tip, 1]
    t0 = time.perf_counter()
    r = pf.simulate(model, t_end, state=st, step=H, n_outputs=int(t_end / H) + 1, progress=False,
                    integrator="generalized_alpha")
    wall_per_second = (time.perf_counter() - t0) / t_end
    y = r.x[:, tip, 1]
    mean = 0.5 * (y[-2000:].max() + y[-2000:].min())
    up = np.flatnonzero((y[:-1] < mean) & (y[1:] >= mean))
    cycles = [(r.t[b], 0.5 * (y[a:b].max() - y[a:b].min())) for a, b in zip(up[:-1], up[1:])]
    mu = np.delete(np.abs(orbit.multipliers), orbit.trivial).max()
    print(f"\nmdot = {mdot} kg/s (planar model): continuation from the Hopf point ({len(br.mass_flow)} orbits) and "
          f"the orbit at {mdot} kg/s: amplitude {amp:.9f} m, largest multiplier {mu:.4f}")
    table(cycles, amp, t_end, wall_per_second, wall_orbit)


def table(cycles, amp, t_end, wall_per_second, wall_orbit):
    print(f"{'accuracy (rel.)':>16s} {'transient: t needed [s]':>24s} {'wall [s]':>9s} {'shooting wall [s]':>18s} "
          f"{'transient / shooting':>21s}")
    for tol in (1e-2, 1e-3, 1e-4, 1e-6):
        settled = next((t for t, a in cycles if all(abs(b / amp - 1) <= tol for tt, b in cycles if tt >= t)), None)
        if settled is None:
            print(f"{tol:16.0e} {'not within ' + str(t_end) + ' s':>24s} "
                  f"{'> ' + format(t_end * wall_per_second, '.2f'):>9s} {wall_orbit:18.3f}")
            continue
        wall_t = settled * wall_per_second
        print(f"{tol:16.0e} {settled:24.2f} {wall_t:9.3f} {wall_orbit:18.3f} {wall_t / wall_orbit:21.2f}")


def main():
    print(f"load average {os.getloadavg()[0]:.2f}")
    compare(30.0, 12.0, 1.0)   # Fig. 3: a strongly attracting cycle (in-plane multiplier 0.29)
    near_hopf(25.5, 60.0)      # near the Hopf point: the transient settles slowly


if __name__ == "__main__":
    main()
