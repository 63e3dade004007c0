#!/usr/bin/env bash
# The whole test suite (what CI runs): installs missing Debian packages,
# builds, makes a real COLMAP workspace from the fountain images, then runs the
# gtest suite (unit tests, CLI tests, real-data accuracy floors) and prints
# "N passed, N failed, N skipped". GPU tests run on a GPU machine instead:
# scripts/gpu_check.sh.
#
# Real data: $AMHMVS_DATA_DIR, else ../shared/data beside the repository.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
export PATH=/usr/bin:/bin:/usr/sbin:/sbin:/usr/local/cuda/bin:$PATH
build=${AMHMVS_BUILD_DIR:-$here/build}
data=${AMHMVS_DATA_DIR:-$here/../shared/data}

"$here/scripts/install_dependencies.sh"
AMHMVS_MAKE_TARGETS="all tests" "$here/scripts/build.sh"

export AMHMVS_DATA_DIR=$data
if [ -d "$data/mvsnet/fountain_x0.25/images" ] && command -v colmap >/dev/null; then
  workspace=$build/colmap_fountain/dense
  if [ ! -f "$workspace/sparse/cameras.bin" ]; then
    echo "== making a COLMAP workspace from the fountain images (CPU SIFT) =="
    rm -rf "$build/colmap_fountain"
    "$here/scripts/make_colmap_model.sh" "$data/mvsnet/fountain_x0.25/images" "$build/colmap_fountain" \
      > "$build/colmap_fountain.log" 2>&1 || { tail -20 "$build/colmap_fountain.log"; exit 1; }
  fi
  export AMHMVS_COLMAP_WORKSPACE=$workspace
fi

echo "== unit, CLI and real-data tests =="
results=$build/test_results/amhmvs_unit_tests.xml
mkdir -p "$(dirname "$results")"
set +e
"$build/devel/lib/amhmvs_mapping/amhmvs_unit_tests" --gtest_output=xml:"$results"
status=$?
set -e
python3 - "$results" <<'PY'
import sys, xml.etree.ElementTree as ET
root = ET.parse(sys.argv[1]).getroot()
total, failed = int(root.get("tests")), int(root.get("failures")) + int(root.get("errors"))
skipped = sum(1 for case in root.iter("testcase") if case.find("skipped") is not None)
print(f"{total - failed - skipped} passed, {failed} failed, {skipped} skipped")
PY
exit $status
