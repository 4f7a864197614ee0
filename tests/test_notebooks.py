"""Execute every notebook in fast mode (PIPEFLEX_FAST=1) with the venv's interpreter, then
evaluate numbers it computed in its kernel and compare them with their references.

Each notebook runs from a copy in a temporary folder outside the repository, with that
folder as its working directory: it must need nothing but the installed package (no
``..`` paths into the checkout), write only into its ``out/`` folder (git-ignored), and
leave the checkout as it found it (``git status`` and every file's modification time).

The notebooks ask for the Jupyter kernel "pipeflex" (``make notebooks`` registers it). The
tests do not rely on that registration: they write a temporary kernelspec of that name
running this interpreter and put it first on JUPYTER_PATH.
"""
import json
import os
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import nbformat
import pytest
from nbclient import NotebookClient

from pipeflex.seeds.seed000 import references as ref000, validation as val000
from pipeflex.seeds.seed002 import references as ref002
from pipeflex.seeds.seed004 import references as ref004

REPO = Path(__file__).resolve().parent.parent
NOTEBOOKS = sorted((REPO / "notebooks").glob("*.ipynb"))
KERNEL = "pipeflex"
OUTPUT_FOLDER = "out"     # where a notebook may write (relative to its working directory)


@dataclass(frozen=True)
class Check:
    """``expression``, evaluated in the notebook's kernel after its last cell, must lie in
    [low, high]; ``source`` says where the bounds come from."""
    expression: str
    low: float
    high: float
    source: str


def near(expression, reference, tol, source):
    """|value - reference| <= tol (absolute)."""
    return Check(expression, reference - tol, reference + tol, f"{source}: {reference!r} +- {tol:g}")


def within(expression, low, high, source):
    return Check(expression, low, high, f"{source}: in [{low:g}, {high:g}]")


# Printed digits: a value printed with k decimals is matched to half a unit of its last digit,
# except where ours differ by about one unit and the validation's tolerance is used:
# seed 000's Table 2 (6 decimals; ours up to 1.0e-6 off, e.g. 25.0089106 for 25.008910).
TABLE2_TOL = val000.TOL_TABLE2          # relative, 2e-7: about 5 units of the last digit


def table2(expression, n_elements, note=""):
    """The critical mass flow [kg/s] of seed 000's Table 2 at ``n_elements`` elements (the
    reference most notebooks reproduce), to TABLE2_TOL; ``note`` qualifies the count."""
    reference = ref000.TABLE2[n_elements]
    return near(expression, reference, TABLE2_TOL * reference,
                f"seed 000, Table 2, {n_elements} elements{note}: critical mass flow [kg/s]")

