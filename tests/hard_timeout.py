"""A hard time limit per test: a pytest plugin for the sanitizer run (tools/sanitize.sh).

    PIPEFLEX_HARD_TIMEOUT=60 python -m pytest -p hard_timeout tests/...

(with tests/ on PYTHONPATH) ends the whole run, exit status 1, if one test (setup, call
and teardown) takes longer than that many seconds. pytest-timeout's thread method
needs the GIL to act, so a C++ loop that holds it (most bindings do) never lets it fire;
faulthandler's timer is a C thread that needs nothing from Python: it writes the
stacks to stderr and exits the process. Without ``PIPEFLEX_HARD_TIMEOUT`` the plugin
does nothing.
"""
import faulthandler
import os
import sys

import pytest

ENV = "PIPEFLEX_HARD_TIMEOUT"
# the real stderr, taken when pytest loads the plugin (-p), before its capture replaces fd 2
_STDERR = os.fdopen(os.dup(sys.stderr.fileno()), "w") if os.environ.get(ENV) else None


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    seconds = float(os.environ.get(ENV) or 0)
    if seconds > 0:
        faulthandler.dump_traceback_later(seconds, exit=True, file=_STDERR)
    try:
        yield
    finally:
        if seconds > 0:
            faulthandler.cancel_dump_traceback_later()
