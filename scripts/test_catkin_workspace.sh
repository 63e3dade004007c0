#!/usr/bin/env bash
# The package the way a ROS user builds it: in src/ of a fresh catkin
# workspace, `catkin_make install` (CPU only, without the tests and the
# offline tools besides amhmvs_depth), then from the INSTALL space:
# `rosrun amhmvs_mapping amhmvs_depth --help` and the rostest missing_tf.
# Prints the time of each step; exit 0 when all pass.
#
# With --from-build BUILD_DIR (what CI does: the package is built once
# already) nothing is compiled again: `catkin_make install` of the empty
# workspace writes the workspace's setup files, `cmake --install BUILD_DIR`
# puts the package into the same install space, and the same checks run.
#
# The workspace is a temporary directory outside the repository (a second
# package.xml under the repository would make rospack see the package twice)
# with a symlink to the repository in src/; it is removed at the end.
#
#   scripts/test_catkin_workspace.sh [--from-build BUILD_DIR] [RESULTS_DIR]
#   (RESULTS_DIR: rostest XML; default: in the workspace)
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
export PATH=/usr/bin:/bin:/usr/sbin:/sbin:$PATH  # the system python3 with the ROS modules
data=${AMHMVS_DATA_DIR:-$here/../shared/data}
workspace=$(mktemp -d "${TMPDIR:-/tmp}/amhmvs_catkin_ws.XXXXXX")
trap 'rm -rf "$workspace"' EXIT
from_build=
if [ "${1:-}" = --from-build ]; then
  from_build=$(cd "$2" && pwd)
  shift 2
fi
results=${1:-$workspace/test_results}
mkdir -p "$workspace/src" "$results"
# A fresh environment: nothing from the repository's own devel space.
unset ROS_PACKAGE_PATH CMAKE_PREFIX_PATH LD_LIBRARY_PATH PYTHONPATH PKG_CONFIG_PATH ROSLISP_PACKAGE_DIRECTORIES
export ROS_HOME=$workspace/ros_home

step_start=$(date +%s)
step() {  # step NAME: prints the time of the previous step
  local now
  now=$(date +%s)
  echo "== $1 (previous step: $(( now - step_start )) s) =="
  step_start=$now
}

args=()
if [ -n "$from_build" ]; then
  step "catkin_make install of the empty workspace $workspace, cmake --install $from_build into it"
else
  step "catkin_make install in $workspace"
  ln -s "$here" "$workspace/src/amhmvs_mapping"
  args=(-DCMAKE_BUILD_TYPE=Release -DAMHMVS_WITH_CUDA=OFF -DCATKIN_ENABLE_TESTING=OFF -DAMHMVS_BUILD_TOOLS=OFF)
  if command -v ccache >/dev/null; then
    # Paths relative to the workspace: a later run in another temporary
    # directory hits the same cache entries.
    export CCACHE_BASEDIR=$workspace
    args+=(-DCMAKE_C_COMPILER_LAUNCHER=ccache -DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
  fi
fi
catkin_make -C "$workspace" install "${args[@]}" -j "$(nproc)" > "$workspace/catkin_make.log" 2>&1 ||
  { tail -40 "$workspace/catkin_make.log"; echo "catkin_make install failed"; exit 1; }
if [ -n "$from_build" ]; then
  cmake --install "$from_build" --prefix "$workspace/install" > "$workspace/install.log" 2>&1 ||
    { tail -40 "$workspace/install.log"; echo "cmake --install $from_build failed"; exit 1; }
fi

step "rosrun amhmvs_mapping amhmvs_depth --help (install space)"
set +u
# shellcheck disable=SC1091
source "$workspace/install/setup.bash"
set -u
found=$(rospack find amhmvs_mapping)
if [ "$found" != "$workspace/install/share/amhmvs_mapping" ]; then
  echo "rospack finds amhmvs_mapping in $found, not in the install space"
  exit 1
fi
help=$(rosrun amhmvs_mapping amhmvs_depth --help) || { echo "amhmvs_depth --help failed"; exit 1; }
grep -q "^Usage: amhmvs_depth" <<< "$help" || { echo "no usage line in: $help"; exit 1; }
# Not `echo | head -1`: head closes the pipe early and pipefail fails on the SIGPIPE.
echo "${help%%$'\n'*}"

bag=$data/bags/strecha_fountain_x0.25.bag
if [ ! -f "$bag" ]; then
  echo "rostest missing_tf: skipped, no bag at $bag"
  exit 0
fi
step "rostest amhmvs_mapping missing_tf.test (install space)"
AMHMVS_DATA_DIR=$data rostest --results-base-dir "$results" amhmvs_mapping missing_tf.test \
  > "$workspace/rostest.log" 2>&1 || { tail -40 "$workspace/rostest.log"; echo "rostest failed"; exit 1; }
grep -E "RESULT|TESTS|ERRORS|FAILURES" "$workspace/rostest.log" || true
step "done"
