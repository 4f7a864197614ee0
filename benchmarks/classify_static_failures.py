"""Classify static failures of random models: limit points or solver weaknesses?

Random pipe models (lines and arcs of 1-2 sections, five kinds of supports, dead and
follower loads, gravity, a point mass, a mass flow) and planar ANCF beams are described
by a seeded numpy generator, with parameters within and slightly outside physical ranges
(as the fuzz tests': EI 1e-2 ... 1e4 N m^2, EA/EI 10 ... 1e7 1/m^2,
loads up to 10 x the stiffness level EI [N], gravity up to 20 m/s^2 a component, flows
up to 3 flow units), and built by the fuzz tests' builders (tests/fuzz/models.py). Each
model is solved by ``pf.static_equilibrium``:

1. ``path="load"`` (load stepping with bisection, the solver before arc length); if it
   converges: **load stepping**;
2. else ``path="auto"`` (arc-length continuation from the last converged step): it
   converges: **arclength** (with the number of limit points passed: snap-through), or
   raises ``LimitPointError`` (the load factor turned back below 1 and did not return
   within ``arc_steps`` steps): **limit point** (checked: the tangent there is
   singular); those are re-run with a 5 x budget to see whether the path comes back to
   the full load after all (**far branch**), and those whose tangent at rest is already
   near-singular (smallest singular value below 1e-12 of the largest: a near-mechanism,
   e.g. supports that leave a rigid motion to round-off) are counted apart;
3. else a ``ConvergenceError``; with a flow, ``path="arclength"`` (the flow ramped with
   the loads from rest) is tried too; else **solver failure** (singular tangent: a
   mechanism or a bifurcation; Newton's failure at the start; ...).

Models refused up front (ValueError/TypeError: unsupported parts, overflows) are counted
apart; each model runs in its own process with a time limit (**timeout**).

    PYTHONPATH=python .venv/bin/python benchmarks/classify_static_failures.py --models 300 [--start 0]
"""
from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import sys
import time
import traceback
from collections import Counter
from pathlib import Path

import numpy as np

COMPONENTS = ("ux", "uy", "uz", "rx", "ry", "rz")
FUZZ = str(Path(__file__).resolve().parents[1] / "tests" / "fuzz")  # the builders' module, models.py


def _unit(rng):
    while True:
        v = rng.uniform(-1, 1, 3)
        if np.linalg.norm(v) > 0.2:
            return v / np.linalg.norm(v)


def _logu(rng, lo, hi):
    return float(10 ** rng.uniform(np.log10(lo), np.log10(hi)))


