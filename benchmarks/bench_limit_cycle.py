"""Benchmark: work-precision of the cantilever's limit cycle (seed 000 Fig. 3, issue 3).

4 elements, tip force 1.5 N, mdot = 30 kg/s; quantity of interest: the tip's lateral
displacement at t = 2 s. Reference: generalised-alpha at h = 62.5 and 31.25 us,
Richardson-extrapolated. IDA only at loose tolerances (it resolves the axial vibration
the flow start excites: see docs/performance.md).
Run: .venv/bin/python benchmarks/bench_limit_cycle.py
"""
import pipeflex as pf
from pipeflex.seeds.seed000.limit_cycle import limit_cycle_model
from pipeflex.work_precision import reference_by_extrapolation, work_precision


def main():
    m, tip = limit_cycle_model(n_elements=4)
    st = pf.static_equilibrium(m, mass_flow=0.0).state
    qoi = lambda r: r.x[-1, tip, 1]  # noqa: E731
    ref = reference_by_extrapolation(m, 2.0, qoi, step=6.25e-5, state=st)
    print(f"reference tip displacement at 2 s = {ref['reference']:.10f} m (error estimate {ref['error_estimate']:.1e})")
    runs = work_precision(m, 2.0, qoi, ref["reference"], steps=(2e-3, 1e-3, 5e-4, 2.5e-4), rtols=(1e-2, 1e-3),
                          state=st, repeat=2)
    print(f"{'integrator':18s} {'setting':>9s} {'abs. error [m]':>15s} {'wall [s]':>9s} {'steps':>7s}")
    for r in runs:
        print(f"{r.integrator:18s} {r.setting:9.1e} {r.error:15.2e} {r.wall_time:9.3f} {r.stats['steps']:7d}")


if __name__ == "__main__":
    main()