CHECKS = {
    "coupled_systems.ipynb": [
        within("sprinkler_final_difference", 0.0, 1e-8,
               "the element-only sprinkler's speed at the same step (acceptance scene a)"),
        within("free_hub_deviation_ratio", 70.0, 140.0,
               "deviation from the prescribed spin-up falls like 1/J: J = 100 -> 1e4 (acceptance scene b)"),
        within("largest_momentum_error", 0.0, 2e-6, "angular momentum = torque impulse (acceptance scene b)"),
        within("hub_eigenvalue_difference", 0.0, 1e-5,
               "a cantilever on a stiff clamped hub body has the clamped cantilever's eigenvalues"),
    ],
    "campbell.ipynb": [
        near("campbell_resonance", 3.88, 5e-3,
             "seed 002, section 7: resonance omega_1 = Omega at gamma = 3.88, 2 decimals (here the crossing of "
             "the Campbell branch with the line omega = Omega)"),
        within("veering_min_mac", 0.9, 1.0, "pipeflex.campbell's contract (docs/plotting.md): branches followed "
               "through the veering with MAC > 0.9 between neighbouring speeds"),
    ],
    "frequency_response.ipynb": [
        near("upper_fold_jump_ratio", 1.0, 0.02, "a stepped-sine transient sweep up drops within a sweep step "
             "(0.2 rad/s fast, 0.1 full) past forced_response's upper fold (tests/test_forced_response.py)"),
        within("middle_multiplier", 1.0, 2.0, "the orbits between the folds are saddles: a Floquet multiplier "
               "above 1"),
        near("peak_on_backbone", 1.0, 1e-3, "the cantilever's resonance peak lies on its backbone (the undamped "
             "free oscillation), both at the continuous equations' frequency"),
        near("meter_peak_ratio", 1.0, 2e-3, "the Coriolis meter driven at 100 N is linear: its peak is the first "
             "mode's frequency (coriolis.first_mode), to the damping's and the sampled peak's error"),
        near("body_upper_fold / upper_fold", 1.0, 0.01, "the beam as 2 FFRF bodies hardens as the element model: "
             "its upper fold within 1 % (docs/forced_response.md: 25.19 against 25.27 rad/s)"),
    ],
    "ffrf_limit_cycle.ipynb": [
        near("hopf_intercept / b.hopf[0]", 1.0, 1e-4,
             "a supercritical Hopf bifurcation: amplitude^2 linear in the flow, zero at critical_mass_flow's Hopf "
             "point (2 FFRF bodies)"),
        near("period_ratio", 1.0, 1e-3, "the period tends to 2 pi / omega_c at the Hopf point (to the "
             "integrator's period error at 128 steps per period, 2e-4)"),
        within("gap_ratio", 0.0, 0.5, "n FFRF bodies behave like 2n elements: the 4-body branch lies closer to "
               "the 16-element model's than the 2-body one"),
    ],
    "seed000_bifurcation.ipynb": [
        near("amplitude_30 / transient_30", 1.0, 1e-3,
             "seed 000, Fig. 3 (30 kg/s, 4 elements, EA = 1e5 N): the orbit continued from the Hopf point and the "
             "long transient of the same model, relative"),
        near("exponent", 0.5, 0.05, "a supercritical Hopf bifurcation: amplitude ~ (mdot - mdot_c)^(1/2)"),
        near("ffrf_amplitude_30", 0.38, 0.005,
             "seed 004, Fig. 4: 2 FFRF bodies saturate at a 0.38 m tip amplitude at 15 m/s (30 kg/s), 2 decimals"),
    ],
    "seed000_coriolis_meter.ipynb": [
        # The seed prints no numbers for Figs. 7-8; its plotted range and statements are the checks.
        within("fig7.omega_scaled[0]", 0.06, 0.18,
               "seed 000, Fig. 7 (b = 3a, water): first frequency omega/omega0 at zero flow, inside the plot's range"),
        near("fig7.omega_scaled[0]", 0.1772, 5e-5,
             "ours, not the seed's: docs/validation.md (seed 000, section 4), 4 decimals"),
        within("abs(kero.sensitivity / water.sensitivity - 1)", 0.0, 0.01,
               "seed 000, Fig. 8: time-lag sensitivity 'very nearly independent of the density' (water, kerosene)"),
    ],
    "seed000_dynamics.ipynb": [
        # fast mode: EI = 1000 N m^2, transients to 3 s (full mode: EI = 100 N m^2, 8 s)
        near("direct", ref000.SPRINKLER[1000.0], val000.TOL_SPRINKLER * ref000.SPRINKLER[1000.0],
             "seed 000, section 3.3, EI = 1000 N m^2: final angular velocity [rad/s] (7 digits printed; "
             "ours 3.5e-7 relative below, within the validation's 5e-6)"),
        near("richardson(w[0], w[1], order=2) / direct", 1.0, 2e-7,
             "the transient, extrapolated over two steps, settles at the direct solver's speed "
             "(as tests/test_sprinkler.py)"),
        within("np.abs(rev.omega[:, 0, 2]).max() / np.abs(fwd.omega[:, 0, 2]).max()", 0.0, 0.01,
               "seed 000, section 3.3, the reverse sprinkler: 'almost no motion occurs' (peak |omega| below "
               "1 % of the blowing pipe's)"),
    ],
    "seed000_tables_1_2.ipynb": [
        table2("crit.mass_flow", 8),
        near("crit_ss.mass_flow", ref000.TABLE1[8], 5e-10,
             "seed 000, Table 1, 8 elements: critical mass flow [kg/s], 9 decimals"),
    ],
    "seed002_rotating_tables.ipynb": [
        within("transverse_gap", 0.0, 5e-5,
               "seed 002, Table 2, simulation column: all 15 transverse frequencies (N = 0..4), 4 decimals"),
        near("ours[1][keys.index((0, 0)), 0]", ref002.TABLE3[(0, 0)][0], 5e-4,
             "seed 002, Table 3, N = 0, R/L = 0, gamma = 1: omega/omega0 of mode 1, 3 decimals"),
        within("digits[1][:, 0].sum()", 30, 30,
               "seed 002, Table 3, gamma = 1: all 30 (N, R/L) entries match every printed digit"),
        near("g_res", 3.88, 5e-3, "seed 002, section 7: resonance omega_1 = Omega at gamma = 3.88, 2 decimals"),
    ],
    "seed002_spin_up.ipynb": [
        # The seed prints no numbers for its spin-ups; Figs. 6-7 show which runs diverge.
        within("crit[1]", 0.0, 10.0,
               "seed 002, Fig. 6: Model 0 with one element unstable at Omega = 10 rad/s (critical rate below)"),
        within("crit[2]", 0.0, 40.0,
               "seed 002, Fig. 7: Model 0 with two elements unstable at Omega = 40 rad/s (critical rate below)"),
        within("RUNS[('ref21', 40.0, '0', 2)]['t_fail']", 0.0, 16.0,
               "seed 002, Fig. 7: the transient of Model 0, two elements, Omega = 40 rad/s diverges (t [s] "
               "within the fast run's 16 s)"),
    ],
    "seed004_cantilever.ipynb": [
        # n FFRF bodies with boundary modes = 2n seed-000 elements
        table2("dict(zip(fig7['bodies'], fig7['bodies_flow']))[4]", 8, " (= 4 bodies)"),
        table2("dict(zip(fig7['bodies'], fig7['bodies_flow']))[1]", 2, " (= 1 body)"),
    ],
    "seed004_curved_pipe.ipynb": [
        # fast mode: 1.5 s instead of 4 s
        near("final[95.85e9]", ref004.TABLE1_FFRF[95.85e9], 5e-3,
             "seed 004, Table 1, FFRF column, E = 95.85 GPa: final angular velocity [rad/s], 3 decimals"),
    ],
    "seed004_model_choice.ipynb": [
        table2("lookup['FFRF 4 b.'].value", 8, " (= 4 FFRF bodies)"),
        table2("lookup['element 8 el.'].value", 8),
    ],
    "seed004_printer.ipynb": [
        # Not a validation: the seed's Fig. 12 compares with nothing; its specification does.
        within("max(np.ptp(p[:, 2]) for p in paths.values())", 0.0, 1e-8,
               "seed 004, section 8.3: a roller keeps the nozzle's height [m]"),
        near("sum(np.linalg.norm(P[b] - P[a]) for a, b in ('OE', 'EB', 'BF', 'FD'))", 0.96, 5e-3,
             "seed 004, section 8.3: hose OE = EB = 0.20 m, BF = FD = 0.28 m [m], 2 decimals"),
        near("shift[6.0] * 1e3", 8.8, 0.05,
             "ours, not the seed's: docs/validation.md (seed 004, section 8.3), nozzle shift at 6 m/s [mm]"),
    ],
    "flutter_3d_branches.ipynb": [
        within("bp_flow[4]", 25.0565, 25.0575, "ours, not the seed's: docs/orbits.md, the planar cycle's branch "
               "point in 3D, 4 elements (25.05688 kg/s at 64 steps per period, 25.05704 at 128)"),
        within("planar_multiplier_30", 1.1, 1.3, "docs/periodic.md: in 3D the planar cycle at 30 kg/s has an "
               "out-of-plane multiplier of up to 1.2"),
        near("whirl_ratio", 1.0, 0.05, "the 3D transient at 30 kg/s leaves the planar cycle for a circular whirl: "
             "equal tip amplitudes in y and z"),
        near("whirl_stable", 1.0, 0.0, "the whirl, shot from the transient's end, is stable"),
        within("chain_bp_above_hopf", 0.0, 5e-3, "docs/orbits.md: the 2 FFRF bodies' branch has a branch point "
               "2.1e-3 kg/s above their Hopf point"),
    ],
    "pulsating_flow.ipynb": [
        near("apex_unstable", 1.0, 0.0, "the principal tongue of the undamped pinned pipe opens from mu = 0: "
             "unstable at 2 omega_1 at mu = 0.01 (Paidoussis & Issid 1974)"),
        near("growth_vs_floquet", 1.0, 0.03, "a transient inside the tongue grows at the largest Floquet "
             "multiplier's rate per period (tests/test_parametric.py: 3 %)"),
        within("decay_outside", 0.0, 0.9, "a transient 3 % outside the tongue's edge decays"),
    ],
    "your_own_pipe.ipynb": [
        near("steps_recorded", 1.0, 0.0, "pipeflex.sensor: a sample at the start and at every accepted step"),
        near("period_ratio", 1.0, 0.02, "a damped hose settles to its pump's pulsation: the crossing sensor's "
             "period over the last 3 s in pump periods (measured 1.0013 over 12 s)"),
        within("vtk_files", 2, 1000, "result.to_vtk wrote the .vtu series"),
    ],
    "stability_map.ipynb": [
        # fast mode: 16 elements, beta in steps of 0.02 (full: 32 elements, steps of 0.0025)
        near("u_cr_02", 5.6, 0.06, "Gregory & Paidoussis (1966): u_cr = 5.6 at beta = 0.2 without gravity "
             "(read from their figure, ~1 %)"),
        near("u_cr_05", 9.32242, 1e-3, "ours, not a paper's: the continuous beam's characteristic determinant, "
             "beta = 0.5 (pipeflex.references.continuous_pipe: u_cr = 9.3224184; 16 elements are 7e-5 "
             "relative above)"),
        within("first_jump", 0.28, 0.31, "Gregory & Paidoussis (1966): the first S-shaped jump of the critical "
               "flow speed near beta = 0.3 (0.29-0.30 at 16 elements, 0.2925 at 32)"),
    ],
}


