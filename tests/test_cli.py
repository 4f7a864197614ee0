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
    assert "6 of 6 published numbers" in capsys.readouterr().out
    assert {p.name for p in out.iterdir()} >= {"critical_flow_convergence.png", "sprinkler_fig5.png",
                                               "coriolis_fig7.png", "coriolis_fig8.png"}


def test_unknown_group_is_an_error():
    import pytest

    with pytest.raises(ValueError, match="unknown validation group 'table9'"):
        main(["validate", "--only", "table9", "--no-figures"])
