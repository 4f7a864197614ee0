"""benchmarks/bench_peer.py --quick as a user runs it: a fresh interpreter writing its JSON, which must
hold the three scenes, each accuracy target's cheapest runs, and the table of where each method fails."""
import json
import os
import subprocess
import sys
from pathlib import Path

import pipeflex as pf

SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "bench_peer.py"
METHODS = {f"generalized_alpha rho_inf={rho}" for rho in (0.0, 0.5, 0.8, 1.0)} | {"rtol control (rtol=1e-4)",
                                                                                  "ida (rtol=1e-6)"}


def test_bench_peer_quick_writes_three_scenes_and_stability(tmp_path):
    out = tmp_path / "peer.json"
    env = dict(os.environ, PYTHONPATH=str(Path(pf.__file__).parents[1]))  # this checkout's package
    run = subprocess.run([sys.executable, str(SCRIPT), "--quick", "--json", str(out)], env=env,
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-2000:]
    data = json.loads(out.read_text())
    scenes = data["scenes"]
    assert set(scenes) == {"limit_cycle", "spin_up", "critical_flow"}

    for name in ("limit_cycle", "spin_up"):
        s = scenes[name]
        assert [row["target"] for row in s["cheapest"]] == [1e-2, 1e-3, 1e-4]
        methods = {r["method"] for r in s["runs"]}
        assert methods == {"fixed step", "rtol"}
        # the reference is converged far below the loosest target, and the loosest target is met
        assert s["reference_spread"] < 1e-6 * s["length_scale"]
        assert s["cheapest"][0]["rtol"] is not None and s["cheapest"][0]["rtol"]["error"] <= 1e-2
        # a smaller fixed step is more accurate (second order): the sweep measures what it claims
        fixed = sorted((r for r in s["runs"] if r["method"] == "fixed step"), key=lambda r: r["step"])
        assert fixed[0]["error"] < fixed[-1]["error"]
        for row in s["cheapest"]:
            assert row["peer"] == "not measured here" or isinstance(row["peer"], (dict, type(None)))

    cf = scenes["critical_flow"]
    for beta in ("0.2", "0.5"):
        runs = cf[beta]["runs"]
        assert [r["n_elements"] for r in runs] == [2, 4, 8]
        assert runs[-1]["error"] < runs[0]["error"] and runs[-1]["error"] < 2e-3  # converging to the continuous pipe
    assert cf["newton_limits"]["static_flow"] and cf["newton_limits"]["stiffness"]

    stability = data["stability"]
    for name in ("limit_cycle", "spin_up", "critical_flow"):
        assert {r["method"] for r in stability if r["scene"] == name} == METHODS
    lc = [r for r in stability if r["scene"] == "limit_cycle"]
    assert {r["mass_flow"] for r in lc} == {0.0, 30.0}
    by = {(r["method"], r["mass_flow"]): r for r in lc}
    # generalised-alpha's numerical damping: more energy lost per period the smaller rho_inf
    drift = [by[(f"generalized_alpha rho_inf={rho}", 0.0)]["energy_drift"]["drift_per_period"] for rho in (0.0, 1.0)]
    assert drift[0] < 0 and abs(drift[1]) < abs(drift[0])
    # with flow the largest stable step is bounded (Newton fails on the fluttering pipe beyond it)
    h = by[("generalized_alpha rho_inf=0.8", 30.0)]["largest_stable_step"]
    assert h is not None and 1e-5 <= h < 0.25
    assert data["meta"]["peer"] in ("measured", "not measured here")
