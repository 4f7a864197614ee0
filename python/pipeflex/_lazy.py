"""Public names of a package that import their module on first use (PEP 562).

``import pipeflex`` imports numpy and the model classes only: scipy (whose
``scipy.sparse`` alone imports csgraph, sparse.linalg and scipy.linalg, about 30 ms),
matplotlib, threadpoolctl and the analyses' modules load when a name that needs them is
first used, so a short script pays only for what it runs (docs/performance.md).
"""
from __future__ import annotations

import importlib
import sys
import types


class _Package(types.ModuleType):
    """A package whose lazy names keep their meaning when a submodule of the same name
    loads: the import system then binds the submodule to the package's attribute
    (``pipeflex.analysis.linearize``, the module), where an eager ``from .linearize import
    linearize`` had left the function."""

    def __setattr__(self, name, value):
        target = self.__dict__.get("_LAZY", {}).get(name, "")
        module, _, attribute = target.partition(":")
        if attribute and isinstance(value, types.ModuleType) and value.__name__ == module:
            value = getattr(value, attribute)
        super().__setattr__(name, value)

    def __reduce__(self):
        # By reference, as a module: pickle refuses modules and cloudpickle (Dask) finds its
        # module reducer by exact type, which this subclass is not; a function of __main__
        # that Dask sends by value carries the package (``pf``) among its globals.
        return importlib.import_module, (self.__name__,)


def attach(package: str, table: dict):
    """``__getattr__`` and ``__dir__`` for the package ``package`` (its ``__name__``):
    ``table`` maps each lazy public name to ``"module"`` or ``"module:attribute"``
    (absolute module names). A name is imported once, then is an ordinary attribute."""
    namespace = sys.modules[package]
    namespace._LAZY = table
    namespace.__class__ = _Package

    def __getattr__(name):
        try:
            target = table[name]
        except KeyError:
            raise AttributeError(f"module {package!r} has no attribute {name!r}") from None
        module, _, attribute = target.partition(":")
        value = importlib.import_module(module)
        if attribute:
            value = getattr(value, attribute)
        setattr(namespace, name, value)
        return value

    def __dir__():
        return sorted(set(namespace.__dict__) | set(table))

    return __getattr__, __dir__


def loaded_instance(obj, module: str, name: str) -> bool:
    """``isinstance(obj, module.name)`` without importing ``module``: an object of a
    class whose module was never imported cannot exist."""
    loaded = sys.modules.get(module)
    return loaded is not None and isinstance(obj, getattr(loaded, name))
