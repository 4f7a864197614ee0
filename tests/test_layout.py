"""The package's shape: the library apart from the seed studies, and no import cycles.

The library is every module of ``pipeflex`` except ``pipeflex.seeds.*`` (the papers'
scenes, published numbers, studies, figures), ``pipeflex.scenes`` (the catalogue of the
seeds' scenes) and ``pipeflex.cli`` (the command line, which runs the seeds' validation).
"""
import ast
import subprocess
import sys
from pathlib import Path

import pipeflex

from helpers import imported_module

PACKAGE = Path(pipeflex.__file__).parent
APPLICATION = ("pipeflex.seeds", "pipeflex.scenes", "pipeflex.cli", "pipeflex.__main__")


def _modules():
    """Module name -> source path of every module in the package."""
    out = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = ("pipeflex",) + path.relative_to(PACKAGE).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    for path in PACKAGE.glob("*.so"):  # the compiled core: a module that imports nothing of ours
        out["pipeflex." + path.name.split(".")[0]] = None
    return out


def _imports(name, path, modules):
    """Modules of the package that ``name`` imports anywhere in its source (also inside functions)."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            target = imported_module(package, node)
            for a in node.names:
                sub = f"{target}.{a.name}"
                found.add(sub if sub in modules else target)
        elif (isinstance(node, ast.Assign) and isinstance(node.value, ast.Dict)
              and any(isinstance(t, ast.Name) and t.id == "_LAZY" for t in node.targets)):
            # a lazy name table (pipeflex._lazy.attach): "module" or "module:attribute"
            found.update(v.value.partition(":")[0] for v in node.value.values if isinstance(v, ast.Constant))
    return {m for m in found if m in modules and m != name}


def _graph():
    modules = _modules()
    return {name: _imports(name, path, modules) if path else set() for name, path in modules.items()}


def _is_library(name):
    return name != "pipeflex" and not any(name == a or name.startswith(a + ".") for a in APPLICATION)


def test_no_import_cycles():
    graph = _graph()
    state, stack, cycles = {}, [], []

    def visit(n):
        state[n] = "open"
        stack.append(n)
        for m in sorted(graph[n]):
            if state.get(m) == "open":
                cycles.append(stack[stack.index(m):] + [m])
            elif m not in state:
                visit(m)
        stack.pop()
        state[n] = "done"

    for n in sorted(graph):
        if n not in state:
            visit(n)
    assert not cycles, "import cycles: " + "; ".join(" -> ".join(c) for c in cycles)


def test_the_graph_sees_imports():
    """The walker must find what is there, or the tests above pass vacuously."""
    graph = _graph()
    assert "pipeflex.seeds.seed000.scenes" in graph["pipeflex.scenes"]
    assert "pipeflex.model" in graph["pipeflex.seeds.seed000.scenes"]
    assert "pipeflex.analysis.eigen" in graph["pipeflex.analysis.transient"]  # an import inside a function


def test_library_imports_nothing_from_the_seeds():
    graph = _graph()
    bad = {n: sorted(m for m in deps if not _is_library(m) and m != "pipeflex")
           for n, deps in graph.items() if _is_library(n)}
    assert not {n: d for n, d in bad.items() if d}


def test_importing_the_library_loads_no_seed_module():
    library = sorted(n for n, path in _modules().items() if path and (_is_library(n) or n == "pipeflex"))
    code = ("import importlib, sys\n"
            f"for m in {library!r}: importlib.import_module(m)\n"
            "print(sorted(m for m in sys.modules if m.startswith('pipeflex.seeds') or m == 'pipeflex.scenes'))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_public_entry_points_keep_working():
    import pipeflex as pf

    assert callable(pf.scenes.cantilever_pipe) and callable(pf.scenes.ffrf_curved_pipe)
    assert callable(pf.critical_mass_flow) and callable(pf.multibody.simulate)
    from pipeflex import scenes  # noqa: F401 (the from-import form works too)


def test_the_library_speaks_of_physics_not_of_the_seeds():
    """Sources are cited by their authors; "seed" belongs to pipeflex.seeds."""
    offenders = [f"{name}:{i}" for name, path in _modules().items() if path and _is_library(name)
                 for i, line in enumerate(path.read_text().splitlines(), 1) if "seed" in line.lower()]
    assert not offenders


ANALYSIS = PACKAGE / "analysis"
FORMULATIONS = ("pipeflex.multibody", "pipeflex.coupled")


def _names_a_formulation(module):
    return any(module == f or module.startswith(f + ".") for f in FORMULATIONS)


def test_the_analyses_import_no_formulation():
    """One driver per analysis for every formulation: pipeflex.analysis names neither
    pipeflex.multibody nor pipeflex.coupled in any import (also inside functions); the
    model classes carry what is formulation-specific (analysis/_protocol.py)."""
    graph = _graph()
    bad = {n: sorted(m for m in deps if _names_a_formulation(m))
           for n, deps in graph.items() if n == "pipeflex.analysis" or n.startswith("pipeflex.analysis.")}
    assert not {n: d for n, d in bad.items() if d}


def test_importing_every_analysis_loads_no_formulation_module():
    analyses = sorted(n for n, path in _modules().items() if path and n.startswith("pipeflex.analysis"))
    assert "pipeflex.analysis.transient" in analyses and "pipeflex.analysis.critical" in analyses
    code = ("import importlib, sys\n"
            f"for m in {analyses!r}: importlib.import_module(m)\n"
            "import pipeflex.analysis as a\n"
            "for name in a.__all__: getattr(a, name)\n"
            f"print(sorted(m for m in sys.modules if any(m == f or m.startswith(f + '.') for f in {FORMULATIONS!r})))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


def test_the_analyses_do_not_dispatch_on_the_model_type():
    """No loaded_instance (the lazy isinstance) and no per-formulation hook looked up on the
    model (getattr(model, "_simulate") and the like) under analysis/."""
    hooks = ('"_simulate"', '"_linearize"', '"_static"', "loaded_instance")
    offenders = [f"{path.name}:{i}: {hook}" for path in sorted(ANALYSIS.glob("*.py"))
                 for i, line in enumerate(path.read_text().splitlines(), 1) for hook in hooks if hook in line]
    assert not offenders
