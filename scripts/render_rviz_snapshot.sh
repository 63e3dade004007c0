#!/usr/bin/env bash
# Renders a saved map (PLY) as rviz shows it, headless, into a PNG: starts Xvfb
# on a free display, a ROS master on a free port, publishes the PLY as a
# latched PointCloud2 (scripts/publish_ply.py; a mesh PLY's triangles also as a
# Marker, which rviz/demo_mesh.rviz shows) and starts rviz with
# rviz/demo_map.rviz (or RVIZ_CONFIG); once rviz subscribes, takes screenshots
# until two in a row agree and show more than the background, then stops
# everything it started. With --up X,Y,Z the view follows the map instead of
# the config's fixed coordinates: it looks at the map's median point, from a
# distance that fits it, with X,Y,Z (world coordinates) up on the screen
# (0,0,1 for a z-up world; 0,-1,0 for 7-Scenes, whose world is a camera frame);
# AMHMVS_VIEW_YAW / AMHMVS_VIEW_PITCH (radians) turn that view.
#
# usage: scripts/render_rviz_snapshot.sh MAP.ply OUT.png [RVIZ_CONFIG] [--up X,Y,Z]
# Needs the Debian packages xvfb, rviz, imagemagick, libgl1-mesa-dri.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
export PATH=/usr/bin:/bin:/usr/sbin:/sbin:$PATH
usage() { awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0" >&2; exit 2; }
arguments=() up=
while [ $# -gt 0 ]; do
  case $1 in
    --up) [ $# -ge 2 ] || usage; up=$2; shift 2 ;;
    *) arguments+=("$1"); shift ;;
  esac
done
[ ${#arguments[@]} -ge 2 ] && [ ${#arguments[@]} -le 3 ] || usage
map=${arguments[0]} png=${arguments[1]} config=${arguments[2]:-$here/rviz/demo_map.rviz}
[ -f "$map" ] || { echo "render_rviz_snapshot: no map at $map" >&2; exit 1; }
timeout_s=${AMHMVS_SNAPSHOT_TIMEOUT:-120}

work=$(mktemp -d)
pids=()
cleanup() {
  for pid in "${pids[@]}"; do kill "$pid" 2>/dev/null || true; done
  for pid in "${pids[@]}"; do wait "$pid" 2>/dev/null || true; done
  rm -rf "$work"
}
trap cleanup EXIT

# wait_for SECONDS WHAT COMMAND...: polls COMMAND every 0.5 s.
wait_for() {
  local seconds=$1 what=$2
  shift 2
  local deadline=$((SECONDS + seconds))
  until "$@" >/dev/null 2>&1; do
    if [ $SECONDS -ge $deadline ]; then
      echo "render_rviz_snapshot: timed out after $seconds s waiting for $what (logs: $work, kept)" >&2
      trap - EXIT
      for pid in "${pids[@]}"; do kill "$pid" 2>/dev/null || true; done
      exit 1
    fi
    sleep 0.5
  done
}

# Xvfb picks a free display itself and writes its number to fd 3.
Xvfb -displayfd 3 -screen 0 1024x720x24 +extension GLX -nolisten tcp 3>"$work/display" >"$work/xvfb.log" 2>&1 &
pids+=($!)
wait_for 20 "Xvfb to start" test -s "$work/display"
export DISPLAY=:$(cat "$work/display") LIBGL_ALWAYS_SOFTWARE=1

port=$(python3 -c 'import socket; s = socket.socket(); s.bind(("", 0)); print(s.getsockname()[1])')
export ROS_MASTER_URI=http://localhost:$port ROS_HOME=$work/ros_home
roscore -p "$port" >"$work/roscore.log" 2>&1 &
pids+=($!)
wait_for 30 "the ROS master" rosparam list

if [ -n "$up" ]; then
  python3 "$here/scripts/map_view_rviz_config.py" "$config" "$work/follow.rviz" "$map"
  config=$work/follow.rviz
fi
python3 "$here/scripts/publish_ply.py" "$map" cloud:=/amhmvs_demo/map mesh:=/amhmvs_demo/mesh _up:="${up:-0,0,1}" \
  >"$work/publish.log" 2>&1 &
pids+=($!)
publisher=$!
published() {
  kill -0 "$publisher" 2>/dev/null || { echo "render_rviz_snapshot: publish_ply.py failed:" >&2; tail -5 "$work/publish.log" >&2; exit 1; }
  grep -q "published" "$work/publish.log"
}
wait_for 120 "the map to be published" published
rviz -d "$config" >"$work/rviz.log" 2>&1 &
pids+=($!)
subscribed() {
  for topic in /amhmvs_demo/map /amhmvs_demo/mesh; do
    rostopic info "$topic" 2>/dev/null | sed -n '/Subscribers:/,$p' | grep -q rviz && return 0
  done
  return 1
}
wait_for 60 "rviz to subscribe to the map" subscribed

# Drawn: two screenshots 1 s apart agree (but for the frame-rate counter,
# under 0.5 % of the pixels) and show more than a blank screen.
drawn() {
  sleep 1
  /usr/bin/import -window root "$work/shot.png" 2>/dev/null || return 1
  python3 - "$work/shot.png" "$work/previous.png" <<'PY'
import os, sys
import cv2, numpy as np
shot = cv2.imread(sys.argv[1])
previous = cv2.imread(sys.argv[2]) if os.path.exists(sys.argv[2]) else None
os.replace(sys.argv[1], sys.argv[2])
colours = len(np.unique(shot.reshape(-1, 3), axis=0))
changed = 1.0 if previous is None or previous.shape != shot.shape else np.mean(np.any(shot != previous, axis=2))
sys.exit(0 if colours > 200 and changed < 0.005 else 1)
PY
}
wait_for "$timeout_s" "rviz to draw the map" drawn
mkdir -p "$(dirname "$png")"
cp "$work/previous.png" "$png"
echo "rviz picture of $map: $png"
