"""tools/sanitize.sh configures its build directory again when its configuration (the
sanitizer flags, build type, Python, generator) changes, and only then. Run on a copy of
the script with a stub ``cmake`` on PATH that logs its calls: no compiler runs."""
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

pytestmark = pytest.mark.skipif(shutil.which("bash") is None, reason="needs bash")

STUB = """#!/bin/sh
echo "$*" >> "$STUB_LOG"
[ "$1" = "--build" ] && exit 0
while [ $# -gt 0 ]; do [ "$1" = "-B" ] && mkdir -p "$2" && : > "$2/CMakeCache.txt"; shift; done
"""


@pytest.fixture
def sanitize(tmp_path):
    (tmp_path / "tools").mkdir()
    shutil.copy(ROOT / "tools" / "sanitize.sh", tmp_path / "tools" / "sanitize.sh")
    (tmp_path / "python" / "pipeflex").mkdir(parents=True)
    (tmp_path / "python" / "pipeflex" / "__init__.py").write_text("")
    stub = tmp_path / "stub"
    stub.mkdir()
    (stub / "cmake").write_text(STUB)
    (stub / "cmake").chmod(0o755)
    log = tmp_path / "cmake.log"

    def build(**env):
        log.write_text("")
        run_env = {k: v for k, v in os.environ.items() if k != "SANITIZE_FLAGS"}
        run_env.update(PATH=f"{stub}{os.pathsep}{os.environ['PATH']}", PY=sys.executable, STUB_LOG=str(log), **env)
        subprocess.run(["bash", str(tmp_path / "tools" / "sanitize.sh"), "build"], env=run_env, check=True,
                       capture_output=True, text=True)
        calls = log.read_text().splitlines()
        assert calls[-1].startswith("--build")
        return [c for c in calls if not c.startswith("--build")]

    return build


def test_sanitize_reconfigures_when_its_flags_change(sanitize):
    pytest.importorskip("pybind11")
    (first,) = sanitize()
    assert "-fsanitize=address,undefined" in first
    assert sanitize() == []  # the same configuration: only the build
    (changed,) = sanitize(SANITIZE_FLAGS="-fsanitize=address -fno-omit-frame-pointer")
    assert "-DCMAKE_CXX_FLAGS=-fsanitize=address -fno-omit-frame-pointer" in changed
    assert sanitize(SANITIZE_FLAGS="-fsanitize=address -fno-omit-frame-pointer") == []
    (back,) = sanitize()
    assert back == first


HUNG = """
import re


def test_spins_in_c_holding_the_gil():
    re.match(r"(a*)*b", "a" * 64)  # catastrophic backtracking: C, GIL held, for ages


def test_quick():
    pass
"""


@pytest.mark.parametrize("hang", [True, False])
def test_hard_timeout_ends_a_test_that_holds_the_gil_in_c(tmp_path, hang):
    """tests/hard_timeout.py (the sanitizer run's per-test limit) ends the run within its
    limit even when the test spins in C with the GIL held, where pytest-timeout's thread
    cannot run; a quick test passes under it."""
    import time

    (tmp_path / "test_hung.py").write_text(HUNG)
    env = dict(os.environ, PYTHONPATH=f"{ROOT / 'tests'}{os.pathsep}{os.environ.get('PYTHONPATH', '')}",
               PIPEFLEX_HARD_TIMEOUT="2")
    target = "test_hung.py" + ("" if hang else "::test_quick")
    t0 = time.monotonic()
    r = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "hard_timeout",
                        "--timeout", "0", "--rootdir", str(tmp_path), "-c", os.devnull, target],
                       cwd=tmp_path, env=env, capture_output=True, text=True, timeout=120)
    if hang:
        assert r.returncode != 0 and "Timeout (0:00:02)" in r.stderr and "test_spins_in_c_holding_the_gil" in r.stderr
        assert time.monotonic() - t0 < 30
    else:
        assert r.returncode == 0, r.stdout + r.stderr
