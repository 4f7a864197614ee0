"""The long fuzz run (``make fuzz``): hypothesis-generated
models through static, eigen, critical flow, simulate (generalised-alpha and IDA),
ANCF (static, simulate, rotating frequencies) and multibody (static, eigen, critical
flow, simulate) analyses.

Each family runs in its own worker process with a time limit, so a crash (segfault,
abort, a sanitizer report) or a hang is detected, not waited on: before each case the
worker writes the case to ``<out>/current-<family>.json``, the reproducer of whatever
killed it, and a per-case watchdog (faulthandler) dumps the stacks and ends a worker
stuck in one case for ``--case-timeout`` seconds. A worker that dies is restarted with
another seed for the cases left.

Outcomes per case (tests/fuzz/models.py): "ok" (finite results), a documented exception
type (ValueError, TypeError, ConvergenceError, SingularMatrixError), or a bug (a
non-finite result without an exception, an undocumented exception, a ValueError leaked
from numpy/scipy, a crash, a hang). Exit status 1 if there was any bug.

    .venv/bin/python tests/fuzz/run_fuzz.py --examples 10000 [--jobs 2] [--seed 0]
    .venv/bin/python tests/fuzz/run_fuzz.py --replay case.json   # rerun one case
    .venv/bin/python tests/fuzz/run_fuzz.py --replay tests/fuzz/open_bugs.json
        # one reproducer per kind of bug a 10 000-case run found (tests/test_properties.py
        # replays those that are fixed)
"""
from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import time
import traceback
from collections import Counter
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

# Share of the examples per family (sums to 1).
WEIGHTS = {"static": 0.2, "eigen": 0.2, "critical": 0.15, "simulate": 0.2, "ancf": 0.1, "multibody": 0.15}


def worker(family, n, seed, out, case_timeout):
    """Run n cases of one family in this process; write <out>/<family>-<seed>.json."""
    import faulthandler

    from hypothesis import HealthCheck, Phase, given, settings
    from hypothesis import seed as hseed

    import models

    counts, bugs, slowest = Counter(), [], []
    current = out / f"current-{family}.json"
    progress = open(out / f"progress-{family}-{seed}.txt", "w", buffering=1)  # survives a crash

    @hseed(seed)
    @settings(max_examples=n, deadline=None, database=None, phases=[Phase.generate],
              suppress_health_check=list(HealthCheck))
    @given(models.cases(family))
    def run(case):
        text = models.dumps(case)
        current.write_text(text)
        faulthandler.dump_traceback_later(case_timeout, exit=True)
        t0 = time.perf_counter()
        try:
            outcome = models.run_case(case)
        except models.Bug as e:
            outcome = "bug"
            bugs.append(dict(case=case, error=str(e),
                             traceback="".join(traceback.format_exception(e.__cause__ or e))))
        finally:
            faulthandler.cancel_dump_traceback_later()
        dt = time.perf_counter() - t0
        counts[outcome] += 1
        progress.write(outcome + "\n")
        slowest.append((dt, outcome, text))
        slowest.sort(key=lambda s: -s[0])
        del slowest[3:]

    t0 = time.perf_counter()
    run()
    result = dict(family=family, seed=seed, counts=counts, bugs=bugs, seconds=time.perf_counter() - t0,
                  slowest=[dict(seconds=s, outcome=o, case=json.loads(c)) for s, o, c in slowest])
    (out / f"{family}-{seed}.json").write_text(json.dumps(result, indent=1, default=float))
    current.unlink(missing_ok=True)


