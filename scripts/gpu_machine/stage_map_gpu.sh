#!/usr/bin/env bash
# Stages amhmvs_map as built here by catkin (CUDA, OpenCV, Ceres: the pose
# refinement that the core-only GPU build lacks) for the GPU machine, with
# its libraries (scripts/gpu_machine/library_closure.py) and issue 12's realism room, and
# a run script that maps the room there offline and in real time and judges
# both maps against the true surface.
#
#   bash scripts/gpu_machine/stage_map_gpu.sh [OUT_DIR]      (default: ./build-gpu-map, git-ignored)
#   device tool, carry OUT_DIR:  bash OUT_DIR/run.sh     (tables and logs in $OUT)
# With REDKITCHEN_FRAMES=N it also stages the first N frames of
# ../shared/data/redkitchen_7scenes and REDKITCHEN_TRAJECTORY (amhmvs_odometry's,
# optional), and RUN=redkitchen.sh OUT_DIR/run.sh maps them there with and
# without the temporal depth filter (redkitchen.sh says which settings).
#
# Build first (scripts/build.sh with nvcc: the catkin build has sm_90).
set -euo pipefail
here=$(cd "$(dirname "$0")/../.." && pwd)
export PATH=/usr/bin:/bin:/usr/sbin:/sbin:$PATH
devel=${AMHMVS_BUILD_DIR:-$here/build}/devel
out=$(mkdir -p "${1:-$here/build-gpu-map}" && cd "${1:-$here/build-gpu-map}" && pwd)
work=$(mktemp -d /tmp/stage_map_gpu.XXXXXX)
trap 'rm -rf "$work"' EXIT
tree=$work/mapgpu
mkdir -p "$tree"/{bin,lib,data}
programs="amhmvs_map amhmvs_cloud_metrics"  # staged; amhmvs_synthetic runs here only

for p in $programs amhmvs_synthetic; do
  [ -x "$devel/lib/amhmvs_mapping/$p" ] || { echo "missing $devel/lib/amhmvs_mapping/$p: build first" >&2; exit 1; }
done
for p in $programs; do cp "$devel/lib/amhmvs_mapping/$p" "$tree/bin/"; done
cp "$devel"/lib/libamhmvs_{core,io,mvs,mapping}.so "$tree/lib/"
python3 "$here/scripts/gpu_machine/library_closure.py" "$tree" "$devel/lib" "$tree"/bin/* \
  --stub libgdal.so.32 --stub libgdcmMSFF.so.3.0 --stub libgdcmDSED.so.3.0 --returning GDALAllRegister

echo "== the realism room (8 views, default profile) and its true cameras as a dense folder"
room=$tree/data/room8
"$devel/lib/amhmvs_mapping/amhmvs_synthetic" "$room" --scene room --views 8 --realism default > "$work/synthetic.log" 2>&1
mkdir -p "$tree/data/truth"
cp -r "$room/cams_gt" "$tree/data/truth/cams"
ln -s ../room8/images "$tree/data/truth/images"
[ -f "$room/pair.txt" ] && cp "$room/pair.txt" "$tree/data/truth/"

if [ -n "${REDKITCHEN_FRAMES:-}" ]; then
  echo "== redkitchen: the first $REDKITCHEN_FRAMES frames"
  source_dir=${AMHMVS_DATA_DIR:-$here/../shared/data}/redkitchen_7scenes
  mkdir -p "$tree/data/redkitchen"
  cp "$source_dir/camera-intrinsics.txt" "$tree/data/redkitchen/"
  ls "$source_dir" | grep '^frame-' | sort | head -$((3 * REDKITCHEN_FRAMES)) \
    | while read -r f; do cp "$source_dir/$f" "$tree/data/redkitchen/"; done
  [ -n "${REDKITCHEN_TRAJECTORY:-}" ] && cp "$REDKITCHEN_TRAJECTORY" "$tree/data/redkitchen_odometry.txt"
  cp "$here/scripts/gpu_machine/redkitchen_gpu.sh" "$tree/redkitchen.sh"
fi

cat > "$tree/run.sh" <<'EOF'
#!/usr/bin/env bash
# The realism room mapped on the GPU with the tracker settings of the
# realism rostest, offline and fed at the recording's rate (--realtime 1,
# queue 8, as the rostest plays its bag), each map against the true surface.
# BACKEND=cpu: the same on the CPU, for comparison.
T=$(cd "$(dirname "$0")" && pwd)
out=${OUT:-$T/out}  # the table and the logs; the maps stay in $maps
maps=$(mktemp -d /tmp/mapgpu_maps.XXXXXX)
mkdir -p "$out"
export LD_LIBRARY_PATH=$T/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
if [ "${BACKEND:-cuda}" = cpu ]; then
  device="CPU, $(nproc) cores"
else
  device=$(nvidia-smi --query-gpu=name,driver_version --format=csv,noheader 2>&1 | head -1)
fi
settings="--backend ${BACKEND:-cuda} --num_sources 4 --pose_refinement --frame_period 0.5 --rolling_shutter_s 0.025
  --pose_refinement_correct_map_poses=1 --fuse_neighbours_again"
{
  echo "Device: $device. amhmvs_map $settings"
  echo
  echo "| feed | keyframes | fused again | map points | within 1 / 2 / 5 cm |"
  echo "|---|---|---|---|---|"
} > "$out/realism_gpu.md"
for feed in offline "--realtime 1 --queue_size 8"; do
  name=${feed// /_}
  # shellcheck disable=SC2086
  "$T/bin/amhmvs_map" "$T/data/room8" "$maps/$name" $settings $( [ "$feed" = offline ] || echo "$feed" ) \
    > "$out/map_$name.log" 2>&1 || { tail -5 "$out/map_$name.log"; exit 1; }
  summary=$(grep "keyframes of" "$out/map_$name.log")
  metrics=$("$T/bin/amhmvs_cloud_metrics" "$maps/$name/map.ply" --gt_depth_dir "$T/data/room8/depth_gt" \
    --cams "$T/data/truth" --thresholds 0.01,0.02,0.05 | awk '$1 ~ /^0\.0/ {printf "%s / ", $2}')
  points=$(grep -o "map [0-9]* points" <<< "$summary" | grep -o "[0-9]*")
  echo "| $feed | $(grep -o "[0-9]* new, [0-9]* late, [0-9]* refined" <<< "$summary") |" \
    "$(grep -o "[0-9]* fused again" <<< "$summary" | grep -o "[0-9]*") | $points | ${metrics% / } |" >> "$out/realism_gpu.md"
done
cat "$out/realism_gpu.md"
EOF
chmod +x "$tree/run.sh"

echo "== archive"
tar -C "$work" -cf - mapgpu | xz -T2 -6 > "$out/mapgpu.tar.xz"
cat > "$out/run.sh" <<'EOF'
#!/usr/bin/env bash
# On the GPU machine: unpack the staged programs and run their check.
set -euo pipefail
S=$(cd "$(dirname "$0")" && pwd)
tar xJf "$S/mapgpu.tar.xz" -C /tmp
exec /tmp/mapgpu/${RUN:-run.sh}
EOF
chmod +x "$out/run.sh"
ls -l "$out/mapgpu.tar.xz"
