#!/usr/bin/env bash
# Copies the real data that the GPU checks need into .gpu_data/ (git-ignored),
# which the device tool carries to the GPU machine (64 MiB limit).
set -euo pipefail
here=$(cd "$(dirname "$0")/../.." && pwd)
data=${AMHMVS_DATA_DIR:-$here/../shared/data}
rm -rf "$here/.gpu_data"
mkdir -p "$here/.gpu_data/strecha/fountain-P11"
cp -r "$data/mvsnet" "$data/middlebury2014" "$here/.gpu_data/"
rm -f "$here/.gpu_data/mvsnet/fountain_x0.25/sparse.npz"
cp -r "$data/strecha/fountain-P11/images" "$here/.gpu_data/strecha/fountain-P11/"
du -sh "$here/.gpu_data"
