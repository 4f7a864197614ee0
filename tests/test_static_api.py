"""The public API as editors and type checkers see it, without running the package.

Every package with lazy names (PEP 562, ``pipeflex._lazy.attach``) spells them out in an
``if TYPE_CHECKING:`` block, which static tools read and the interpreter skips (so that
``import pipeflex`` stays lazy: tests/test_import_cost.py). The block must name exactly the
lazy table's names, each bound to the object the package gives at run time. The compiled
core's functions take named arguments (``py::arg``), so their signatures read
``apply(self, directions)``, not ``apply(self, arg0)``.
"""
import ast
import importlib
import importlib.util
import inspect
import re
import types
from pathlib import Path

import pytest

import pipeflex
from pipeflex import _core

from helpers import imported_module

PACKAGE = Path(pipeflex.__file__).parent
# the packages known to have lazy names: the search below must find at least these
KNOWN_LAZY = {"pipeflex", "pipeflex.analysis", "pipeflex.scenes", "pipeflex.seeds.seed000",
              "pipeflex.seeds.seed002", "pipeflex.seeds.seed004"}


def _module_name(path):
    parts = ("pipeflex",) + path.relative_to(PACKAGE).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _lazy_modules():
    """(module name, is a package, syntax tree) of every module calling ``_lazy.attach``."""
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        text = path.read_text()
        if "_lazy.attach" not in text:
            continue
        tree = ast.parse(text)
        if any(isinstance(n, ast.Attribute) and n.attr == "attach" and isinstance(n.value, ast.Name)
               and n.value.id == "_lazy" for n in ast.walk(tree)):
            found.append((_module_name(path), path.name == "__init__.py", tree))
    return found


LAZY = _lazy_modules()


def _type_checking_imports(name, is_package, tree):
    """{bound name: (absolute module, imported name)} of the module-level ``if TYPE_CHECKING:``
    blocks (``import a.b as c`` gives (a.b, None))."""
    package = name if is_package else name.rpartition(".")[0]
    out = {}
    for node in tree.body:
        if not (isinstance(node, ast.If) and isinstance(node.test, ast.Name) and node.test.id == "TYPE_CHECKING"):
            continue
        for stmt in node.body:
            if isinstance(stmt, ast.ImportFrom):
                module = imported_module(package, stmt)
                for alias in stmt.names:
                    bound = alias.asname or alias.name
                    assert bound not in out, f"{name}: {bound} imported twice under TYPE_CHECKING"
                    out[bound] = (module, alias.name)
            elif isinstance(stmt, ast.Import):
                for alias in stmt.names:
                    assert alias.asname, f"{name}: `import {alias.name}` binds no lazy name"
                    out[alias.asname] = (alias.name, None)
            else:
                raise AssertionError(f"{name}: only imports belong in the TYPE_CHECKING block, "
                                     f"found {ast.dump(stmt)[:60]}")
    return out


def _resolve(owner, module, attribute):
    """What the import statement binds at run time, found without ``owner``'s lazy table:
    ``from owner import x`` is owner's submodule x (else the test would compare the table
    with itself); ``from m import x`` is m's attribute x, else its submodule x."""
    if attribute is None:
        return importlib.import_module(module)
    submodule = f"{module}.{attribute}"
    if module == owner:
        return importlib.import_module(submodule)
    mod = importlib.import_module(module)
    if hasattr(mod, attribute):
        return getattr(mod, attribute)
    return importlib.import_module(submodule)


def test_the_search_finds_every_lazy_package():
    assert KNOWN_LAZY <= {name for name, _, _ in LAZY}


@pytest.mark.parametrize("name, is_package, tree", LAZY, ids=[name for name, _, _ in LAZY])
def test_type_checking_block_names_exactly_the_lazy_names_and_the_same_objects(name, is_package, tree):
    module = importlib.import_module(name)
    declared = _type_checking_imports(name, is_package, tree)
    assert declared, f"{name} has lazy names but no `if TYPE_CHECKING:` block spelling them out"
    table = module._LAZY
    assert set(declared) == set(table), (f"{name}: missing under TYPE_CHECKING {sorted(set(table) - set(declared))}, "
                                         f"not lazy {sorted(set(declared) - set(table))}")
    for bound, (source, attribute) in declared.items():
        expected = _resolve(name, source, attribute)
        assert getattr(module, bound) is expected, f"{name}.{bound}: the lazy table and TYPE_CHECKING disagree"


