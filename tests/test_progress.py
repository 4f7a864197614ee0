"""The progress policy of the long loops (pipeflex._progress) and the package's logger.

``progress=None``: a bar in a notebook or on a terminal once the run has lasted
BAR_DELAY s; elsewhere log lines every LOG_INTERVAL s, never a carriage return;
``progress=False`` imports no tqdm; without tqdm the lines replace the bar.
"""
import json
import logging
import re
import os
import subprocess
import sys
import textwrap
import warnings
from pathlib import Path

import pytest

import pipeflex as pf
from pipeflex import _progress


@pytest.fixture(scope="module")
def model():
    return pf.scenes.cantilever_pipe(n_elements=4, polar_inertia=1e-4)


def _square(x):
    return {"y": x * x}


def run(code: str):
    """The JSON the snippet prints last, from a new interpreter (stderr a pipe, not a TTY)."""
    env = dict(os.environ, PYTHONPATH=str(Path(pf.__file__).parents[1]))
    out = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], env=env, capture_output=True, text=True,
                         stdin=subprocess.DEVNULL)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout.splitlines()[-1]), out.stderr


def test_the_package_logger_is_pipeflex_with_a_null_handler():
    logger = logging.getLogger("pipeflex")
    assert _progress.logger is logger
    assert any(isinstance(h, logging.NullHandler) for h in logger.handlers)


def test_simulate_off_a_terminal_logs_progress_lines_without_carriage_returns(model, monkeypatch, caplog, capfd):
    monkeypatch.setattr(_progress, "LOG_INTERVAL", 0.0)  # a line at every report
    with caplog.at_level(logging.INFO, logger="pipeflex"):
        r = pf.simulate(model, 0.02, integrator="generalized_alpha", step=1e-3, n_outputs=5)
    messages = [rec.getMessage() for rec in caplog.records if rec.name == "pipeflex"]
    lines = [m for m in messages if m.startswith("simulate (generalized_alpha): t = ")]
    # the core reports at most every 0.1 s of wall time (this run is shorter), simulate the end
    assert 1 <= len(lines) <= 4
    # rounded simulated time and a percentage, not the sum of the steps
    assert all(re.match(r"simulate \(generalized_alpha\): t = 0\.0\d*/0\.02 s \(\d+%\)", m) for m in lines)
    assert lines[-1].startswith("simulate (generalized_alpha): t = 0.02/0.02 s (100%)")
    # the milestones: start (with the step) and end (with the step count)
    assert any(m.startswith("simulate: generalized_alpha from t = 0 to 0.02 s, 5 outputs") and "step 0.001 s" in m
               for m in messages)
    assert any(m.startswith(f"simulate: generalized_alpha done in") and f"{r.stats['steps']} steps" in m
               for m in messages)
    err = capfd.readouterr().err
    assert "\r" not in err and "simulate" not in err  # logging is the application's choice: nothing on stderr


def test_the_log_lines_come_at_the_log_interval_only(model, monkeypatch, caplog):
    monkeypatch.setattr(_progress, "LOG_INTERVAL", 1e6)
    with caplog.at_level(logging.INFO, logger="pipeflex"):
        pf.simulate(model, 0.02, integrator="generalized_alpha", step=1e-3, n_outputs=5)
    assert not [r for r in caplog.records if ": t = " in r.getMessage()]


def test_progress_false_imports_no_tqdm_in_simulate_or_sweep():
    loaded, _ = run("""
        import json, sys
        import pipeflex as pf
        m = pf.scenes.cantilever_pipe(n_elements=4, polar_inertia=1e-4)
        pf.simulate(m, 0.01, integrator="generalized_alpha", step=1e-3, n_outputs=3, progress=False)
        def f(x):
            return {"y": x}
        pf.sweep(f, executor="serial", progress=False, x=[1.0, 2.0])
        print(json.dumps(sorted(k for k in sys.modules if k.split(".")[0] == "tqdm")))
        """)
    assert loaded == []


