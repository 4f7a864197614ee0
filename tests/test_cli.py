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
