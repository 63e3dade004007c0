#!/usr/bin/env bash
# First run: installs what is missing, builds, renders the built-in synthetic
# room (no download), estimates a depth map per view with AMHMVS (on the GPU if
# there is one, else on the CPU) and reports accuracy against the exact
# ground truth. Outputs go to OUT (default: ./out/demo).
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
out=${1:-$here/out/demo}
export PATH=/usr/bin:/bin:/usr/sbin:/sbin:/usr/local/cuda/bin:$PATH
build=${AMHMVS_BUILD_DIR:-$here/build}
bin=$build/devel/lib/amhmvs_mapping

"$here/scripts/install_dependencies.sh"
"$here/scripts/build.sh"
rm -rf "$out"
"$bin/amhmvs_synthetic" "$out/scene" --scene room --views 8 --width 320 --height 240
"$bin/amhmvs_depth" "$out/scene" "$out/depth" --num_sources 4 --ground_truth "$out/scene/depth_gt"
echo
echo "demo outputs in $out:"
echo "  $out/scene/       the synthetic views (MVSNet dense folder, ground truth in depth_gt/)"
echo "  $out/depth/NNNNNNNN/depth.png   colour-mapped depth maps (depth.pfm: metres)"