@pytest.fixture(scope="module")
def kernel_env(tmp_path_factory):
    # Debian's kernelspec runs /usr/bin/python3, which cannot import the venv's package;
    # the user's "pipeflex" kernel may be missing or stale: this one comes first.
    root = tmp_path_factory.mktemp("jupyter")
    spec = root / "kernels" / KERNEL
    spec.mkdir(parents=True)
    (spec / "kernel.json").write_text(json.dumps({
        "argv": [sys.executable, "-Xfrozen_modules=off", "-m", "ipykernel_launcher", "-f", "{connection_file}"],
        "display_name": "Python (pipeflex), tests", "language": "python"}))
    old = {k: os.environ.get(k) for k in ("JUPYTER_PATH", "MPLBACKEND", "PIPEFLEX_FAST")}
    os.environ.update(JUPYTER_PATH=str(root), MPLBACKEND="Agg", PIPEFLEX_FAST="1")
    yield
    for k, v in old.items():
        if v is None:
            os.environ.pop(k, None)
        else:
            os.environ[k] = v


def test_every_notebook_is_checked():
    assert sorted(CHECKS) == [p.name for p in NOTEBOOKS]


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.name for p in NOTEBOOKS])
def test_notebook_committed_executed(path):
    """Committed with its outputs, run top to bottom in one kernel, asking for the "pipeflex" kernel."""
    nb = nbformat.read(path, as_version=4)
    assert nb.metadata.kernelspec.name == KERNEL
    counts = [c.execution_count for c in nb.cells if c.cell_type == "code"]
    assert counts == list(range(1, len(counts) + 1))


