#!/usr/bin/env bash
# Build the C++ core with AddressSanitizer + UndefinedBehaviorSanitizer into a separate
# directory (build/asan-<tag>; the normal build/cmake-<tag> and python/pipeflex/_core*.so
# are left alone), lay out a copy of the Python package next to it, and run the given
# command (default: the sanitizer test subset) with that package first on PYTHONPATH.
#
#   tools/sanitize.sh                 # build, then run the subset (make sanitize)
#   tools/sanitize.sh build           # build only
#   tools/sanitize.sh run CMD ARGS... # build, then run CMD ARGS under the sanitizers
#
# Python is not instrumented: libasan/libubsan are preloaded; leaks are not checked
# (CPython keeps its objects at exit by design); any ASan or UBSan report aborts the
# process, so it fails the job. A test that hangs ends the run after SANITIZE_TIMEOUT
# seconds (an integer, default 60): pytest-timeout at 9/10 of it reports the test, and
# tests/hard_timeout.py (faulthandler's C timer) exits at the limit where pytest-timeout
# cannot act (a C++ loop holding the GIL). A fuzz case that hangs is stopped likewise.
# The configuration (flags, build type, Python, generator) is kept in
# build/asan-<tag>/configure.stamp: when it changes, cmake configures the directory
# afresh (SANITIZE_FLAGS=... overrides the sanitizer flags).
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
PY=${PY:-$ROOT/.venv/bin/python}
tag=$("$PY" -c 'import sys; print(f"py{sys.version_info[0]}{sys.version_info[1]}")')
BUILD=$ROOT/build/asan-$tag
PKG=$BUILD/pkg
SAN=${SANITIZE_FLAGS:-"-fsanitize=address,undefined -fno-sanitize-recover=undefined -fno-omit-frame-pointer"}
TIMEOUT=${SANITIZE_TIMEOUT:-60}

