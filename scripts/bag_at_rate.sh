#!/usr/bin/env bash
# Plays a bag at its recorded rate through launch/mapping.launch (the shipped
# config, CPU backend unless told otherwise) and watches the nodelet:
#   scripts/bag_at_rate.sh BAG OUT.json [roslaunch args, e.g. queue_size:=4]
# OUT.json holds the depth images and map sizes against wall time and the
# last diagnostics; a line is printed: frames, depth images (during the bag),
# the map's voxels, the final status. Needs the build (scripts/build.sh) and
# a free ROS master port 11411. Not part of the test suite (wall-clock rates).
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
[ $# -ge 2 ] || { sed -n 2,9p "$0"; exit 2; }
bag=$(realpath "$1"); out=$(realpath -m "$2"); shift 2
[ -f "$bag" ] || { echo "bag_at_rate: no bag at $bag" >&2; exit 1; }
export PATH=/usr/bin:/bin:$PATH
set +u; source "$here/build/devel/setup.bash"; set -u
export ROS_PACKAGE_PATH=$here${ROS_PACKAGE_PATH:+:$ROS_PACKAGE_PATH}
export ROS_MASTER_URI=http://localhost:11411 ROS_HOME=${ROS_HOME:-/tmp/amhmvs_bag_at_rate}
mkdir -p "$(dirname "$out")"
roscore -p 11411 > "$out.roscore.log" 2>&1 &
core=$!
trap 'kill $core 2>/dev/null || true' EXIT
sleep 3
roslaunch --wait amhmvs_mapping mapping.launch bag:="$bag" delay:=6 backend:=cpu "$@" > "$out.launch.log" 2>&1 &
launch=$!
python3 "$here/scripts/watch_mapping.py" "$out" 300
kill -INT $launch 2>/dev/null || true
wait $launch 2>/dev/null || true
