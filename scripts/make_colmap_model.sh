#!/usr/bin/env bash
# Builds a real, undistorted COLMAP workspace from a folder of images, for the
# COLMAP reader's tests (set AMHMVS_COLMAP_WORKSPACE=<out_dir>/dense).
#
# Usage: make_colmap_model.sh <image_dir> <out_dir>
# Result: <out_dir>/dense/images/ (undistorted images) and <out_dir>/dense/sparse/
# holding the same model twice: binary (cameras.bin, ...) and text (cameras.txt, ...).
# CPU only (no GPU, no display), so it runs on any CI machine with `colmap`.
set -euo pipefail

if [[ $# -ne 2 ]]; then
  echo "usage: $0 <image_dir> <out_dir>" >&2
  exit 2
fi
image_dir=$(realpath "$1")
out_dir=$2
if ! command -v colmap >/dev/null; then
  echo "error: colmap not found (Debian/Ubuntu: apt-get install colmap)" >&2
  exit 1
fi
if [[ ! -d "$image_dir" ]]; then
  echo "error: image folder '$image_dir' does not exist" >&2
  exit 1
fi
# COLMAP links Qt even for command-line tools; no display is needed.
export QT_QPA_PLATFORM=offscreen

mkdir -p "$out_dir"
out_dir=$(realpath "$out_dir")
db="$out_dir/database.db"
rm -rf "$db" "$out_dir/sparse_raw" "$out_dir/dense"
mkdir -p "$out_dir/sparse_raw"

# One shared camera: every test set here comes from a single physical camera,
# and a shared calibration makes the reconstruction more stable.
colmap feature_extractor --database_path "$db" --image_path "$image_dir" \
  --ImageReader.single_camera 1 --SiftExtraction.use_gpu 0
colmap exhaustive_matcher --database_path "$db" --SiftMatching.use_gpu 0
colmap mapper --database_path "$db" --image_path "$image_dir" \
  --output_path "$out_dir/sparse_raw"
if [[ ! -f "$out_dir/sparse_raw/0/cameras.bin" ]]; then
  echo "error: mapper produced no model in $out_dir/sparse_raw/0" >&2
  exit 1
fi
# Undistortion turns the camera into PINHOLE, the only models the reader takes.
colmap image_undistorter --image_path "$image_dir" --input_path "$out_dir/sparse_raw/0" \
  --output_path "$out_dir/dense" --output_type COLMAP
# The text copy sits next to the binary one so tests can compare the two.
colmap model_converter --input_path "$out_dir/dense/sparse" \
  --output_path "$out_dir/dense/sparse" --output_type TXT
echo "COLMAP workspace ready: $out_dir/dense"