def test_a_short_run_off_a_terminal_imports_no_tqdm_and_writes_nothing():
    loaded, err = run("""
        import json, sys
        import pipeflex as pf
        m = pf.scenes.cantilever_pipe(n_elements=4, polar_inertia=1e-4)
        pf.simulate(m, 6.0, integrator="generalized_alpha", step=5e-3, n_outputs=7)
        print(json.dumps(sorted(k for k in sys.modules if k.split(".")[0] == "tqdm")))
        """)
    assert loaded == [] and err == ""


def test_without_tqdm_a_forced_bar_becomes_lines_on_stderr(model, monkeypatch, capfd):
    for name in ("tqdm", "tqdm.std", "tqdm.notebook", "tqdm.auto"):
        monkeypatch.setitem(sys.modules, name, None)  # import raises ImportError
    monkeypatch.setattr(_progress, "in_notebook", lambda: True)
    monkeypatch.setattr(_progress, "LOG_INTERVAL", 0.0)
    pf.simulate(model, 0.02, integrator="generalized_alpha", step=1e-3, n_outputs=3, progress=True)
    err = capfd.readouterr().err
    assert "simulate (generalized_alpha): t = 0.02/0.02 s (100%)" in err  # the end (the core reports at most every 0.1 s)
    assert "\r" not in err


def test_in_a_notebook_without_ipywidgets_a_text_bar_and_no_iprogress_warning(model, monkeypatch, capfd):
    pytest.importorskip("tqdm")
    monkeypatch.setattr(_progress, "in_notebook", lambda: True)  # as in a Jupyter kernel
    monkeypatch.setattr(_progress, "_has_widgets", lambda: False)
    monkeypatch.setattr(_progress, "BAR_DELAY", 0.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # tqdm.auto's "IProgress not found" would be a TqdmWarning
        pf.simulate(model, 0.02, integrator="generalized_alpha", step=1e-3, n_outputs=5)
        ds = pf.sweep(_square, executor="serial", x=[1.0, 2.0, 3.0])
    assert list(ds.y.values) == [1.0, 4.0, 9.0]
    err = capfd.readouterr().err
    assert "simulate (generalized_alpha)" in err
    assert "0.02" in err and "0.020000000000000004" not in err
    assert "sweep" in err and "3/3" in err


def test_a_forced_bar_is_tqdm_std_and_the_policy_waits_for_the_delay(monkeypatch):
    pytest.importorskip("tqdm")
    import tqdm.std

    monkeypatch.setattr(_progress, "in_notebook", lambda: True)
    monkeypatch.setattr(_progress, "_has_widgets", lambda: False)
    with _progress.Progress(True, 2.0, desc="d", unit="s") as p:
        assert isinstance(p._bar, tqdm.std.tqdm)
        p.update(0.30000000000000004)
        assert p._bar.n == 0.3
    with _progress.Progress(None, 2.0, desc="d", unit="s") as p:
        p.update(1.0)
        assert p._bar is None  # a short loop: no bar before BAR_DELAY
    with _progress.Progress(False, 2.0, desc="d", unit="s") as p:
        p.update(1.0)
        assert p.mode == "off" and p._bar is None


def test_sweep_logs_its_points(monkeypatch, caplog):
    with caplog.at_level(logging.DEBUG, logger="pipeflex"):
        pf.sweep(_square, executor="serial", progress=False, x=[1.0, 2.0])
    messages = [r.getMessage() for r in caplog.records]
    assert any("sweep" in m and "2 points to compute" in m for m in messages)
    assert sum("point {'x': " in m and m.endswith("done") for m in messages) == 2
    assert any(m.endswith("2 points, 0 failed, 0 not computed") for m in messages)


def test_critical_mass_flow_logs_its_bracket_and_result(caplog):
    m = pf.scenes.cantilever_pipe(n_elements=4)
    with caplog.at_level(logging.DEBUG, logger="pipeflex"):
        crit = pf.critical_mass_flow(m)
    messages = [r.getMessage() for r in caplog.records]
    assert any(m.startswith("critical_mass_flow: flutter bracketed in [") for m in messages)
    assert any(m.startswith("critical_mass_flow: Brent at") for m in messages)
    assert any(m.startswith(f"critical_mass_flow: flutter at {crit.mass_flow:.10g} kg/s") for m in messages)
