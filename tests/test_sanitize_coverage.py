"""The sanitizer run (``make sanitize``, tools/sanitize.sh) reaches every C++ entry point:
each bound function and method of ``pipeflex._core`` is called by at least one test of
its selection.

The record comes from the selection's own run: the ``core_calls`` plugin
(tests/core_calls.py) traces the calls of ``_core``'s functions (a ``sys.setprofile``
hook, by object identity) and writes their names to ``$PIPEFLEX_CORE_CALLS``;
tools/sanitize.sh then runs this file with the same variable. Without a record (an
ordinary test run) the check of the selection is skipped; the other tests check the
tracing and the listing themselves."""
from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
import core_calls  # noqa: E402  (tests/core_calls.py: the plugin)

from pipeflex import _core  # noqa: E402


def uncalled(called) -> list:
    """The bound functions of ``_core`` (as :func:`core_calls.bound_functions` lists them)
    not in ``called``."""
    return sorted(set(core_calls.bound_functions(_core)) - set(called))


def test_the_sanitized_selection_calls_every_bound_function():
    path = os.environ.get(core_calls.ENV)
    if not path:
        pytest.skip(f"no record: set {core_calls.ENV} to the core_calls plugin's output (make sanitize does)")
    record = json.loads(Path(path).read_text())
    # the record was made against the same module: a function added since is not "called"
    missing = uncalled(record["called"])
    assert not missing, (
        f"no test of the sanitizer's selection (tools/sanitize.sh SUBSET) calls {', '.join(missing)}: "
        f"add a test that reaches them to the selection")


def test_the_listing_has_module_functions_and_methods_and_no_constructor():
    names = set(core_calls.bound_functions(_core))
    assert {"linear_matrices", "steady_rotation", "rotating_state", "static_equilibrium",
            "integrate", "flow_map", "Model.add_pipes", "MultibodySystemCore.free_motions", "FlowMapTangent.apply",
            "TimeTable.at"} <= names
    assert not any(n.endswith(".__init__") for n in names)
    assert "State.q" not in names  # a property, not a function
    assert "DENSE_LU_BELOW" not in names and "MAX_OUTPUT_BYTES" not in names
    assert len(uncalled([])) == len(names)
    assert uncalled(names) == []
    assert uncalled(names - {"rotating_state"}) == ["rotating_state"]


def test_the_trace_sees_module_functions_and_methods_called_through_pipeflex():
    import pipeflex as pf

    original = vars(_core.Model)["add_pipes"]
    rec = core_calls.Recorder(_core).start()
    try:
        model = pf.scenes.cantilever_pipe(n_elements=2)  # Model.add_pipes(**pipes): a keyword call
        pf.static_equilibrium(model)
        _core.rotation_exp(np.array([0.1, 0.2, 0.3]))
    finally:
        called = rec.stop()
    assert {"rotation_exp", "element_system", "static_equilibrium", "Model.finalize", "Model.add_pipes"} <= called
    assert "rotating_state" not in called
    # the run is left as it was
    assert sys.getprofile() is None and vars(_core.Model)["add_pipes"] is original
