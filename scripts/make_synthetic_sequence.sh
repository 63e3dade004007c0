#!/usr/bin/env bash
# Renders the synthetic indoor sequence (textured room: walls, floor, boxes, a
# ramp, a sphere, a weakly textured wall) along a smooth camera path with exact
# ground-truth depth and poses, and writes it twice: an MVSNet dense folder
# (OUT_DIR/scene, ground truth in depth_gt/) and a ROS bag (OUT_DIR/sequence.bag)
# with the topics of the bags in ../shared/data/bags plus /camera/depth_gt.
# Same options, same bytes. --realism default renders what a real camera
# behind a real tracker delivers (amhmvs_synthetic --realism: the bag's poses
# are the tracker's, the ground truth stays exact).
#
# usage: scripts/make_synthetic_sequence.sh OUT_DIR [--views N] [--size WxH] [--seed S] [--period SECONDS]
#                                           [--realism none|default]
#   defaults: 10 views, 320x240, seed 1, 0.5 s between frames, realism none
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
export PATH=/usr/bin:/bin:/usr/sbin:/sbin:$PATH
bin=${AMHMVS_BUILD_DIR:-$here/build}/devel/lib/amhmvs_mapping

usage() { awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0" >&2; exit 2; }
[ $# -ge 1 ] || usage
out=$1
shift
views=10 size=320x240 seed=1 period=0.5 realism=none
while [ $# -gt 0 ]; do
  [ $# -ge 2 ] || usage
  case $1 in
    --views) views=$2 ;;
    --size) size=$2 ;;
    --seed) seed=$2 ;;
    --period) period=$2 ;;
    --realism) realism=$2 ;;
    *) echo "make_synthetic_sequence: unknown option $1" >&2; usage ;;
  esac
  shift 2
done
[[ $size =~ ^([0-9]+)x([0-9]+)$ ]] || { echo "make_synthetic_sequence: --size must be WxH, e.g. 320x240" >&2; exit 2; }
[ -x "$bin/amhmvs_synthetic" ] || { echo "make_synthetic_sequence: $bin/amhmvs_synthetic not built (scripts/build.sh)" >&2; exit 1; }

rm -rf "$out/scene" "$out/sequence.bag"
"$bin/amhmvs_synthetic" "$out/scene" --scene room --views "$views" --width "${BASH_REMATCH[1]}" \
  --height "${BASH_REMATCH[2]}" --seed "$seed" --realism "$realism" --frame_period "$period"
python3 "$here/scripts/dense_folder_to_bag.py" "$out/scene" "$out/sequence.bag" --period "$period"