def describe(rng):
    """A plain-dict model description (JSON: the printout reproduces it)."""
    if rng.random() < 0.15:  # a planar ANCF cantilever
        EI = _logu(rng, 1e-2, 1e4)
        return dict(kind="ancf", hub=False, n=int(rng.integers(1, 5)), elastic=str(rng.choice(["A", "0"])), EI=EI,
                    EA=EI * _logu(rng, 1e2, 1e6), mass=_logu(rng, 0.05, 50.0), length=_logu(rng, 0.1, 3.0),
                    angle=float(rng.uniform(-np.pi, np.pi)), load=list(rng.uniform(-1, 1, 2)),
                    level=EI * _logu(rng, 1e-3, 10.0),
                    gravity=None if rng.random() < 0.5 else [float(rng.uniform(-20, 20)), float(rng.uniform(-20, 20)), 0.0])
    fluid = rng.random() < 0.8
    sections = []
    for _ in range(int(rng.integers(1, 3))):
        EI = _logu(rng, 1e-2, 1e4)
        s = dict(EI=EI, pipe_mass=_logu(rng, 0.05, 50.0), fluid_mass=_logu(rng, 0.05, 50.0) if fluid else 0.0)
        if rng.random() < 0.5:
            s["EIz"] = EI * _logu(rng, 0.2, 5.0)
        if rng.random() < 0.5:
            s["EA"] = EI * _logu(rng, 1e1, 1e7)
        if rng.random() < 0.5:
            s["GJ"] = EI * _logu(rng, 0.2, 2.0)
        if rng.random() < 0.5:
            s["GAy"] = s["GAz"] = EI * _logu(rng, 1e2, 1e6)
        sections.append(s)
    segments, left = [], 8
    for _ in range(int(rng.integers(1, 4))):
        if left <= 0:
            break
        n = int(rng.integers(1, min(4, left) + 1))
        left -= n
        if rng.random() < 0.5:
            segments.append(dict(kind="line", direction=list(_unit(rng)), length=_logu(rng, 0.1, 3.0), n=n))
        else:
            segments.append(dict(kind="arc", normal=list(_unit(rng)), radial=list(_unit(rng)),
                                 radius=_logu(rng, 0.05, 2.0),
                                 angle=float(rng.choice([-1, 1]) * rng.uniform(0.05, 2 * np.pi)), n=n))
    support = str(rng.choice(["clamp", "clamp", "clamp", "clamp_both", "pin_pin", "hinge_roller", "fix_random"]))
    m = dict(kind="pipe", sections=sections, segments=segments, support=support, axis=list(_unit(rng)),
             fixed=[list(rng.choice(COMPONENTS, size=int(rng.integers(1, 7)), replace=False)) for _ in range(2)])
    scale = max(s["EI"] for s in sections)
    m["loads"] = [dict(node=int(rng.integers(0, 21)), force=list(rng.uniform(-1, 1, 3)),
                       moment=list(rng.uniform(-1, 1, 3)), follower=bool(rng.random() < 0.5),
                       level=scale * _logu(rng, 1e-4, 10.0)) for _ in range(int(rng.integers(0, 3)))]
    m["gravity"] = None if rng.random() < 0.3 else list(rng.uniform(-20, 20, 3))
    m["point_masses"] = [] if rng.random() < 0.5 else [
        dict(node=int(rng.integers(0, 21)), mass=_logu(rng, 1e-3, 10.0), inertia=(0.0, 0.0, 0.0))]
    m["flow"] = float(rng.uniform(0, 3)) if fluid and rng.random() < 0.6 else 0.0
    m["load_steps"] = int(rng.integers(1, 5))
    return m


def build(m):
    """(model, mass flow [kg/s], load steps) of a description, by the fuzz tests' builders
    (the descriptions here are in their format; only the distributions differ)."""
    if FUZZ not in sys.path:
        sys.path.insert(0, FUZZ)
    from models import build_ancf, build_pipe

    if m["kind"] == "ancf":
        return build_ancf(m), 0.0, 1
    model, mdot = build_pipe(m)
    return model, mdot, m["load_steps"]


