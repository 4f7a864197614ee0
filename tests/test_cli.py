"""`pipeflex validate`: rows, JSON, exit code and figures (what `make demo` runs)."""
import json

from pipeflex.cli import main


def test_validate_writes_json_and_figures(tmp_path, capsys):
    out = tmp_path / "out"
    code = main(["validate", "--only", "table1", "--json", str(tmp_path / "v.json"), "--out", str(out)])
    assert code == 0
    rows = json.loads((tmp_path / "v.json").read_text())
    assert len(rows) == 6 and all(r["passed"] for r in rows)
    assert {"source", "published", "ours", "deviation", "tolerance"} <= set(rows[0])
    assert "6 of 6 checked published numbers" in capsys.readouterr().out
    # --only computes only the named group: its figure, none of the others
    assert {p.name for p in out.iterdir()} == {"critical_flow_convergence.png"}


def test_shown_rows_do_not_fail_the_run(tmp_path):
    """Seed 002's gamma = 20, 50 entries and one misprint are shown, not checked."""
    code = main(["validate", "--only", "seed002_tables3to5", "--json", str(tmp_path / "v.json"), "--no-figures"])
    rows = json.loads((tmp_path / "v.json").read_text())
    assert code == 0 and len(rows) == 720
    shown = [r for r in rows if not r["checked"]]
    assert len(shown) == 181 and all("g=20" in r["source"] or "g=50" in r["source"] or "N=3, R/L=3, g=10" in r["source"]
                                     for r in shown)


def test_unknown_group_is_a_one_line_error_with_status_2(capsys):
    import pytest

    with pytest.raises(SystemExit) as exit_info:
        main(["validate", "--only", "table9", "--no-figures"])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("pipeflex: error: unknown validation group table9")


def test_run_names_unknown_groups():
    import pytest

    from pipeflex.seeds import validate

    with pytest.raises(ValueError, match="unknown validation group.*'table9'.*table1"):
        validate.run(["table9"])


def test_list_and_version(capsys):
    import pytest

    import pipeflex
    from pipeflex.seeds.validate import GROUPS

    assert main(["validate", "--list"]) == 0
    listed = [line.split()[0] for line in capsys.readouterr().out.splitlines()]
    assert listed == list(GROUPS)
    with pytest.raises(SystemExit) as exit_info:
        main(["--version"])
    assert exit_info.value.code == 0
    assert capsys.readouterr().out.strip() == f"pipeflex {pipeflex.__version__}"


def test_help_is_plain_text(capsys):
    import pytest

    for argv in (["--help"], ["validate", "--help"]):
        with pytest.raises(SystemExit):
            main(argv)
        assert "``" not in capsys.readouterr().out


def test_rows_from_numpy_values_serialise():
    """A group that computes with numpy still writes plain JSON (numpy bools are not JSON)."""
    import numpy as np

    from pipeflex.seeds.checks import Row

    row = Row("s", "q [-]", np.float64(2.0), np.float64(2.0 + 1e-9), np.float64(1e-6), checked=np.bool_(True))
    d = json.loads(json.dumps(row.as_dict()))
    assert d["passed"] is True and d["checked"] is True and d["ours"] == 2.0 + 1e-9


def test_run_static_and_simulate_write_results_and_figures(tmp_path, capsys):
    from pathlib import Path

    import numpy as np

    import pipeflex as pf

    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    nodes = b.add_line(n0, (1.0, 0.0, 0.0), 4, pf.PipeSection(EI=10.0, pipe_mass=1.0, rotary_inertia=(1e-3, 0, 0)))
    b.clamp(n0)
    b.add_load(nodes[-1], force=(0.0, 0.0, -1.0))
    model_file = pf.save_model(b.build(), tmp_path / "beam.yaml")
    out = tmp_path / "out"
    assert main(["run", str(model_file), "--analysis", "static", "--out", str(out), "--vtk"]) == 0
    assert "static equilibrium" in capsys.readouterr().out
    saved = pf.StaticResult.load(out / "beam_static.npz")
    direct = pf.static_equilibrium(pf.load_model(model_file))
    assert np.array_equal(saved.state.q, direct.state.q) and saved.state.q[6 * 4 + 2] < 0
    assert (out / "beam_static.png").stat().st_size > 0 and (out / "vtk" / "beam.pvd").is_file()
    assert main(["run", str(model_file), "--analysis", "simulate", "--t-end", "0.01", "--n-outputs", "5",
                 "--out", str(out)]) == 0
    written = {Path(line.split()[-1]).name for line in capsys.readouterr().out.splitlines() if line.startswith("wrote")}
    assert written in ({"beam_simulate.nc", "beam_simulate.png"}, {"beam_simulate.npz", "beam_simulate.png"})


def test_run_refuses_bad_input_with_status_2(tmp_path, capsys):
    import pytest

    bad = tmp_path / "bad.yaml"
    bad.write_text("geometry:\n  - nod: [0, 0, 0]\n")
    for argv, message in ((["run", str(bad)], "bad.yaml, line 2, geometry[0].nod: unknown key 'nod'"),
                          (["run", str(bad), "--analysis", "simulate"], "needs --t-end"),
                          (["run", str(tmp_path / "none.yaml")], "no such model file"),
                          (["run", str(bad), "--t-end", "1"], "--t-end is for --analysis simulate")):
        with pytest.raises(SystemExit) as exit_info:
            main(argv + ["--out", str(tmp_path / "out")])
        assert exit_info.value.code == 2
        assert message in capsys.readouterr().err
    assert not (tmp_path / "out").exists()  # refused before anything was written


def test_run_reports_a_failed_analysis_with_status_1(tmp_path, capsys):
    import pipeflex as pf

    b = pf.ModelBuilder()
    n0 = b.add_node((0.0, 0.0, 0.0))
    b.add_line(n0, (1.0, 0.0, 0.0), 2, pf.PipeSection(EI=1.0, pipe_mass=1.0))  # no fluid: no critical flow
    b.clamp(n0)
    path = pf.save_model(b.build(), tmp_path / "dry.json")
    assert main(["run", str(path), "--analysis", "critical", "--out", str(tmp_path / "out")]) == 1
    assert "pipeflex run: critical of" in capsys.readouterr().err


def test_python_dash_m_runs_the_command(tmp_path):
    """`python -m pipeflex` is the `pipeflex` command (a venv whose bin/ is not on PATH)."""
    import subprocess
    import sys

    import pipeflex

    done = subprocess.run([sys.executable, "-m", "pipeflex", "--version"], capture_output=True, text=True,
                          cwd=tmp_path, timeout=120)
    assert done.returncode == 0, done.stderr
    assert pipeflex.__version__ in done.stdout
    bad = subprocess.run([sys.executable, "-m", "pipeflex", "validate", "--only", "no_such_group"],
                         capture_output=True, text=True, cwd=tmp_path, timeout=120)
    assert bad.returncode == 2 and "no_such_group" in bad.stderr
