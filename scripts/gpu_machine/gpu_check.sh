#!/usr/bin/env bash
# Builds the ROS-free core with nvcc and runs every GPU check in one call, on
# the GPU machine (no ROS, no OpenCV C++ there):
#   1. prepare the carried real data (scripts/gpu_machine/prepare_gpu_data.py),
#   2. build (CMake, AMHMVS_CORE_ONLY, sm_90 unless AMHMVS_CUDA_ARCHITECTURES),
#   3. compiler resource report (registers, stack, spills),
#   4. GPU tests: texture emulation, determinism, CPU/GPU agreement, accuracy,
#   5. compute-sanitizer memcheck and racecheck on a small scene,
#   6. the benchmark table (estimator, fusion, online pipeline, memory replay),
#   7. "baseline": the code of AMHMVS_BASELINE_TAR (a `git archive` of an
#      earlier commit) built too; both amhmvs_depth binaries on the GPU:
#      depth/normal/cost cmp-equal, and "depthwall": wall time per depth map
#      of amhmvs_depth with all its outputs (fountain x0.25, x0.5, x1 and a
#      640x480 synthetic room folder), median of 3 runs of the program.
# Local use:  scripts/gpu_machine/stage_gpu_data.sh, then through the device tool:
#   bash scripts/gpu_machine/gpu_check.sh   (with carry: [".gpu_data"])
# Results land in $OUT (or ./gpu_results).
set -uo pipefail
here=$(cd "$(dirname "$0")/../.." && pwd)
out=${OUT:-$here/gpu_results}
mkdir -p "$out"
data=/tmp/amhmvs_gpu_data
arch=${AMHMVS_CUDA_ARCHITECTURES:-90}
steps=${AMHMVS_GPU_STEPS:-"tests sanitize bench"}  # also: baseline depthwall profile variants planar
status=0

nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader | tee "$out/device.txt"
if [ ! -d "$data" ]; then
  python3 "$here/scripts/gpu_machine/prepare_gpu_data.py" "$here/.gpu_data" "$data" || exit 1
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
    --section ComputeWorkloadAnalysis --section WarpStateStats --section SchedulerStats \
    --section InstructionStats --section SourceCounters \
    "$bin/amhmvs_benchmark" "$data" --only fountain_x0.25 --runs 1 > "$out/ncu.txt" 2>&1
  cuobjdump -sass $(find /tmp/amhmvs_build -name 'cuda_backend.cu.o' | head -1) > "$out/sass.txt" 2>&1
  grep -vE "^==PROF==|^ +-+ " "$out/ncu.txt" | grep -E "Throughput|Occupancy|Registers|Stack|Warp Cycles|Stall|L1|L2|DRAM|Duration|Pipe|Texture|Eligible|Issued|Block Limit|Local" | head -60
