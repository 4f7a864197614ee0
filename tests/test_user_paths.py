"""pf.sweep of a user's own function, the way docs/sweeps.md shows it: a function at module
level of a script run as ``python flows.py`` (its module is ``__main__``), or of a notebook
cell, next to ``import pipeflex as pf``; the points run on a 2-worker Dask LocalCluster and
on the default process pool.

Each run happens in a fresh interpreter with its working directory outside the repository
(where a user's script lives), importing this checkout's pipeflex. Dask (cloudpickle)
sends a function of ``__main__`` by value, with the globals it uses: the module ``pf``
among them, which must pickle by reference.
"""
import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import pipeflex as pf

PYTHONPATH = str(Path(pf.__file__).parents[1])
# critical_mass_flow's default tol is 1e-10 (relative): two processes (BLAS threads, warm
# starts) may end its root search anywhere within it
RTOL = 1e-9

# What a user writes: a cheap but real analysis at module level, the sweep under the guard.
FUNCTION = '''
import json
import sys

import pipeflex as pf


def critical_flow(EI, mass_ratio):
    """Critical mass flow [kg/s] of a 3-element cantilever, 10 kg/m of pipe and fluid."""
    model = pf.scenes.cantilever_pipe(n_elements=3, EI=EI, pipe_mass=10.0 * (1 - mass_ratio),
                                      fluid_mass=10.0 * mass_ratio)
    return pf.critical_mass_flow(model)
'''

GRID = dict(EI=[5.0, 20.0], mass_ratio=[0.2, 0.5])

SWEEP = '''
def run(how):
    """The sweep's mass flows, and the function's own, called here point by point."""
    grid = {grid!r}
    if how == "dask":
        from distributed import Client, LocalCluster

        with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, \\
                Client(cluster) as client:
            ds = pf.sweep(critical_flow, client=client, **grid)
    else:
        ds = pf.sweep(critical_flow, workers=2, **grid)
    serial = [[critical_flow(EI, b).mass_flow for b in grid["mass_ratio"]] for EI in grid["EI"]]
    return {{"fn": ds.attrs["fn"], "n_failed": ds.attrs["n_failed"], "errors": ds.error.values.ravel().tolist(),
            "dims": list(ds.mass_flow.dims), "swept": ds.mass_flow.values.tolist(), "serial": serial}}
'''.format(grid=GRID)

SCRIPT = FUNCTION + SWEEP + '''

if __name__ == "__main__":
    print(json.dumps(run(sys.argv[1])))
'''


def _env():
    return dict(os.environ, PYTHONPATH=PYTHONPATH, MPLBACKEND="Agg")


def _check(out: dict, fn: str):
    assert out["fn"] == fn
    assert out["errors"] == [""] * 4 and out["n_failed"] == 0
    assert out["dims"] == ["EI", "mass_ratio"]
    swept, serial = np.array(out["swept"]), np.array(out["serial"])
    assert swept.shape == (2, 2) and np.all(serial > 0)
    np.testing.assert_allclose(swept, serial, rtol=RTOL, atol=0)
    assert serial[1, 0] > serial[0, 0]  # a stiffer pipe takes more flow


def _run_script(tmp_path: Path, how: str) -> dict:
    script = tmp_path / "flows.py"
    script.write_text(SCRIPT)
    out = subprocess.run([sys.executable, script.name, how], cwd=tmp_path, env=_env(), capture_output=True,
                         text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-4000:]
    return json.loads(out.stdout.splitlines()[-1])


def test_script_function_swept_on_a_dask_local_cluster(tmp_path):
    pytest.importorskip("distributed")
    _check(_run_script(tmp_path, "dask"), "__main__.critical_flow")


def test_script_function_swept_on_the_default_process_pool(tmp_path):
    _check(_run_script(tmp_path, "pool"), "__main__.critical_flow")