def _checkout_state():
    """The checkout's ``git status --porcelain`` (untracked files listed one by one) and the
    modification time [ns] of every tracked file and every untracked file outside the
    ignored folders, or None outside a git checkout. The times catch a tracked file that is
    rewritten, even with the bytes it had."""
    def git(*args):
        return subprocess.run(["git", "-C", str(REPO), *args], capture_output=True, text=True,
                              check=True).stdout
    try:
        status = git("status", "--porcelain", "--untracked-files=all")
        files = git("ls-files", "-z", "--cached", "--others", "--exclude-standard").split("\0")
    except (OSError, subprocess.CalledProcessError):
        return None
    times = {}
    for name in filter(None, files):
        try:
            times[name] = (REPO / name).stat().st_mtime_ns
        except FileNotFoundError:      # a deleted tracked file: git status shows it
            times[name] = None
    return status, times


def _changes(before, after):
    """What differs between two _checkout_state() snapshots, as readable lines."""
    (status0, times0), (status1, times1) = before, after
    lines = [f"git status: {line}" for line in sorted(set(status0.splitlines()) ^ set(status1.splitlines()))]
    lines += [f"written: {name}" for name in sorted(times0.keys() | times1.keys())
              if times0.get(name, "absent") != times1.get(name, "absent")]
    return lines