fi
if [[ " $steps " == *" variants "* ]]; then
  # Compile-time variants of the update kernel, built in parallel, then timed
  # one after the other. AMHMVS_VARIANTS: "name=nvcc-flags;name=flags;..."
  # (default: rows of the matching window per loop trip, and a register cap).
  variants=${AMHMVS_VARIANTS:-"rows1=-DAMHMVS_WINDOW_ROW_UNROLL=1;rows2=-DAMHMVS_WINDOW_ROW_UNROLL=2;rows3=-DAMHMVS_WINDOW_ROW_UNROLL=3;rows6=-DAMHMVS_WINDOW_ROW_UNROLL=6;rows2_b5=-DAMHMVS_UPDATE_MIN_BLOCKS=5"}
  echo "== variants: update kernel =="
  IFS=';' read -ra specs <<< "$variants"
  for spec in "${specs[@]}"; do
    name=${spec%%=*}; flags=${spec#*=}; vb=/tmp/amhmvs_build_v_$name
    ( cmake -S "$here" -B $vb -DAMHMVS_CORE_ONLY=ON -DCMAKE_BUILD_TYPE=Release -DAMHMVS_CUDA_ARCHITECTURES="$arch" \
        -DCMAKE_CUDA_FLAGS="-Xptxas -v $flags" > /dev/null 2>&1 &&
      cmake --build $vb -j 4 --target amhmvs_benchmark > "$out/build_v_$name.log" 2>&1 || echo "build of $name failed" ) &
  done
  wait
  for spec in "${specs[@]}"; do
    name=${spec%%=*}; flags=${spec#*=}; vb=/tmp/amhmvs_build_v_$name
    echo "-- $name ($flags): $(grep -A2 'Function properties for.*updateKernel.*FixedWindow' "$out/build_v_$name.log" | grep -oE '[0-9]+ bytes spill stores|Used [0-9]+ registers' | tr '\n' ' ')"
    [ -x $vb/amhmvs_benchmark ] && $vb/amhmvs_benchmark "$data" --only fountain_x0.25 --runs 5 --out /dev/null | grep fountain
  done
fi
if [[ " $steps " == *" baseline "* ]]; then
  # The earlier code, built alongside (amhmvs_depth only).
  echo "== baseline build =="
  # Both folders fresh: the tar's files keep their commit times, which can be
  # older than a warm machine's objects from another baseline.
  rm -rf /tmp/amhmvs_base /tmp/amhmvs_base_build && mkdir -p /tmp/amhmvs_base
  tar -xzf "${AMHMVS_BASELINE_TAR:-$here/.baseline.tar.gz}" -C /tmp/amhmvs_base || { echo "FAIL  no baseline tar"; status=1; }
  cmake -S /tmp/amhmvs_base -B /tmp/amhmvs_base_build -DAMHMVS_CORE_ONLY=ON -DCMAKE_BUILD_TYPE=Release \
    -DAMHMVS_CUDA_ARCHITECTURES="$arch" > "$out/cmake_base.log" 2>&1 && \
  cmake --build /tmp/amhmvs_base_build -j 16 --target amhmvs_depth > "$out/build_base.log" 2>&1 || { echo "FAIL  baseline build"; status=1; }
  echo "== GPU depth maps: this code vs the baseline (fountain x0.25, all views, 10 sources) =="
  rm -rf /tmp/cmp_new /tmp/cmp_base
  "$bin/amhmvs_depth" "$data/mvsnet/fountain_x0.25" /tmp/cmp_new --backend cuda --quiet
  /tmp/amhmvs_base_build/amhmvs_depth "$data/mvsnet/fountain_x0.25" /tmp/cmp_base --backend cuda --quiet
  differ=0
  for f in /tmp/cmp_base/*/depth.pfm /tmp/cmp_base/*/normal.pfm /tmp/cmp_base/*/cost.pfm /tmp/cmp_base/*/depth.png; do
    cmp -s "$f" "/tmp/cmp_new/${f#/tmp/cmp_base/}" || { echo "differs: ${f#/tmp/cmp_base/}"; differ=1; }
  done
  n=$(ls /tmp/cmp_base/*/depth.pfm | wc -l)
  [ $differ = 0 ] && [ "$n" -gt 0 ] && echo "PASS  GPU outputs identical to the baseline ($n views x depth, normal, cost, png)" \
    || { echo "FAIL  GPU outputs differ from the baseline"; status=1; }
fi
if [[ " $steps " == *" depthwall "* ]]; then
  echo "== amhmvs_depth wall time per depth map (all outputs written; median of ${AMHMVS_WALL_RUNS:-3} runs) =="
  if [ ! -d /tmp/synthetic_640 ]; then  # rendered as PNG, read here as PPM (no PNG decoder in this build)
    "$bin/amhmvs_synthetic" /tmp/synthetic_640_png --scene room --views 11 --width 640 --height 480 > /dev/null && \
    python3 -c "import sys; sys.path.insert(0, '$here/scripts/gpu_machine'); import prepare_gpu_data as p; \
p.convert_dense_folder('/tmp/synthetic_640_png', '/tmp/synthetic_640')"
  fi
  walltime() {  # program folder extra-args... -> median ms per map
    local program=$1 folder=$2; shift 2
    local times=()
    for run in $(seq ${AMHMVS_WALL_RUNS:-3}); do
      rm -rf /tmp/wall_out
      local t0=$(date +%s%N)
      "$program" "$folder" /tmp/wall_out --backend cuda --quiet "$@" || return 1
      local t1=$(date +%s%N)
      local maps=$(ls /tmp/wall_out | wc -l)
      times+=($(( (t1 - t0) / 1000 / maps )))
    done
    printf '%s\n' "${times[@]}" | sort -n | sed -n "$(( (${#times[@]} + 1) / 2 ))p" | awk '{printf "%.1f", $1 / 1000}'
  }
  echo "| input | maps | baseline ms/map | this code ms/map | target (2x ACMH) |"
  echo "|---|---|---|---|---|"
  for row in "fountain_x0.25|$data/mvsnet/fountain_x0.25|43|" "fountain_x0.5|$data/mvsnet/fountain_x0.5|136|" \
             "fountain_x1|$data/mvsnet/fountain_x1|564|" "synthetic 640x480 room, 4 sources|/tmp/synthetic_640|43|--num_sources 4"; do
    IFS='|' read -r name folder target extra <<< "$row"
    [ -d "$folder" ] || { echo "| $name | missing | | | |"; continue; }
    maps=$(ls "$folder/cams" | wc -l)
    base=$( [ -x /tmp/amhmvs_base_build/amhmvs_depth ] && walltime /tmp/amhmvs_base_build/amhmvs_depth "$folder" $extra || echo "-")
    new=$(walltime "$bin/amhmvs_depth" "$folder" $extra || echo "failed")
    echo "| $name | $maps | $base | $new | <= $target |"
  done | tee "$out/depth_wall.md"
  echo "where the time goes (this code, one more run each):"
  for folder in "$data/mvsnet/fountain_x0.25" "$data/mvsnet/fountain_x0.5" "$data/mvsnet/fountain_x1" /tmp/synthetic_640; do
    extra=""; [ "$folder" = /tmp/synthetic_640 ] && extra="--num_sources 4"
    [ -d "$folder" ] && "$bin/amhmvs_depth" "$folder" /tmp/wall_out --backend cuda $extra 2>&1 | grep "ms in all" \
      | sed "s|^|  $(basename $folder): |" | tee -a "$out/depth_wall.md"
  done
fi
if [[ " $steps " == *" planar "* ]]; then
  # The planar prior (mvs/planar_prior.h) against none: Middlebury dev pooled
  # (two views each, --views 0,1), two scales with one finer iteration,
  # photometric and with --geometric; the fountain's estimator time per map
  # from amhmvs_depth's summary line (its accuracy: the GPU tests).
  echo "== planar prior =="
  {
    echo "| set | mode | planar prior | within 1 / 2 / 5 % | estimating ms per map |"
    echo "|---|---|---|---|---|"
    for mode in "" "--geometric"; do
      for prior in false true; do
        pooled=$(for scene in Adirondack Motorcycle Piano Playtable; do
          "$bin/amhmvs_depth" "$data/mvsnet/middlebury2014_$scene" /tmp/planar_out --backend cuda --num_sources 1 \
            --multiscale 2 --multiscale_iterations 1 --views 0,1 --ground_truth "$data/middlebury2014/$scene" \
            --planar_prior $prior $mode 2>&1 | grep "depth accuracy"
        done | python3 -c '
import re, sys
n = 0; s = [0.0, 0.0, 0.0]
for line in sys.stdin:
    m = re.search(r"\((\d+) pixels\): within 1/2/5 %: ([\d.]+) / ([\d.]+) / ([\d.]+)", line)
    k = int(m.group(1)); n += k
    for i in range(3): s[i] += k * float(m.group(i + 2))
print(" / ".join("%.2f" % (v / n) for v in s))')
        echo "| Middlebury dev (4) | ${mode:-photometric} | $prior | $pooled | |"
        line=$("$bin/amhmvs_depth" "$data/mvsnet/fountain_x0.25" /tmp/planar_out --backend cuda --multiscale 2 \
          --multiscale_iterations 1 --planar_prior $prior $mode 2>&1)
        per_map=$(echo "$line" | grep -o "[0-9]* estimating" | head -1 | awk '{printf "%.1f", $1 / 11}')
        echo "| fountain x0.25 (11 maps, 10 sources) | ${mode:-photometric} | $prior | | $per_map |"
      done
    done
  } | tee "$out/planar_prior.md"
fi
if [[ " $steps " == *" bench "* ]]; then
  echo "== benchmark =="
  "$bin/amhmvs_benchmark" "$data" --out "$out/benchmark.md" --runs 5 --cpu-threads 2 ${AMHMVS_BENCH_FLAGS:-} || status=1
fi
exit $status
