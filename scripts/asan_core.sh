#!/usr/bin/env bash
# The compiled core under AddressSanitizer (issue 36, item 2): an access outside an array fails
# here even where the normal build happens not to crash on it.
#
# Builds delta_pin/core once with -fsanitize=address -fno-omit-frame-pointer into its own build
# folder (build/asan; the venv's installed core is left as it is), then runs
# tests/sim/test_core_bounds.py and one small existing core test (the analytic plant's) with that
# core loaded in place of the installed one (a sitecustomize.py puts it into sys.modules as
# delta_pin.compiled._core, in pytest and in every subprocess it starts), libasan preloaded into
# Python and ASAN_OPTIONS=detect_leaks=0 (Python's own allocations are not leaks to report).
#
# .ci/run runs it before the test suite. The build is g++'s (the libasan preloaded below is gcc's;
# CMakeLists.txt would take clang++ where it is installed); the tests take about 20 s.
#
# Usage: bash scripts/asan_core.sh [extra pytest arguments]   (from anywhere; needs the venv's
# python with pin, cmeel-eigen and nanobind: pip install nanobind)
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
python="${PYTHON:-$root/.venv/bin/python}"
build="$root/build/asan"
start=$(date +%s)

"$python" -c "import nanobind" 2>/dev/null || "$python" -m pip install -q nanobind
version="$("$python" -c "import tomllib; print(tomllib.load(open('$root/pyproject.toml', 'rb'))['project']['version'])")"
# EIGEN_MALLOC_ALREADY_ALIGNED=1: Eigen turns its glibc "malloc is aligned" shortcut off under
# __SANITIZE_ADDRESS__ and then frees by its hand-made aligned allocator, while the pin wheel's
# libpinocchio_default (built without ASan) allocates with plain malloc: every Data freed here
# would read 8 bytes before its arrays (a false heap-buffer-overflow at the first ClosedChainModel)
flags="-fsanitize=address -fno-omit-frame-pointer -g -DEIGEN_MALLOC_ALREADY_ALIGNED=1"
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DSKBUILD_PROJECT_NAME=delta_pin -DSKBUILD_PROJECT_VERSION="$version" \
  -DPython_EXECUTABLE="$python" -DCMAKE_CXX_COMPILER=g++ -DCMAKE_CXX_FLAGS="$flags" \
  -DCMAKE_SHARED_LINKER_FLAGS="-fsanitize=address" -DCMAKE_MODULE_LINKER_FLAGS="-fsanitize=address" >/dev/null
ninja -C "$build"
so="$(ls "$build"/_core.*.so)"
echo "asan core: $so (built in $(($(date +%s) - start)) s)"

# the ASan core as delta_pin.compiled._core in every interpreter that starts under this env
site="$build/site"
mkdir -p "$site"
cat >"$site/sitecustomize.py" <<'PY'
import importlib.util
import os
import sys

_so = os.environ.get("DELTA_PIN_ASAN_CORE")
if _so:
    import pinocchio  # noqa: F401  (loads libpinocchio_default, which the core links)

    import delta_pin.compiled as _parent

    _spec = importlib.util.spec_from_file_location("delta_pin.compiled._core", _so)
    _module = importlib.util.module_from_spec(_spec)
    sys.modules[_spec.name] = _module
    _spec.loader.exec_module(_module)
    _parent._core = _module
PY

cd "$root"
export DELTA_PIN_ASAN_CORE="$so"
export PYTHONPATH="$site${PYTHONPATH:+:$PYTHONPATH}"
export ASAN_OPTIONS="detect_leaks=0"
# libstdc++ beside libasan: without it ASan cannot find the real __cxa_throw (CHECK failed in
# asan_interceptors.cpp) and every C++ exception aborts
export LD_PRELOAD="$(gcc -print-file-name=libasan.so):$(gcc -print-file-name=libstdc++.so)"
"$python" -c "import delta_pin.compiled._core as c; assert c.__file__ == '$so', c.__file__; print('loaded', c.__file__)"
"$python" -m pytest -q -p no:cacheprovider tests/sim/test_core_bounds.py \
  "tests/sim/test_core_analytic_plant.py::test_the_core_derivative_is_the_python_plants" "$@"
echo "asan_core.sh: done in $(($(date +%s) - start)) s"