def test_the_checkout_watch_sees_a_change():
    """The watch must see tracked files, or the checkout test in test_notebook_runs passes
    vacuously; a rewrite with the same bytes (same status, new time) must count."""
    state = _checkout_state()
    if state is None:
        pytest.skip("not a git checkout")
    status, times = state
    assert "tests/test_notebooks.py" in times and "notebooks/stability_map.ipynb" in times
    name = "docs/stability_map.md"
    rewritten = dict(times, **{name: (times[name] or 0) + 1})
    assert _changes(state, (status, rewritten)) == [f"written: {name}"]
    assert _changes(state, (status + "?? new.png\n", dict(times, **{"new.png": 1}))) == [
        "git status: ?? new.png", "written: new.png"]


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.name for p in NOTEBOOKS])
def test_notebook_runs(path, kernel_env, tmp_path):
    """Run from a copy outside the checkout: no path into the repository, output only under
    out/, the checkout untouched; then its numbers against their references."""
    work = tmp_path / "run"     # the working directory; its parent holds nothing else
    work.mkdir()
    shutil.copy(path, work / path.name)
    nb = nbformat.read(work / path.name, as_version=4)
    checks = CHECKS[path.name]
    # one extra cell, run in the same kernel after the notebook's own cells
    nb.cells.append(nbformat.v4.new_code_cell("\n".join(f"print(repr(float({c.expression})))" for c in checks)))
    before = _checkout_state()
    NotebookClient(nb, timeout=600, kernel_name=KERNEL, resources={"metadata": {"path": str(work)}}).execute()
    after = _checkout_state()
    errors = [o for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", []) if o.output_type == "error"]
    assert not errors, "\n".join(f"{e.ename}: {e.evalue}" for e in errors)
    if before is not None:
        changed = _changes(before, after)
        assert not changed, "the notebook changed the checkout:\n" + "\n".join(changed)
    # the folder above the working directory too: a notebook's "../x" must not escape the check
    written = sorted(str(f.relative_to(tmp_path)) for f in tmp_path.rglob("*")
                     if f.is_file() and f != work / path.name and not f.is_relative_to(work / OUTPUT_FOLDER))
    assert not written, f"written outside {OUTPUT_FOLDER}/: {written}"
    text = "".join(o.text for o in nb.cells[-1].outputs if o.output_type == "stream" and o.name == "stdout")
    values = [float(v) for v in text.split()]
    assert len(values) == len(checks)
    print("\n".join(f"{c.expression} = {v!r}  ({c.source})" for c, v in zip(checks, values)))
    bad = [f"{c.expression} = {v!r}, expected {c.source}" for c, v in zip(checks, values) if not c.low <= v <= c.high]
    assert not bad, "\n".join(bad)
