#!/usr/bin/env bash
# The README's first command. Installs what is missing, builds, renders a
# synthetic indoor sequence with exact ground truth (no download), writes it as
# a ROS bag, plays it through the mapping nodelet with roslaunch + rosbag play
# (headless; CUDA when usable, else the CPU at 320x240), prints a line per
# keyframe and a summary, and writes the nodelet's global map (PLY, through its
# ~save_map service), colour-mapped depth images and, when Xvfb is installed,
# a PNG of the map as rviz shows it.
#
# usage: scripts/demo.sh [OUT_DIR] [options]      (OUT_DIR default: ./out/demo)
#   --views N        frames of the sequence (default 10)
#   --size WxH       image size (default 320x240)
#   --seed S         scene and trajectory seed (default 1)
#   --rviz           also open rviz with the shipped config (needs a display);
#                    it stays open after the summary: close it to go on
#   --no-snapshot    skip the headless rviz picture
#   --skip-build     do not install or build when the programs are already built
#   --timeout S      wall seconds the mapping may take (default 900)
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
export PATH=/usr/bin:/bin:/usr/sbin:/sbin:/usr/local/cuda/bin:$PATH
build=${AMHMVS_BUILD_DIR:-$here/build}
bin=$build/devel/lib/amhmvs_mapping

out=$here/out/demo views=10 size=320x240 seed=1 rviz=false snapshot=true skip_build=false timeout=900
while [ $# -gt 0 ]; do
  case $1 in
    --views) views=$2; shift 2 ;;
    --size) size=$2; shift 2 ;;
    --seed) seed=$2; shift 2 ;;
    --rviz) rviz=true; shift ;;
    --no-snapshot) snapshot=false; shift ;;
    --skip-build) skip_build=true; shift ;;
    --timeout) timeout=$2; shift 2 ;;
    -h|--help) awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0"; exit 0 ;;
    -*) echo "demo.sh: unknown option $1 (--help lists them)" >&2; exit 2 ;;
    *) out=$1; shift ;;
  esac
done
if [ "$rviz" = true ] && [ -z "${DISPLAY:-}" ]; then
  echo "demo.sh: --rviz needs a display (DISPLAY is not set); without it the demo runs headless" >&2
  exit 2
fi
out=$(mkdir -p "$out" && cd "$out" && pwd)

if [ "$skip_build" = false ] || [ ! -x "$bin/amhmvs_mapping_node" ]; then
  "$here/scripts/install_dependencies.sh" --demo
  # Only what the demo runs: the node and nodelet, the renderer of its
  # sequence (the tests, benchmarks and other tools are the test command's).
  # A new build folder on a machine without a visible GPU is configured
  # without CUDA (it would not run; a third of the build's CPU time); the
  # test command reuses that build. AMHMVS_WITH_CUDA=ON keeps CUDA.
  if [ -z "${AMHMVS_WITH_CUDA:-}" ] && [ ! -f "$build/CMakeCache.txt" ] && ! nvidia-smi -L > /dev/null 2>&1; then
    export AMHMVS_WITH_CUDA=OFF
    echo "demo.sh: no GPU visible: a CPU-only build (AMHMVS_WITH_CUDA=ON bash scripts/build.sh adds CUDA later)"
  fi
  AMHMVS_MAKE_TARGETS="${AMHMVS_MAKE_TARGETS:-amhmvs_mapping_node amhmvs_mapping_nodelet amhmvs_synthetic amhmvs_mapping_generate_messages_py amhmvs_mapping_gencfg}" \
    "$here/scripts/build.sh"
fi

echo "== rendering the synthetic sequence ($views frames, $size, seed $seed) =="
rm -rf "$out/depth" "$out/map.ply" "$out/summary.txt" "$out/summary.json" "$out/map_rviz.png"
"$here/scripts/make_synthetic_sequence.sh" "$out" --views "$views" --size "$size" --seed "$seed"

echo "== mapping: roslaunch amhmvs_mapping demo.launch (rosbag play, nodelet, monitor) =="
set +u
source "$build/devel/setup.bash"
set -u
export ROS_PACKAGE_PATH=$here${ROS_PACKAGE_PATH:+:$ROS_PACKAGE_PATH}
export ROS_HOME=$out/ros_home
# A master of our own on a free port: no clash with a running roscore.
port=$(python3 -c 'import socket; s = socket.socket(); s.bind(("", 0)); print(s.getsockname()[1])')
export ROS_MASTER_URI=http://localhost:$port
# rviz (--rviz): the shipped config, its view moved onto the room.
python3 "$here/scripts/room_view_rviz_config.py" "$here/rviz/amhmvs_mapping.rviz" "$out/rviz_live.rviz"
# The console gets the progress lines, the summary, warnings and errors; the
# whole roslaunch output goes to mapping.log.
roslaunch -p "$port" amhmvs_mapping demo.launch bag:="$out/sequence.bag" output_dir:="$out" \
  expected_frames:="$views" timeout:="$timeout" rviz:="$rviz" rviz_config:="$out/rviz_live.rviz" 2>&1 |
  tee "$out/mapping.log" |
  grep --line-buffered -E '^(keyframe [0-9]|== |keyframes processed|time per|depth accuracy|map|depth images)|stays open|WARN|ERROR' || true
if ! grep -q '"completed": true' "$out/summary.json" 2>/dev/null; then
  echo "demo.sh: the mapping run did not complete (log: $out/mapping.log)" >&2
  exit 1
fi

if [ "$snapshot" = true ]; then
  if command -v Xvfb >/dev/null && command -v rviz >/dev/null; then
    echo "== rviz picture of the map (headless) =="
    "$here/scripts/render_rviz_snapshot.sh" "$out/map.ply" "$out/map_rviz.png"
  else
    echo "(no rviz picture: install xvfb and rviz, or run scripts/install_dependencies.sh)"
  fi
fi

echo
echo "demo outputs in $out:"
echo "  summary.txt, summary.json   keyframes, ms per keyframe, depth accuracy, map size"
echo "  map.ply                     the map: the nodelet's fused voxel map (world frame), saved by ~save_map"
echo "  depth/NNNN.png              colour-mapped depth per keyframe: estimate | ground truth"
[ -f "$out/map_rviz.png" ] && echo "  map_rviz.png                the map as rviz shows it"
echo "  sequence.bag, scene/        the synthetic sequence (bag with /camera/depth_gt; MVSNet dense folder)"
