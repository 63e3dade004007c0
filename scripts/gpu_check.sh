#!/usr/bin/env bash
# Builds the ROS-free core with nvcc and runs every GPU check in one call, on
# the GPU machine (no ROS, no OpenCV C++ there):
#   1. prepare the carried real data (scripts/prepare_gpu_data.py),
#   2. build (CMake, AMHMVS_CORE_ONLY, sm_90 unless AMHMVS_CUDA_ARCHITECTURES),
#   3. compiler resource report (registers, stack, spills),
#   4. GPU tests: texture emulation, determinism, CPU/GPU agreement, accuracy,
#   5. compute-sanitizer memcheck and racecheck on a small scene,
#   6. the benchmark table.
# Local use:  scripts/stage_gpu_data.sh, then through the device tool:
#   bash scripts/gpu_check.sh   (with carry: [".gpu_data"])
# Results land in $OUT (or ./gpu_results).
set -uo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
out=${OUT:-$here/gpu_results}
mkdir -p "$out"
data=/tmp/amhmvs_gpu_data
arch=${AMHMVS_CUDA_ARCHITECTURES:-90}
steps=${AMHMVS_GPU_STEPS:-"tests sanitize bench"}
status=0

nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader | tee "$out/device.txt"
if [ ! -d "$data" ]; then
  python3 "$here/scripts/prepare_gpu_data.py" "$here/.gpu_data" "$data" || exit 1
fi
cmake -S "$here" -B /tmp/amhmvs_build -DAMHMVS_CORE_ONLY=ON -DCMAKE_BUILD_TYPE=Release \
  -DAMHMVS_CUDA_ARCHITECTURES="$arch" -DCMAKE_CUDA_FLAGS="-Xptxas -v" > "$out/cmake.log" 2>&1 || { tail -30 "$out/cmake.log"; exit 1; }
cmake --build /tmp/amhmvs_build -j 16 > "$out/build.log" 2>&1 || { grep -E "error" -A3 "$out/build.log" | head -40; exit 1; }
grep -E "Compiling entry|registers|stack frame" "$out/build.log" | grep -B1 -A1 "Kernel\|registers" \
  | sed -n '1,40p' > "$out/ptxas.txt"
echo "== compiler resource report (kernels) =="
grep -E "Function properties|Used [0-9]+ registers|spill" "$out/build.log" | head -24

bin=/tmp/amhmvs_build
if [[ " $steps " == *" tests "* ]]; then
  echo "== GPU tests =="
  "$bin/amhmvs_gpu_tests" "$data" ${AMHMVS_GPU_TEST_FLAGS:-} 2>&1 | tee "$out/gpu_tests.txt"
  [ "${PIPESTATUS[0]}" = 0 ] || status=1
fi
if [[ " $steps " == *" sanitize "* ]]; then
  for tool in memcheck racecheck; do
    echo "== compute-sanitizer $tool =="
    compute-sanitizer --tool $tool --error-exitcode 9 "$bin/amhmvs_gpu_tests" "$data" --sanitize \
      > "$out/sanitizer_$tool.txt" 2>&1
    rc=$?
    tail -3 "$out/sanitizer_$tool.txt"
    [ $rc = 0 ] && echo "PASS  compute-sanitizer $tool clean" || { echo "FAIL  compute-sanitizer $tool (rc $rc)"; status=1; }
  done
fi
if [[ " $steps " == *" profile "* ]]; then
  # Nsight Compute on one update pass of fountain x0.25 (clocks left alone).
  echo "== ncu: updateKernel, fountain x0.25 =="
  ncu --clock-control none --kernel-name regex:updateKernel --launch-skip 6 --launch-count 1 \
    --section SpeedOfLight --section Occupancy --section LaunchStats --section MemoryWorkloadAnalysis \
    --section ComputeWorkloadAnalysis --section WarpStateStats \
    "$bin/amhmvs_benchmark" "$data" --only fountain_x0.25 --runs 1 > "$out/ncu.txt" 2>&1
  grep -vE "^==PROF==|^ +-+ " "$out/ncu.txt" | grep -E "Throughput|Occupancy|Registers|Stack|Warp Cycles|Stall|L1|L2|DRAM|Duration|Pipe|Texture|Eligible|Issued|Block Limit|Local" | head -60
fi
if [[ " $steps " == *" variants "* ]]; then
  # Register caps of the update kernel (minimum resident blocks per SM).
  echo "== variants: update kernel register cap =="
  for blocks in ${AMHMVS_VARIANT_BLOCKS:-1 4 5 6}; do
    vb=/tmp/amhmvs_build_b$blocks
    cmake -S "$here" -B $vb -DAMHMVS_CORE_ONLY=ON -DCMAKE_BUILD_TYPE=Release -DAMHMVS_CUDA_ARCHITECTURES="$arch" \
      -DCMAKE_CUDA_FLAGS="-Xptxas -v -DAMHMVS_UPDATE_MIN_BLOCKS=$blocks" > /dev/null 2>&1
    cmake --build $vb -j 16 --target amhmvs_benchmark > "$out/build_b$blocks.log" 2>&1 || { echo "build failed"; continue; }
    echo "-- min blocks $blocks: $(grep -A2 'Function properties for.*updateKernel.*FixedWindow' "$out/build_b$blocks.log" | grep -oE '[0-9]+ bytes spill stores|Used [0-9]+ registers' | tr '\n' ' ')"
    $vb/amhmvs_benchmark "$data" --only fountain_x0.25 --runs 5 --out /dev/null | grep fountain
  done
fi
if [[ " $steps " == *" bench "* ]]; then
  echo "== benchmark =="
  "$bin/amhmvs_benchmark" "$data" --out "$out/benchmark.md" --runs 5 --cpu-threads 2 || status=1
fi
exit $status
