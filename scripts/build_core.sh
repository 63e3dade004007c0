#!/usr/bin/env bash
# Builds the ROS-free core, its tools and its unit tests with plain CMake (no
# catkin): scripts/build_core.sh BUILD_DIR [CMAKE_ARGS...], e.g. a clang build
#   CC=clang CXX=clang++ scripts/build_core.sh build-clang
# or a sanitizer build
#   scripts/build_core.sh build-asan -DAMHMVS_SANITIZERS=address,undefined
# CPU only (no CUDA); targets: AMHMVS_MAKE_TARGETS (default: all).
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
export PATH=/usr/bin:/bin:/usr/sbin:/sbin:$PATH
build=$1
shift
mkdir -p "$build"
args=(-DAMHMVS_CORE_ONLY=ON -DAMHMVS_WITH_CUDA=OFF -DCMAKE_BUILD_TYPE=${AMHMVS_BUILD_TYPE:-Release})
# Ninja, as scripts/build.sh: a new build folder only.
if command -v ninja >/dev/null && [ ! -f "$build/CMakeCache.txt" ]; then
  args+=(-G Ninja)
fi
if command -v ccache >/dev/null; then
  # what lets ccache cache the files compiled with a precompiled header
  export CCACHE_SLOPPINESS=${CCACHE_SLOPPINESS:-pch_defines,time_macros,include_file_mtime,include_file_ctime}
  args+=(-DCMAKE_C_COMPILER_LAUNCHER=ccache -DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
fi
cmake -S "$here" -B "$build" "${args[@]}" "$@" > "$build/configure.log" 2>&1 ||
  { cat "$build/configure.log"; exit 1; }
grep -E "amhmvs:" "$build/configure.log" || true
# shellcheck disable=SC2086
cmake --build "$build" -j "$(nproc)" --target ${AMHMVS_MAKE_TARGETS:-all}