build() {
  mkdir -p "$BUILD" "$PKG/pipeflex"
  local gen=()
  command -v ninja >/dev/null && gen=(-G Ninja)
  pybind11_dir=$("$PY" -c 'import pybind11; print(pybind11.get_cmake_dir())')
  local config=("${gen[@]}" -DPython_EXECUTABLE="$PY" \
    -Dpybind11_DIR="$pybind11_dir" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g" -DCMAKE_CXX_FLAGS="$SAN" \
    -DCMAKE_MODULE_LINKER_FLAGS="$SAN" -DCMAKE_SHARED_LINKER_FLAGS="$SAN" \
    -DCMAKE_LIBRARY_OUTPUT_DIRECTORY="$PKG/pipeflex")
  local stamp=$BUILD/configure.stamp
  if [ ! -f "$BUILD/CMakeCache.txt" ] || [ "$(cat "$stamp" 2>/dev/null)" != "$(printf '%s\n' "${config[@]}")" ]; then
    # a changed flag or generator: configure from scratch (a kept cache would keep the
    # old values of anything not given again, and a generator cannot change in place)
    rm -rf "$BUILD/CMakeCache.txt" "$BUILD/CMakeFiles" "$stamp"
    cmake -S "$ROOT" -B "$BUILD" "${config[@]}" >/dev/null
    printf '%s\n' "${config[@]}" >"$stamp"
  fi
  cmake --build "$BUILD" --parallel "${JOBS:-$(nproc)}"
  # the Python sources, fresh each time (not the normal build's _core)
  "$PY" - "$ROOT/python/pipeflex" "$PKG/pipeflex" <<'PYEOF'
import shutil, sys
from pathlib import Path
src, dst = Path(sys.argv[1]), Path(sys.argv[2])
for p in dst.iterdir():
    if not p.name.startswith("_core"):
        shutil.rmtree(p) if p.is_dir() else p.unlink()
ignore = shutil.ignore_patterns("_core*.so", "__pycache__")
for p in src.iterdir():
    if p.name.startswith("_core") or p.name == "__pycache__":
        continue
    shutil.copytree(p, dst / p.name, ignore=ignore) if p.is_dir() else shutil.copy2(p, dst / p.name)
PYEOF
}

run() {
  export PYTHONPATH=$PKG${PYTHONPATH:+:$PYTHONPATH}
  export LD_PRELOAD="$(gcc -print-file-name=libasan.so):$(gcc -print-file-name=libubsan.so)"
  export ASAN_OPTIONS=detect_leaks=0:abort_on_error=1:halt_on_error=1:check_initialization_order=1:strict_init_order=1
  export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
  export PIPEFLEX_SANITIZED=1
  "$@"
}

# Tests covering every C++ entry point: element kernels (test_element*), assembly and
# the size/index checks (test_reliability, test_bad_input), static, linearize/eigen,
# critical flow, generalised-alpha and IDA (test_transient), the flow map
# _core.flow_map (test_periodic), ANCF (test_ancf, test_rotating),
# steady rotation (test_sprinkler), FFRF bodies and the multibody integrator and statics
# (test_ffrf_*, test_multibody_*), the element interface's spring (test_element_interface),
# the system object's entry points (test_system), the static driver's arc-length and flow
# continuation on every system (test_static_any_system), and the property tests (hypothesis); then a short
# fuzz run. About a fifth of the fast suite's tests, 4 min under the sanitizers
# (the whole suite took 24 min). test_sanitized_entry_points reaches what the others do
# not (the coupled linearisation, the coupled and the bodies' steady rotation, the
# bindings that serve tests and benchmarks); the core_calls plugin (tests/core_calls.py)
# records which functions and methods of pipeflex._core the selection calls, and
# test_sanitize_coverage then fails on any that no test called.
SUBSET=(
  tests/test_element.py tests/test_element_tangent.py tests/test_reliability.py
  tests/test_bad_input.py tests/test_static.py tests/test_linearization.py
  tests/test_critical_flow.py tests/test_transient.py tests/test_periodic.py
  tests/test_ancf.py tests/test_rotating.py tests/test_sprinkler.py tests/test_ffrf_body.py
  tests/test_ffrf_scenes.py tests/test_multibody_joints.py tests/test_multibody_input.py
  tests/test_properties.py tests/test_coupled.py tests/test_sanitized_entry_points.py
  tests/test_element_interface.py tests/test_system.py tests/test_linear_csc.py
  tests/test_static_any_system.py tests/test_spring_dampers.py tests/test_user_loads.py
  tests/test_body_springs.py tests/test_distributed_load.py tests/test_sensors.py
  tests/test_bushing.py tests/test_body_foundation.py tests/test_sensors_bodies.py
)

case "${1:-test}" in
  build) build ;;
  run) shift; build; run "$@" ;;
  test)
    build
    # the Ctrl-C test asserts wall-clock bounds (stops within 0.5 s), which the sanitizers'
    # 5x slowdown on a loaded machine breaks; its C++ path (poll_interrupt) runs in every
    # integrator loop of the subset anyway
    calls=$BUILD/core_calls.json
    rm -f "$calls"
    limits=(-p hard_timeout --timeout "$((TIMEOUT * 9 / 10))")
    run env MPLBACKEND=Agg PIPEFLEX_FAST=1 PYTHONPATH="$PKG:$ROOT/tests${PYTHONPATH:+:$PYTHONPATH}" \
      PIPEFLEX_CORE_CALLS="$calls" PIPEFLEX_HARD_TIMEOUT="$TIMEOUT" \
      "$PY" -m pytest -q -p no:cacheprovider -p core_calls "${limits[@]}" "${SUBSET[@]}" \
      --deselect tests/test_reliability.py::test_ctrl_c_stops_a_multibody_run
    run env PYTHONPATH="$PKG:$ROOT/tests${PYTHONPATH:+:$PYTHONPATH}" PIPEFLEX_CORE_CALLS="$calls" \
      PIPEFLEX_HARD_TIMEOUT="$TIMEOUT" "$PY" -m pytest -q -p no:cacheprovider "${limits[@]}" \
      tests/test_sanitize_coverage.py
    # a short fuzz run: a sanitizer report kills its worker, which counts as a crash
    run "$PY" tests/fuzz/run_fuzz.py --examples "${SANITIZE_FUZZ_EXAMPLES:-300}" --jobs 2 --crashes-only \
      --case-timeout "$TIMEOUT" --timeout 1800 --out "$BUILD/fuzz"
    ;;
  *) echo "usage: $0 [build | run CMD... | test]" >&2; exit 2 ;;
esac