@pytest.mark.parametrize("name", [name for name, _, _ in LAZY])
def test_all_lists_every_public_lazy_function_and_class_and_resolves(name):
    module = importlib.import_module(name)
    public = module.__all__
    assert len(public) == len(set(public)), f"{name}.__all__ repeats a name"
    assert [n for n in public if not hasattr(module, n)] == []
    # lazy modules (pf.scenes, pf.plot, ...) are namespaces, not names to star-import
    objects = {n for n in module._LAZY if not isinstance(getattr(module, n), types.ModuleType)}
    assert sorted(objects - set(public)) == [], f"{name}.__all__ misses public lazy names"
    # a package of lazy modules only (the seeds) lists them all
    if not objects:
        assert set(public) == set(module._LAZY)


def test_star_import_gives_the_analyses():
    namespace = {}
    exec("from pipeflex import *", namespace)
    assert namespace["critical_mass_flow"] is pipeflex.analysis.critical.critical_mass_flow
    assert namespace["sweep"] is pipeflex.sweeps.sweep


def test_an_editor_completes_and_signs_the_lazy_analyses(tmp_path):
    """Jedi (IPython's and many editors' completion engine) reads the source statically: the
    TYPE_CHECKING block is what lets it complete ``pf.critical_mass_flow(`` with its
    parameters."""
    jedi = pytest.importorskip("jedi")
    # a script outside the checkout, with this checkout's package on the path (as installed)
    project = jedi.Project(tmp_path, added_sys_path=[str(PACKAGE.parent)])

    def script(code):
        return jedi.Script(code, path=str(tmp_path / "study.py"), project=project)

    assert "critical_mass_flow" in {c.name for c in script("import pipeflex as pf\npf.crit").complete()}
    call = "pf.critical_mass_flow("
    signatures = script(f"import pipeflex as pf\n{call}").get_signatures(2, len(call))
    assert signatures, "no signature for pf.critical_mass_flow("
    assert [p.name for p in signatures[0].params] == list(inspect.signature(pipeflex.critical_mass_flow).parameters)
    assert "cantilever_pipe" in {c.name for c in script("import pipeflex as pf\npf.scenes.cantilever_p").complete()}


def _core_routines():
    """(qualified name, docstring) of every function of _core and method of its classes."""
    out = []
    for name, obj in vars(_core).items():
        if name.startswith("__"):
            continue
        if inspect.isroutine(obj):
            out.append((name, obj.__doc__ or ""))
        elif inspect.isclass(obj):
            for attr, member in vars(obj).items():
                if isinstance(member, property) or attr in ("__new__", "__module__", "__doc__", "__dict__"):
                    continue
                if inspect.isroutine(getattr(obj, attr)):
                    out.append((f"{name}.{attr}", getattr(obj, attr).__doc__ or ""))
    return out


def test_core_functions_and_methods_have_named_parameters():
    routines = dict(_core_routines())
    # the walk must see what is there: functions, methods, constructors
    assert {"assemble", "Model.add_node", "State.__init__", "FlowMapTangent.apply", "TimeTable.at",
            "MultibodySystemCore.evaluate"} <= set(routines)
    assert len(routines) > 60
    unnamed = sorted(name for name, doc in routines.items() if re.search(r"\barg\d+\b", doc))
    assert unnamed == [], f"_core signatures with unnamed parameters (arg0, ...): {unnamed}"


def test_core_parameters_are_passed_by_name():
    """The names are part of the interface: a call by keyword reaches the same C++ parameter."""
    import numpy as np

    table = _core.TimeTable()
    table.t, table.value = [0.0, 1.0], [0.0, 2.0]
    assert table.at(time=0.5) == table.at(0.5) == 1.0
    assert table.rate(time=0.5) == 2.0
    model = _core.Model()
    node = model.add_node(position=np.array([0.0, 0.0, 1.0]))
    assert node == 0 and model.n_nodes == 1