@pytest.fixture
def kernel(tmp_path, monkeypatch):
    """A kernelspec running this interpreter (the Debian one runs /usr/bin/python3, which
    cannot import the venv's packages), first on JUPYTER_PATH; its name."""
    name = "pipeflex-user-paths"
    spec = tmp_path / "jupyter" / "kernels" / name
    spec.mkdir(parents=True)
    (spec / "kernel.json").write_text(json.dumps({
        "argv": [sys.executable, "-Xfrozen_modules=off", "-m", "ipykernel_launcher", "-f", "{connection_file}"],
        "display_name": "Python (pipeflex), tests", "language": "python"}))
    for key, value in _env().items():
        monkeypatch.setenv(key, value)
    monkeypatch.setenv("JUPYTER_PATH", str(tmp_path / "jupyter"))
    return name


@pytest.mark.parametrize("how", ["dask", "pool"])
def test_notebook_cell_function_swept(how, kernel, tmp_path):
    if how == "dask":
        pytest.importorskip("distributed")
    nbformat = pytest.importorskip("nbformat")
    from nbclient import NotebookClient

    work = tmp_path / "notebook"
    work.mkdir()
    nb = nbformat.v4.new_notebook()
    nb.cells = [nbformat.v4.new_code_cell(FUNCTION), nbformat.v4.new_code_cell(SWEEP),
                nbformat.v4.new_code_cell(f"print(json.dumps(run({how!r})))")]
    NotebookClient(nb, timeout=300, kernel_name=kernel, resources={"metadata": {"path": str(work)}}).execute()
    text = "".join(o.text for o in nb.cells[-1].outputs if o.output_type == "stream" and o.name == "stdout")
    _check(json.loads(text.splitlines()[-1]), "__main__.critical_flow")


def test_every_pipeflex_package_pickles_by_reference():
    """The packages with lazy names (a module subclass) pickle as a reference to the
    imported module, with pickle and with cloudpickle (Dask)."""
    import importlib
    import pickle

    cloudpickle = pytest.importorskip("cloudpickle")
    names = ["pipeflex", "pipeflex.analysis", "pipeflex.scenes", "pipeflex.seeds.seed000",
             "pipeflex.seeds.seed002", "pipeflex.seeds.seed004"]
    for name in names:
        module = importlib.import_module(name)
        assert type(module) is not type(os), f"{name} is expected to be a lazy package"
        for dumps in (pickle.dumps, cloudpickle.dumps):
            data = dumps(module)
            assert len(data) < 200, f"{name} pickled by value ({len(data)} bytes)"
            assert pickle.loads(data) is module


def test_a_by_value_function_using_pf_round_trips_through_cloudpickle():
    """What Dask does with a notebook's function: by value, its global ``pf`` by reference."""
    cloudpickle = pytest.importorskip("cloudpickle")
    namespace = {"__name__": "__main__"}
    exec(textwrap.dedent("""
        import pipeflex as pf

        def span(n):
            return pf.scenes.cantilever_pipe(n_elements=n).total_length
        """), namespace)
    span = cloudpickle.loads(cloudpickle.dumps(namespace["span"]))
    assert span.__globals__["pf"] is pf
    assert span(2) == pytest.approx(1.0, rel=1e-15)


def test_a_dask_pickling_failure_says_what_cannot_be_pickled():
    """A by-value function whose global cannot be pickled: the TypeError says that Dask
    sends it with its globals (not "define it at module level", which it is)."""
    distributed = pytest.importorskip("distributed")
    import threading

    namespace = {"__name__": "__main__", "pf": pf, "lock": threading.Lock()}
    exec("def locked(a):\n    with lock:\n        return a\n", namespace)
    with distributed.Client(processes=False, n_workers=1, threads_per_worker=1, dashboard_address=None) as client:
        with pytest.raises(TypeError, match=r"fn \(__main__.locked\) cannot be pickled for the Dask workers "
                                            r"\(TypeError: cannot pickle '_thread.lock' object\); Dask sends a "
                                            r"function of a script or notebook by value, with the globals"):
            pf.sweep(namespace["locked"], a=[1.0], client=client, progress=False)
