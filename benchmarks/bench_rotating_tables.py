"""Benchmark: rotating cantilever of seed 002 (Berzeri & Shabana), Tables 2-5 and spin-up.

1. Table 2 (non-rotating frequencies, N = 0..4) and Tables 3-5 (30 configurations
   (N, R/L) x 8 gammas x 3 transverse modes = 720 entries; 10 ANCF Model A elements)
   with the seed's small-deformation linearisation. Target: Tables 3-5 under 2 s.
2. The same Tables 3-5 linearised about the nonlinear steady state ("steady_state";
   Newton continuation in Omega^2 per configuration). No target: for comparison.
3. One spin-up run (eq. 13, T = 15 s, 20 s of motion): the ref. 21 beam, 2 Model A
   elements, Omega = 4 rad/s, generalised-alpha at h = 2 ms.
Prints the median (and minimum) of repeated runs after a warm-up, the ratio to the
target, and a few of the computed numbers, so that a faster but wrong run shows.
Run: .venv/bin/python benchmarks/bench_rotating_tables.py [--repeat N]
"""
import argparse
import statistics
import time

import numpy as np

from pipeflex.seeds.seed002 import references as ref002, studies as rotating_studies, tables as rotating_tables

TARGET_TABLES = 2.0  # s, Tables 3-5 (small_deformation)


def timed(f, repeat):
    out = f()  # warm-up (imports, first-call overheads); its result is returned
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        f()
        times.append(time.perf_counter() - t)
    return statistics.median(times), min(times), out


def summary(result):
    """Largest |relative deviation| from the printed tables for gamma <= 10 (without the
    suspected misprint Table 4, N = 3, R/L = 3, gamma = 10) and for gamma = 20, 50."""
    dev = rotating_tables.deviations(result)
    low = high = 0.0
    for mode, table in dev.items():
        for key, d in table.items():
            d = np.abs(d)
            lo = d[:6].copy()
            if mode == 2 and key == (3, 3):
                lo[5] = 0.0
            low, high = max(low, float(lo.max())), max(high, float(d[6:].max()))
    return low, high


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    n_entries = 3 * len(ref002.TABLE3) * len(ref002.GAMMAS)

    med2, best2, t2 = timed(rotating_tables.table2, args.repeat)
    print(f"Table 2 (5 tip masses, gamma = 0): median {med2 * 1e3:7.1f} ms  (min {best2 * 1e3:6.1f} ms); "
          f"N = 0: {', '.join(f'{x:.4f}' for x in t2[0])}")

    med, best, small = timed(lambda: rotating_tables.tables_3_to_5(), args.repeat)
    low, high = summary(small)
    print(f"Tables 3-5, small_deformation ({n_entries} entries): median {med:.3f} s  (min {best:.3f} s); "
          f"target {TARGET_TABLES:.0f} s -> ratio {med / TARGET_TABLES:.2f}")
    print(f"    max |rel. deviation| from the printed values: gamma <= 10 {low:.1e} (without Table 4, N = 3, "
          f"R/L = 3, gamma = 10), gamma = 20/50 {high:.1e}")
    print(f"Tables 2-5 together: median {med + med2:.3f} s; target {TARGET_TABLES:.0f} s -> ratio "
          f"{(med + med2) / TARGET_TABLES:.2f}")

    meds, bests, steady = timed(lambda: rotating_tables.tables_3_to_5(linearization="steady_state"), args.repeat)
    diff = max(float(np.max(np.abs(steady.values[m][k][:6] / small.values[m][k][:6] - 1.0)))
               for m in (1, 2, 3) for k in small.values[m])
    strain = max(float(np.max(s[:6])) for s in steady.max_strain.values())
    print(f"Tables 3-5, steady_state ({n_entries} entries): median {meds:.3f} s  (min {bests:.3f} s); "
          f"{meds / med:.1f} x small_deformation")
    print(f"    gamma <= 10: largest steady_state / small_deformation - 1 = {diff:.1e} at axial strains up to "
          f"{strain:.1e}")

    medu, bestu, (t, tip) = timed(lambda: rotating_studies.spin_up(reference="ref21", n_elements=2, omega=4.0),
                                  args.repeat)
    print(f"spin-up (ref. 21 beam, 2 Model A elements, Omega = 4 rad/s, 20 s, h = 2 ms): median "
          f"{medu * 1e3:.1f} ms  (min {bestu * 1e3:.1f} ms); tip deflection: largest |.| {np.abs(tip).max():.4f} m, "
          f"at t = {t[-1]:.0f} s {tip[-1]:+.5f} m")


if __name__ == "__main__":
    main()
