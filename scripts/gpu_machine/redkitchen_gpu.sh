#!/usr/bin/env bash
# On the GPU machine (staged by stage_map_gpu.sh with REDKITCHEN_FRAMES):
# amhmvs_map on redkitchen at full size on the GPU, at KinectFusion's and the
# odometry's poses, with each setting of SETTINGS (one per line, "name: flags";
# default: the temporal depth filter off and on), against the Kinect depth:
# the published depth, the voxel map and the surface map's mesh.
T=$(cd "$(dirname "$0")" && pwd)
out=${OUT:-$T/out}
maps=$(mktemp -d /tmp/redkitchen_maps.XXXXXX)
mkdir -p "$out"
export LD_LIBRARY_PATH=$T/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
device=$(nvidia-smi --query-gpu=name,driver_version --format=csv,noheader 2>&1 | head -1)
settings=${SETTINGS:-"filter off: --set depth_filter/enabled=false
filter on: --set depth_filter/enabled=true"}
common="--backend cuda --intrinsics fitted7scenes --color_offset=-0.010,0,0 --quiet ${EXTRA:-}"
poses="kinectfusion"
[ -f "$T/data/redkitchen_odometry.txt" ] && poses="$poses odometry"
{
  echo "Device: $device. amhmvs_map ../shared/data/redkitchen_7scenes (first frames staged) OUT $common"
  echo
  echo "| poses | setting | wall s | published: within 5 %, completeness | of all Kinect pixels within 5 % | map points, within 5 cm, Kinect surface covered within 5 cm | mesh vertices, within 5 cm, covered within 5 cm |"
  echo "|---|---|---|---|---|---|---|"
} > "$out/redkitchen_gpu.md"
for pose in $poses; do
  trajectory=""
  [ "$pose" = odometry ] && trajectory="--trajectory $T/data/redkitchen_odometry.txt"
  while IFS= read -r line; do
    [ -z "$line" ] && continue
    name=${line%%:*}
    flags=${line#*:}
    file=$(tr -c 'A-Za-z0-9_\n' '_' <<< "${pose}_${name}")
    log="$out/$file.log"
    start=$(date +%s)
    # shellcheck disable=SC2086
    "$T/bin/amhmvs_map" "$T/data/redkitchen" "$maps/$file" $common $trajectory $flags > "$log" 2>&1 \
      || { tail -5 "$log"; continue; }
    wall=$(( $(date +%s) - start ))
    summary=$(grep "keyframes of" "$log")
    within=$(grep -o "published (confidence >= [0-9.]*): [0-9.]* / [0-9.]* / [0-9.]*" <<< "$summary" | awk '{print $NF}')
    complete=$(grep -o "completeness [0-9.]* %; map" <<< "$summary" | grep -o "[0-9.]*")
    of_all=$(awk -v a="$within" -v b="$complete" 'BEGIN {printf "%.1f", a * b / 100}')
    maps_json=$(python3 - "$maps/$file/summary.json" <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
m, f = s["map"], s.get("surface")
cells = ["%s, %.1f %%, %.1f %%" % (m["points"], m["within_5cm_pct"], m["truth_covered"]["within_5cm_pct"])]
cells.append("%s, %.1f %%, %.1f %%" % (f["vertices"], f["within_5cm_pct"], f["truth_covered"]["within_5cm_pct"])
             if f and "within_5cm_pct" in f else "off")
print(" | ".join(cells))
PY
)
    echo "| $pose | $name | $wall | $within %, $complete % | $of_all % | $maps_json |" >> "$out/redkitchen_gpu.md"
  done <<< "$settings"
done
cat "$out/redkitchen_gpu.md"
