#!/usr/bin/env bash
# Configures and builds the catkin package (core, CLIs, tests) into build/.
# CUDA is used when nvcc is found (/usr/local/cuda or PATH), compiled for
# this machine's GPU, else (no GPU visible: the CUDA code is compiled, not
# run) for sm_90 only: a quarter of the time of the five targets a release
# build of the package makes (measured: cuda_backend.cu 75 against 273 s).
# AMHMVS_CUDA_ARCHITECTURES sets the GPU targets (CMake syntax);
# AMHMVS_WITH_CUDA=OFF makes a CPU-only build (the demo asks for one in a new
# folder when no GPU is visible). The demo, the fast tier and the test command
# all build through here, so they share one configuration.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
# Debian's catkin and pluginlib call python3 from PATH: it must be the
# system one with the ROS modules, not a pyenv shim.
export PATH=/usr/bin:/bin:/usr/sbin:/sbin:/usr/local/cuda/bin:$PATH
build=${AMHMVS_BUILD_DIR:-$here/build}
mkdir -p "$build"
if [ -z "${AMHMVS_CUDA_ARCHITECTURES:-}" ]; then
  if nvidia-smi -L > /dev/null 2>&1; then
    AMHMVS_CUDA_ARCHITECTURES=native
  else
    AMHMVS_CUDA_ARCHITECTURES=90
  fi
fi
args=(-DCMAKE_BUILD_TYPE=Release)
# Ninja compiles a library's files while the layer below it still links (Make
# waits for each target), which keeps both cores busy while nvcc runs. A
# configured build folder keeps the generator it was made with.
if command -v ninja >/dev/null && [ ! -f "$build/CMakeCache.txt" ]; then
  args+=(-G Ninja)
fi
[ -n "${AMHMVS_WITH_CUDA:-}" ] && args+=(-DAMHMVS_WITH_CUDA="$AMHMVS_WITH_CUDA")
args+=(-DAMHMVS_CUDA_ARCHITECTURES="$AMHMVS_CUDA_ARCHITECTURES")
# ccache, when installed, makes rebuilds in several checkouts cheap.
if command -v ccache >/dev/null; then
  # what lets ccache cache the files compiled with a precompiled header
  export CCACHE_SLOPPINESS=${CCACHE_SLOPPINESS:-pch_defines,time_macros,include_file_mtime,include_file_ctime}
  args+=(-DCMAKE_C_COMPILER_LAUNCHER=ccache -DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_CUDA_COMPILER_LAUNCHER=ccache)
fi
cmake -S "$here" -B "$build" "${args[@]}" > "$build/configure.log" 2>&1 || { cat "$build/configure.log"; exit 1; }
grep -E "amhmvs:" "$build/configure.log" || true
# shellcheck disable=SC2086
cmake --build "$build" -j "$(nproc)" --target ${AMHMVS_MAKE_TARGETS:-all}
