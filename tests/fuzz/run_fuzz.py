"""The long fuzz run (``make fuzz``): hypothesis-generated
models through static, eigen, critical flow, simulate (generalised-alpha and IDA),
ANCF (static, simulate, rotating frequencies) and multibody (static, eigen, critical
flow, simulate) analyses.

Each family runs in its own worker process with a time limit, so a crash (segfault,
abort, a sanitizer report) or a hang is detected, not waited on: before each case the
worker writes the case to ``<out>/current-<family>.json``, the reproducer of whatever
killed it, and signals the start and the end of the case on a pipe to the parent. The
parent's own timer decides "hang" (a case running longer than ``--case-timeout``
seconds) before anything else happens; only then does it collect a stack (the worker's
threads from ``/proc``, and the Python stacks the worker's faulthandler writes to
``<out>/stack-<family>-<seed>.txt`` on SIGUSR1) and kill the worker. A dump that itself
crashes the worker (faulthandler reads the frames of a thread that is running) cannot
turn a hang into a crash. A worker that dies is restarted with another seed for the
cases left.

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
import importlib.util
import json
import os
import re
import select
import signal
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
MODELS = HERE / "models.py"  # the module that draws (cases), runs (run_case) and prints (dumps) cases
DUMP_SIGNAL = signal.SIGUSR1  # the parent asks a hung worker for its Python stacks with it
DUMP_GRACE = 3.0  # seconds the parent waits for that dump before it kills the worker


def load_models(path=MODELS):
    """The cases module at ``path``, imported as ``models`` (tests pass a fake one)."""
    path = Path(path).resolve()
    if path == MODELS and "models" in sys.modules:
        return sys.modules["models"]
    spec = importlib.util.spec_from_file_location("models", path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules["models"] = mod
    spec.loader.exec_module(mod)
    return mod


def worker(family, n, seed, out, case_timeout, beat_fd=None, models_path=MODELS):
    """Run n cases of one family in this process; write <out>/<family>-<seed>.json.

    Writes b"s" to the pipe ``beat_fd`` when a case starts and b"e" when it ends: the
    parent times the cases with them (see :func:`run_worker`)."""
    import faulthandler

    from hypothesis import HealthCheck, Phase, given, settings
    from hypothesis import seed as hseed

    models = load_models(models_path)
    faulthandler.enable()  # a crash prints the Python stack to stderr (the parent's log)
    stack_file = open(out / f"stack-{family}-{seed}.txt", "w")  # noqa: SIM115 - open for the process's life
    faulthandler.register(DUMP_SIGNAL, file=stack_file, all_threads=True, chain=False)
    if beat_fd is not None:
        os.set_inheritable(beat_fd, False)  # a process the case starts must not hold the pipe open

    def beat(mark):
        if beat_fd is not None:
            os.write(beat_fd, mark)

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
        # the parent decides a hang and kills this worker after case_timeout; this timer
        # only ends a worker whose parent has gone
        faulthandler.dump_traceback_later(4 * case_timeout + 60, exit=True, file=stack_file)
        beat(b"s")
        t0 = time.perf_counter()
        try:
            outcome = models.run_case(case)
        except models.Bug as e:
            outcome = "bug"
            bugs.append(dict(case=case, error=str(e),
                             traceback="".join(traceback.format_exception(e.__cause__ or e))))
        finally:
            faulthandler.cancel_dump_traceback_later()
            beat(b"e")
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


def _threads_from_outside(pid):
    """The state, kernel wait channel and system call of each thread of ``pid``, read
    from /proc (needs nothing from the process, so it works whatever the process does)."""
    lines = []
    for task in sorted(Path(f"/proc/{pid}/task").glob("*"), key=lambda t: int(t.name)):
        def read(name):
            try:
                return (task / name).read_text().strip()
            except OSError:
                return "?"
        stat = read("stat")
        state = stat.rsplit(")", 1)[-1].split()[0] if ")" in stat else "?"
        syscall = read("syscall").split()[0] if read("syscall") != "?" else "?"
        lines.append(f"  thread {task.name} ({read('comm')}): state {state}, wchan {read('wchan') or '-'}, "
                     f"syscall {syscall}")
    return "\n".join(lines)


def run_worker(cmd, case_timeout, deadline, log, stack_path):
    """Run the worker ``cmd`` (to which the write end of a pipe is appended) and time its
    cases by their b"s"/b"e" marks on that pipe.

    Returns ``(hang, code, stack)``: ``hang`` is None when the worker ended by itself,
    else why this process's own timer declared a hang ("case" or "family time limit"),
    decided before any stack is asked for; ``code`` the worker's exit status; ``stack``
    for a hang, the worker's threads from /proc and the Python stacks it dumped on
    :data:`DUMP_SIGNAL` (whatever came of that dump: it does not change the verdict).
    """
    r, w = os.pipe()
    try:
        with open(log, "w") as err:
            proc = subprocess.Popen(cmd + [str(w)], stdin=subprocess.DEVNULL, stdout=err, stderr=err,
                                    pass_fds=(w,))
    finally:
        os.close(w)
    started, hang = None, None
    try:
        while True:
            limit = deadline if started is None else min(deadline, started + case_timeout)
            now = time.monotonic()
            if now >= limit:
                hang = "case" if started is not None and limit < deadline else "family time limit"
                break
            if select.select([r], [], [], min(0.5, limit - now))[0]:
                marks = os.read(r, 4096)
                if not marks:
                    break  # the worker closed the pipe: it has ended
                started = time.monotonic() if marks.endswith(b"s") else None
            elif proc.poll() is not None:
                break
    finally:
        os.close(r)
    if hang is None:
        return None, proc.wait(), ""
    # the verdict is in; now (only now) ask for the stacks, then kill the worker
    limit = f"a case past {case_timeout:g} s" if hang == "case" else "the family's time limit"
    stack = [f"hang ({limit}) decided by the fuzz driver's timer; the worker's threads:",
             _threads_from_outside(proc.pid)]
    proc.send_signal(DUMP_SIGNAL)
    # faulthandler writes the stacks and goes on: wait until the file stops growing
    t_end, size = time.monotonic() + DUMP_GRACE, -1
    while time.monotonic() < t_end and proc.poll() is None:
        time.sleep(0.1)
        now = stack_path.stat().st_size if stack_path.exists() else 0
        if now and now == size:
            break
        size = now
    proc.kill()
    code = proc.wait()
    if code != -signal.SIGKILL:
        stack.append(f"(the worker died with exit {code} while dumping its stacks)")
    dumped = stack_path.read_text(errors="replace") if stack_path.exists() else ""
    stack.append("Python stacks (faulthandler):\n" + (dumped.strip() or "(none written)"))
    return hang, code, "\n".join(stack)


def drive(family, n, seed, out, case_timeout, family_timeout, models_path=MODELS):
    """Run a family's n cases in worker processes; restart after a crash or a hang.

    A hang is a case that runs longer than ``case_timeout`` [s] by this process's clock
    (or a worker still running at ``family_timeout`` [s]); a crash, a worker that ended
    without its report (a signal, an abort, a sanitizer report, a nonzero exit)."""
    counts, bugs, seconds, slowest, left, attempt = Counter(), [], 0.0, [], n, 0
    deadline = time.monotonic() + family_timeout
    while left > 0:
        s = seed + 1000 * attempt
        attempt += 1
        cmd = [sys.executable, str(Path(__file__).resolve()), "--worker", family, str(left), str(s), str(out),
               str(case_timeout), str(Path(models_path).resolve())]
        t0 = time.perf_counter()
        log = out / f"stderr-{family}-{s}.txt"
        hang, code, stack = run_worker(cmd, case_timeout, deadline, log, out / f"stack-{family}-{s}.txt")
        seconds += time.perf_counter() - t0
        report = out / f"{family}-{s}.json"
        if hang is None and code == 0 and report.exists():
            r = json.loads(report.read_text())
            counts.update(r["counts"])
            bugs += r["bugs"]
            slowest += r["slowest"]
            left = 0
            break
        current = out / f"current-{family}.json"
        case = json.loads(current.read_text()) if current.exists() else None
        kind = "crash" if hang is None else "hang"
        counts[kind] += 1
        stderr = log.read_text(errors="replace") if log.exists() else ""
        error = f"crash (exit {code})" if hang is None else f"hang ({hang})"
        bugs.append(dict(case=case, error=error, traceback=(stack + "\n" + stderr[-3000:] if stack else stderr[-6000:])))
        if hang == "family time limit" or time.monotonic() >= deadline or attempt >= 100:
            break
        progress = out / f"progress-{family}-{s}.txt"
        done = progress.read_text().split() if progress.exists() else []
        counts.update(done)  # the cases the worker finished before it died
        left -= len(done) + 1  # the case that hung or crashed is one of them
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
    ap.add_argument("--worker", nargs=7, help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.worker:
        family, n, seed, out, case_timeout, models_path, beat_fd = a.worker
        worker(family, int(n), int(seed), Path(out), float(case_timeout), int(beat_fd), Path(models_path))
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