def classify(m, arc_steps=200):
    """(class, details) of one model description."""
    import pipeflex as pf

    try:
        model, mdot, steps = build(m)
    except (ValueError, TypeError) as e:
        return "refused", str(e)[:120]
    t0 = time.perf_counter()
    try:
        pf.static_equilibrium(model, mass_flow=mdot, load_steps=steps, path="load")
        return "load stepping", f"{time.perf_counter() - t0:.3f} s"
    except (ValueError, TypeError) as e:
        return "refused", str(e)[:120]
    except pf.ConvergenceError as e:
        first = f"{type(e).__name__} at load factor {e.load_factor:.4g}"
    s0 = _singular_values(model, model.initial_state(), mdot, 0.0)
    mechanism = s0[-1] <= 1e-12 * s0[0]  # the tangent at rest: near-singular?
    try:
        r = pf.static_equilibrium(model, mass_flow=mdot, load_steps=steps, path="auto", arc_steps=arc_steps)
        kind = f"snap-through, {len(r.limit_points)} limit points" if r.limit_points else "no limit point"
        return f"arclength ({kind})", f"{first}; limit points {[round(x, 4) for x in r.limit_points]}"
    except pf.LimitPointError as e:
        # at a limit point the tangent is singular: check it
        lf = e.load_factor
        s = _singular_values(model, e.reached_state, e.mass_flow, lf)
        detail = f"{first}; limit at {lf:.4g} (tangent sigma_min/sigma_max {s[-1] / s[0]:.1e})"
        if not s[-1] <= 1e-6 * s[0]:
            return "limit point, tangent not singular (unverified)", detail
        if mechanism:
            return "limit point of a near-mechanism (tangent at rest near-singular)", detail
        try:
            pf.static_equilibrium(model, mass_flow=mdot, load_steps=steps, path="auto", arc_steps=5 * arc_steps)
            return "limit point, far branch found with a 5x budget", detail
        except pf.LimitPointError:
            return "limit point", detail
        except pf.ConvergenceError as e2:
            return "limit point", detail + f"; 5x budget: {str(e2)[-100:]}"
    except pf.ConvergenceError as e:
        kind = "singular" if isinstance(e, pf.SingularMatrixError) else "no convergence"
        if mdot and not mechanism:  # the flow alone: ramp it with the loads from rest
            try:
                r = pf.static_equilibrium(model, mass_flow=mdot, load_steps=steps, path="arclength",
                                          arc_steps=arc_steps)
                return "arclength, flow ramped from rest (path='arclength')", f"{first}; {r.limit_points}"
            except pf.LimitPointError as e2:
                return "limit point of the flow+load ramp (path='arclength')", f"{first}; {str(e2)[:100]}"
            except pf.ConvergenceError:
                pass
        if mechanism:
            kind += ", tangent at rest near-singular: a near-mechanism"
        elif "at t = 0:" in str(e) or "at the start" in str(e):
            kind += ", at the start"
        return f"solver failure ({kind})", f"{first}; {str(e)[-160:]}"


def _singular_values(model, state, mdot, load_factor):
    from pipeflex.analysis._assembly import residual_and_tangent

    _, K = residual_and_tangent(model, state, model.load_state(mass_flow=mdot, gravity_factor=load_factor),
                                load_factor=load_factor)
    return np.linalg.svd(K.toarray(), compute_uv=False)


def _child(m, conn):
    try:
        conn.send(classify(m))
    except Exception as e:  # a bug: report it, do not hide it
        conn.send(("bug", f"{type(e).__name__}: {e}\n{traceback.format_exc()[-400:]}"))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--models", type=int, default=250)
    ap.add_argument("--start", type=int, default=0, help="index of the first model (the generator's key)")
    ap.add_argument("--timeout", type=float, default=60.0, help="per model [s]")
    ap.add_argument("--verbose", action="store_true")
    ap.add_argument("--json", help="write the counts and the failures to this file")
    ap.add_argument("--indices", type=int, nargs="*", help="only these model indices")
    args = ap.parse_args()
    ctx = mp.get_context("fork")
    counts, failures = Counter(), []
    t0 = time.time()
    indices = args.indices if args.indices else range(args.start, args.start + args.models)
    for i in indices:
        m = describe(np.random.default_rng([2026, i]))
        recv, send = ctx.Pipe(duplex=False)
        p = ctx.Process(target=_child, args=(m, send))
        p.start()
        if recv.poll(args.timeout):
            cls, detail = recv.recv()
        else:
            cls, detail = "timeout", f"> {args.timeout} s"
        p.join(1.0)
        if p.is_alive():
            p.terminate()  # the process this loop started
            p.join()
        counts[cls] += 1
        if cls != "load stepping" and cls != "refused":
            failures.append(dict(index=i, cls=cls, detail=detail, kind=m["kind"]))
        if args.verbose or cls not in ("load stepping", "refused"):
            print(f"{i:4d} {m['kind']:5s} {cls}: {detail}", flush=True)
    print(f"\n{len(indices)} models (generator key 2026, indices {indices[0]}..{indices[-1]}), "
          f"{time.time() - t0:.0f} s")
    for cls, n in counts.most_common():
        print(f"  {n:4d}  {cls}")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(dict(counts=counts, failures=failures), fh, indent=1, default=str)


if __name__ == "__main__":
    sys.exit(main())
