#!/usr/bin/env bash
# The nodelet's soak: scripts/soak_nodelet.sh [MINUTES [OUT]] plays the
# fountain bag in a loop (rate 5: 10 frames/s) through the nodelet on the
# shipped config on the CPU at 96 px for MINUTES (default 60), with
# loop-closure pose updates every 30 s and a ~reset every 10 minutes, and
# writes OUT/soak.csv (a row every 10 s: memory, counts, the last keyframe's
# time) and OUT/summary.txt (default OUT: out/soak). Needs the build
# (scripts/build.sh) and $AMHMVS_DATA_DIR's bags; not part of the test suite.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
export PATH=/usr/bin:/bin:/usr/sbin:/sbin:$PATH
minutes=${1:-60}
out=$(realpath -m "${2:-$here/out/soak}")
data=${AMHMVS_DATA_DIR:-$here/../shared/data}
bag=$data/bags/strecha_fountain_x0.25.bag
[ -f "$bag" ] || { echo "soak_nodelet: no bag at $bag (set AMHMVS_DATA_DIR)" >&2; exit 1; }
build=${AMHMVS_BUILD_DIR:-$here/build}
[ -f "$build/devel/setup.bash" ] || { echo "soak_nodelet: no build at $build (scripts/build.sh)" >&2; exit 1; }
set +u
source "$build/devel/setup.bash"
set -u
export ROS_PACKAGE_PATH=$here${ROS_PACKAGE_PATH:+:$ROS_PACKAGE_PATH}
export ROS_HOME=${ROS_HOME:-$out/ros_home}
mkdir -p "$out"
echo "soak_nodelet: $minutes min into $out (log: $out/launch.log)"
roslaunch --port 11390 amhmvs_mapping soak.launch bag:="$bag" out:="$out" minutes:="$minutes" > "$out/launch.log" 2>&1 ||
  { tail -20 "$out/launch.log"; exit 1; }
[ -f "$out/summary.txt" ] && cat "$out/summary.txt" || echo "soak_nodelet: no summary (shorter than the 5-minute warm-up)"