def drive(family, n, seed, out, case_timeout, family_timeout):
    """Run a family's n cases in worker processes; restart after a crash or a hang."""
    counts, bugs, seconds, slowest, left, attempt = Counter(), [], 0.0, [], n, 0
    deadline = time.monotonic() + family_timeout
    while left > 0:
        s = seed + 1000 * attempt
        attempt += 1
        cmd = [sys.executable, str(Path(__file__).resolve()), "--worker", family, str(left), str(s), str(out),
               str(case_timeout)]
        t0 = time.perf_counter()
        try:
            proc = subprocess.run(cmd, capture_output=True, text=True, timeout=max(1.0, deadline - time.monotonic()))
            code, stderr = proc.returncode, proc.stderr
        except subprocess.TimeoutExpired as e:
            code, stderr = "timeout", (e.stderr or b"").decode(errors="replace") if isinstance(e.stderr, bytes) \
                else (e.stderr or "")
        seconds += time.perf_counter() - t0
        report = out / f"{family}-{s}.json"
        if code == 0 and report.exists():
            r = json.loads(report.read_text())
            counts.update(r["counts"])
            bugs += r["bugs"]
            slowest += r["slowest"]
            left = 0
            break
        current = out / f"current-{family}.json"
        case = json.loads(current.read_text()) if current.exists() else None
        kind = "hang" if code == "timeout" or "Timeout (" in stderr else "crash"
        counts[kind] += 1
        bugs.append(dict(case=case, error=f"{kind} (exit {code})", traceback=stderr[-6000:]))
        if code == "timeout" or time.monotonic() >= deadline or attempt >= 100:
            break
        progress = out / f"progress-{family}-{s}.txt"
        done = progress.read_text().split() if progress.exists() else []
        counts.update(done)  # the cases the worker finished before it died
        left = max(1, left - len(done) - 1)
    return dict(family=family, counts=dict(counts), bugs=bugs, seconds=seconds,
                slowest=sorted(slowest, key=lambda s: -s["seconds"])[:3])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--examples", type=int, default=10000, help="cases in all, shared by WEIGHTS")
    ap.add_argument("--families", nargs="+", default=list(WEIGHTS), choices=list(WEIGHTS))
    ap.add_argument("--jobs", type=int, default=1, help="families run in parallel")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--case-timeout", type=float, default=120.0, help="seconds; a case that takes longer is a hang")
    ap.add_argument("--timeout", type=float, default=3600.0, help="seconds per family")
    ap.add_argument("--out", type=Path, default=Path("build/fuzz"))
    ap.add_argument("--crashes-only", action="store_true",
                    help="exit status 1 only for crashes and hangs (the sanitizer job), not for other bugs")
    ap.add_argument("--replay", type=Path, help="run the case in this JSON file and show its outcome")
    ap.add_argument("--worker", nargs=5, help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.worker:
        family, n, seed, out, case_timeout = a.worker
        worker(family, int(n), int(seed), Path(out), float(case_timeout))
        return 0
    if a.replay:  # one case, a bug record ({"case": ...}) or a list of them (open_bugs.json)
        import models

        data = json.loads(a.replay.read_text())
        for entry in data if isinstance(data, list) else [data]:
            case = entry.get("case", entry)
            print(entry.get("kind", case.get("family")), flush=True)
            try:
                print("  ->", models.run_case(case), flush=True)
            except models.Bug as e:
                print("  -> bug:", e, flush=True)
        return 0
    a.out.mkdir(parents=True, exist_ok=True)
    total = sum(WEIGHTS[f] for f in a.families)
    share = {f: max(1, round(a.examples * WEIGHTS[f] / total)) for f in a.families}
    t0 = time.perf_counter()
    with ThreadPoolExecutor(max(1, a.jobs)) as pool:
        results = list(pool.map(lambda f: drive(f, share[f], a.seed, a.out, a.case_timeout, a.timeout), a.families))
    wall = time.perf_counter() - t0
    counts = Counter()
    for r in results:
        counts.update(r["counts"])
        print(f"{r['family']:>10}: {sum(r['counts'].values()):6d} cases in {r['seconds']:7.1f} s  "
              + ", ".join(f"{k} {v}" for k, v in sorted(r["counts"].items())))
    n_bugs = sum(len(r["bugs"]) for r in results)
    print(f"{'all':>10}: {sum(counts.values()):6d} cases in {wall:7.1f} s wall  "
          + ", ".join(f"{k} {v}" for k, v in sorted(counts.items())))
    summary = dict(examples=sum(counts.values()), wall_seconds=wall, seed=a.seed, counts=dict(counts),
                   families=results, python=sys.version.split()[0])
    (a.out / "summary.json").write_text(json.dumps(summary, indent=1, default=float))
    # bugs grouped by their message (numbers blanked), each with its shortest reproducer
    kinds = {}
    for r in results:
        for b in r["bugs"]:
            key = (r["family"], re.sub(r"[-+]?\d[\d.e+-]*", "#", b["error"]))
            kinds.setdefault(key, []).append(b)
    for (family, key), bs in sorted(kinds.items(), key=lambda kv: -len(kv[1])):
        b = min(bs, key=lambda b: len(json.dumps(b["case"], default=float)))
        print(f"\nBUG x{len(bs)} ({family}): {b['error']}\n  reproduce: {json.dumps(b['case'], default=float)}\n"
              + "  " + b["traceback"].strip().replace("\n", "\n  ")[-2500:])
    summary["bug_kinds"] = {f"{f}: {k}": len(v) for (f, k), v in kinds.items()}
    (a.out / "summary.json").write_text(json.dumps(summary, indent=1, default=float))
    fatal = sum(counts[k] for k in ("crash", "hang"))
    print(f"\nsummary: {a.out / 'summary.json'}; bugs: {n_bugs} (crashes and hangs: {fatal})")
    return 1 if (fatal if a.crashes_only else n_bugs) else 0


if __name__ == "__main__":
    sys.exit(main())
