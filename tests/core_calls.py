"""Which bound functions of ``pipeflex._core`` a test run calls: a pytest plugin for the
sanitizer run (tools/sanitize.sh), read by tests/test_sanitize_coverage.py.

    PIPEFLEX_CORE_CALLS=calls.json python -m pytest -p core_calls tests/...

(with tests/ on PYTHONPATH) records, while the tests run, every call of a module
function or of a method of a class of ``pipeflex._core``, and writes the names to
``calls.json`` at the end. Without ``PIPEFLEX_CORE_CALLS`` the plugin does nothing.

The record is a runtime trace, not a reading of the sources (a name that appears in
the code but that no test reaches is not counted; see :class:`Recorder`), so it counts
what the tests actually reach through the Python package. Not seen: calls in other
processes (pool workers, the fuzz workers); constructors (``__init__``) and properties
are not listed.
"""
from __future__ import annotations

import functools
import json
import os
import sys
import threading
from pathlib import Path

ENV = "PIPEFLEX_CORE_CALLS"


def bound_functions(core) -> dict:
    """{name: (owner, attribute, member)} for the module functions ("steady_rotation")
    and the methods, static methods included, of the module's classes ("Model.add_node")
    of the extension module ``core``; constructors, other dunder methods and properties
    left out. ``owner`` is the module or the class, ``member`` what its dict holds."""
    found = {}
    for name, obj in vars(core).items():
        if name.startswith("__"):
            continue
        if isinstance(obj, type) and obj.__module__ == core.__name__:
            for attr, member in vars(obj).items():
                if attr.startswith("__") or isinstance(member, property):
                    continue
                if callable(getattr(member, "__func__", member)):  # instancemethod / staticmethod
                    found[f"{name}.{attr}"] = (obj, attr, member)
        elif type(obj).__name__ == "builtin_function_or_method":
            found[name] = (core, name, obj)
    return found


class Recorder:
    """Collects the names of ``core``'s functions called between :meth:`start` and
    :meth:`stop`, in every thread.

    Module functions: a profile hook (``sys.setprofile``, ``threading.setprofile``) sees
    each call of a C function and looks it up by identity, so a function reached through
    any alias (``from ._core import f``, a dict of kernels) counts. Methods: the hook does
    not see a method called with ``**kwargs`` (CPython 3.11 traces only a bare C function
    there, not a bound method), so each method is wrapped, for the run, in a Python
    function that records its name and calls it; the classes are shared, so every
    instance and every caller goes through the wrapper."""

    def __init__(self, core):
        self.found = bound_functions(core)
        self.ids = {id(member): name for name, (owner, _, member) in self.found.items() if owner is core}
        self.called = set()
        self._patched = []

    def _profile(self, frame, event, arg):
        if event == "c_call":
            name = self.ids.get(id(arg))
            if name is not None:
                self.called.add(name)

    def _wrap(self, name, member):
        fn = getattr(member, "__func__", member)
        called = self.called

        @functools.wraps(fn)
        def recorded(*args, **kwargs):
            called.add(name)
            return fn(*args, **kwargs)

        return staticmethod(recorded) if isinstance(member, staticmethod) else recorded

    def start(self):
        for name, (owner, attr, member) in self.found.items():
            if isinstance(owner, type):
                setattr(owner, attr, self._wrap(name, member))
                self._patched.append((owner, attr, member))
        threading.setprofile(self._profile)
        sys.setprofile(self._profile)
        return self

    def stop(self):
        sys.setprofile(None)
        threading.setprofile(None)
        for owner, attr, member in self._patched:
            setattr(owner, attr, member)
        self._patched.clear()
        return self.called


_recorder = None


def pytest_configure(config):
    global _recorder
    if os.environ.get(ENV):
        from pipeflex import _core

        _recorder = Recorder(_core).start()


def pytest_unconfigure(config):
    global _recorder
    if _recorder is not None:
        called = sorted(_recorder.stop())
        listed = sorted(_recorder.found)
        Path(os.environ[ENV]).write_text(json.dumps(dict(called=called, listed=listed), indent=1))
        _recorder = None
