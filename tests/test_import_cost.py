"""`import pipeflex` and a transient's path load only what they use (docs/performance.md).

Each check runs in a fresh interpreter: the test session has imported everything already.
"""
import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import pipeflex as pf
from pipeflex import _blas

HEAVY = ["scipy", "scipy.sparse", "scipy.linalg", "matplotlib", "threadpoolctl", "pipeflex.multibody",
         "pipeflex.coupled", "pipeflex.sweeps", "pipeflex.plot", "pipeflex.analysis.eigen",
         "pipeflex.analysis.campbell"]


def run(code: str):
    """The JSON the snippet prints, from a new interpreter importing this checkout's pipeflex."""
    env = dict(os.environ, PYTHONPATH=str(Path(pf.__file__).parents[1]))
    out = subprocess.run([sys.executable, "-c", textwrap.dedent(code)], env=env, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    return json.loads(out.stdout.splitlines()[-1])


def test_import_pipeflex_loads_no_scipy_matplotlib_threadpoolctl_or_analyses():
    loaded = run(f"""
        import json, sys
        import pipeflex
        print(json.dumps([m for m in {HEAVY!r} if m in sys.modules]))
        """)
    assert loaded == []


def test_a_transient_of_an_element_model_needs_no_multibody_threadpoolctl_or_eigen_modules():
    loaded = run(f"""
        import json, sys
        import pipeflex as pf
        import pipeflex._blas
        sec = pf.PipeSection(EI=10.0, pipe_mass=8.0, fluid_mass=2.0, EA=1e5, rotary_inertia=(1e-3, 0.0, 0.0))
        b = pf.ModelBuilder()
        nodes = b.add_line(b.add_node((0.0, 0.0, 0.0)), (1.0, 0.0, 0.0), 4, sec)
        b.clamp(nodes[0])
        model = b.build(mass_flow=1.0)
        pf.simulate(model, 0.01, n_outputs=2, progress=False, integrator="generalized_alpha", step=1e-3)
        openblas = bool(pipeflex._blas._openblas_functions())
        print(json.dumps([m for m in {HEAVY!r} if m in sys.modules] + ([] if openblas else ["no OpenBLAS"])))
        """)
    assert loaded == [] or loaded == ["threadpoolctl", "no OpenBLAS"]


def test_an_element_scene_loads_no_scipy_bodies_or_seed_studies():
    """``pf.scenes`` and the seed packages load their modules on first use: building the
    seed-000 cantilever imports neither the floating-frame bodies nor scipy nor the seed's
    studies (the Coriolis meter's study imports the eigen-analysis)."""
    loaded = run(f"""
        import json, sys
        import pipeflex as pf
        pf.scenes.cantilever_pipe(n_elements=4)
        print(json.dumps([m for m in {HEAVY!r} + ["pipeflex.seeds.seed000.coriolis", "pipeflex.seeds.seed004"]
                          if m in sys.modules]))
        """)
    assert loaded == []
    scenes = run("""
        import json
        import pipeflex as pf
        print(json.dumps([n for n in pf.scenes.__all__ if not hasattr(pf.scenes, n)]
                         + [n for n in pf.seeds.seed004.__all__ if not hasattr(pf.seeds.seed004, n)]))
        """)
    assert scenes == []


def test_every_public_name_resolves_and_keeps_its_meaning_when_a_namesake_submodule_loads_first():
    kinds = run("""
        import json
        import pipeflex.analysis.linearize, pipeflex.analysis.campbell  # the submodules first
        import pipeflex as pf
        from pipeflex.analysis import eigen
        missing = [n for n in pf.__all__ if not hasattr(pf, n)] + [n for n in pf.analysis.__all__
                                                                     if not hasattr(pf.analysis, n)]
        print(json.dumps([missing, type(pf.analysis.linearize).__name__, type(pf.analysis.campbell).__name__,
                          type(eigen).__name__, pf.linearize is pf.analysis.linearize]))
        """)
    assert kinds == [[], "function", "function", "module", True]
    assert set(pf.__all__) <= set(dir(pf)) and set(pf.analysis.__all__) <= set(dir(pf.analysis))
    with pytest.raises(AttributeError, match="no attribute 'no_such_name'"):
        pf.no_such_name


def test_pin_sets_each_openblas_to_one_thread_once_and_never_back():
    functions = _blas._openblas_functions()
    if not functions:
        pytest.skip("no OpenBLAS found by its own API here (threadpoolctl's path)")
    if _blas.user_setting():
        pytest.skip(f"the BLAS thread count is the user's ({_blas.user_setting()})")
    _blas.pin()
    assert [get() for _, get, _ in functions] == [1] * len(functions)
    _, get, put = functions[0]
    put(2)  # a count the user sets after the pin
    try:
        _blas.pin()
        assert get() == 2
        _blas._looked = -1  # as after an import: the libraries are looked for again
        _blas.pin()
        assert get() == 2  # each library is set once
    finally:
        put(1)


def test_a_critical_flow_does_not_import_scipy_optimize():
    """Brent's method is pipeflex's own (analysis/_roots.py): scipy.optimize's package
    costs 70-90 ms of a process's first critical flow."""
    loaded = run("""
        import json, sys
        import pipeflex as pf
        pf.critical_mass_flow(pf.scenes.cantilever_pipe(n_elements=4))
        print(json.dumps([m for m in ("scipy.optimize",) if m in sys.modules]))
        """)
    assert loaded == []
