#!/usr/bin/env bash
# GPU runs without building on the GPU machine: the programs are built here
# (core only, sm_90, without OpenCV, as scripts/gpu_machine/gpu_check.sh builds them
# there) and carried with the prepared real data, so that a call spends its
# device time measuring (session 7: a call of three pipeline runs took 20 s).
#
#   scripts/gpu_machine/gpu_prebuilt.sh stage [BASE_COMMIT]   here: fills build-gpu-stage/ (git-ignored)
#   bash build-gpu-stage/gpu_prebuilt.sh run STEP...   there (device tool, carry: build-gpu-stage)
#
# STEPs (V = new, this checkout, or base, BASE_COMMIT built alongside):
#   pipe:V[:ENV=VALUE]  amhmvs_benchmark --only pipeline (BENCH_ONLY=... for other sections,
#                       BENCH_ARGS=... for more options, e.g. "--pipeline-multiscale 2,1")
#   replay:V:N          amhmvs_benchmark --only replay --replay N (host and device memory; BENCH_ARGS too)
#   wall:V              amhmvs_depth wall time on fountain x0.25 (5 program runs)
#   tests:V             amhmvs_gpu_tests (without the CPU fountain run)
#   sanitize            compute-sanitizer memcheck of the GPU tests' small scenes (new)
#   cmp                 depth, normal, cost and depth.png of base and new cmp-identical
# Logs and tables land in $OUT.
set -uo pipefail

stage() {
  local here stage_dir base=${1:-}
  here=$(cd "$(dirname "$0")/../.." && pwd)
  stage_dir=$here/build-gpu-stage
  export PATH=/usr/bin:/bin:/usr/sbin:/sbin:/usr/local/cuda/bin:$PATH
  local programs="amhmvs_benchmark amhmvs_depth amhmvs_gpu_tests amhmvs_synthetic"
  build() {  # source dir, build dir
    mkdir -p "$2"
    cmake -S "$1" -B "$2" -DAMHMVS_CORE_ONLY=ON -DAMHMVS_CORE_WITHOUT_OPENCV=ON -DCMAKE_BUILD_TYPE=Release \
      -DAMHMVS_CUDA_ARCHITECTURES=90 -DCMAKE_CXX_COMPILER_LAUNCHER=ccache > "$2/configure.log" 2>&1 &&
      cmake --build "$2" -j "$(nproc)" --target $programs > "$2/build.log" 2>&1 ||
      { tail -20 "$2/build.log"; return 1; }
  }
  rm -rf "$stage_dir" && mkdir -p "$stage_dir/lib"
  build "$here" "$here/build-gpu-new" || exit 1
  tar -czf "$stage_dir/new.tgz" -C "$here/build-gpu-new" $programs
  if [ -n "$base" ]; then
    rm -rf "$here/build-gpu-base-src" && mkdir -p "$here/build-gpu-base-src"
    git -C "$here" archive "$base" | tar -x -C "$here/build-gpu-base-src"
    build "$here/build-gpu-base-src" "$here/build-gpu-base" || exit 1
    tar -czf "$stage_dir/base.tgz" -C "$here/build-gpu-base" $programs
    # A second copy of the package in the checkout would confuse rostest's package search.
    rm -rf "$here/build-gpu-base-src"
  fi
  cp -L /usr/local/cuda/lib64/libcudart.so.13 /lib/x86_64-linux-gnu/libgomp.so.1 "$stage_dir/lib/"
  # The real data converted for a build without image decoders (fountain
  # x0.25 and Middlebury; the x0.5 / x1 folders would not fit the carry limit).
  local data=${AMHMVS_DATA_DIR:-$here/../shared/data} src
  src=$(mktemp -d) && ln -s "$data/mvsnet" "$src/mvsnet" && ln -s "$data/middlebury2014" "$src/middlebury2014"
  python3 "$here/scripts/gpu_machine/prepare_gpu_data.py" "$src" "$src/prepared" > /dev/null || exit 1
  rm -f "$src/prepared/mvsnet/fountain_x0.25/sparse.npz"
  tar -czf "$stage_dir/gpu_data.tgz" -C "$src/prepared" . && rm -rf "$src"
  cp "$0" "$stage_dir/gpu_prebuilt.sh"
  du -sh "$stage_dir"
}

run() {
  local S out
  S=$(cd "$(dirname "$0")" && pwd)
  out=${OUT:-/tmp/out}
  mkdir -p "$out" /tmp/d
  export LD_LIBRARY_PATH=$S/lib:${LD_LIBRARY_PATH:-}
  nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader | tee "$out/device.txt"
  tar -xzf "$S/gpu_data.tgz" -C /tmp/d
  for v in new base; do
    [ -f "$S/$v.tgz" ] && mkdir -p "/tmp/$v" && tar -xzf "$S/$v.tgz" -C "/tmp/$v"
  done
  local step v envs n
  for step in "$@"; do
    echo "== $step ($(date +%T))"
    case $step in
      pipe:*)
        IFS=: read -r _ v envs <<< "$step"
        # shellcheck disable=SC2086
        env $envs "/tmp/$v/amhmvs_benchmark" /tmp/d --only "${BENCH_ONLY:-pipeline}" ${BENCH_ARGS:-} \
          --out "$out/bench_${v}_$(date +%H%M%S).md" 2>&1 | grep -E "^\| [48] |per reference|^\| [0-9.]+ \|" ;;
      replay:*)
        IFS=: read -r _ v n <<< "$step"
        # shellcheck disable=SC2086
        "/tmp/$v/amhmvs_benchmark" /tmp/d --only replay --replay "$n" ${BENCH_ARGS:-} --out "$out/replay_${v}_$n.md" 2>&1 |
          tail -14 ;;
      wall:*)
        v=${step#wall:}
        for r in 1 2 3 4 5; do
          rm -rf /tmp/w
          local t0 t1
          t0=$(date +%s%N)
          "/tmp/$v/amhmvs_depth" /tmp/d/mvsnet/fountain_x0.25 /tmp/w --backend cuda --quiet
          t1=$(date +%s%N)
          echo "$v run $r: $(( (t1 - t0) / 1000000 )) ms, $(( (t1 - t0) / 11000000 )) ms/map"
        done
        "/tmp/$v/amhmvs_depth" /tmp/d/mvsnet/fountain_x0.25 /tmp/w --backend cuda 2>&1 | grep "ms in all" ;;
      tests:*)
        v=${step#tests:}
        "/tmp/$v/amhmvs_gpu_tests" /tmp/d --skip-cpu-fountain > "$out/gpu_tests_$v.txt" 2>&1
        echo "rc $?"
        grep -E "FAIL|failure" "$out/gpu_tests_$v.txt" ;;
      sanitize)
        compute-sanitizer --tool memcheck --error-exitcode 9 /tmp/new/amhmvs_gpu_tests /tmp/d --sanitize \
          > "$out/sanitizer_memcheck.txt" 2>&1
        echo "memcheck rc $?"
        tail -2 "$out/sanitizer_memcheck.txt" ;;
      cmp)
        rm -rf /tmp/cb /tmp/cn
        /tmp/base/amhmvs_depth /tmp/d/mvsnet/fountain_x0.25 /tmp/cb --backend cuda --quiet
        /tmp/new/amhmvs_depth /tmp/d/mvsnet/fountain_x0.25 /tmp/cn --backend cuda --quiet
        local differ=0 f
        for f in /tmp/cb/*/*.pfm /tmp/cb/*/depth.png; do
          cmp -s "$f" "/tmp/cn/${f#/tmp/cb/}" || { echo "differs: ${f#/tmp/cb/}"; differ=1; }
        done
        echo "cmp: $(ls /tmp/cb/*/depth.pfm | wc -l) views, differ=$differ" ;;
      *) echo "unknown step $step" ;;
    esac
  done
}

case ${1:-} in
  stage) shift; stage "$@" ;;
  run) shift; run "$@" ;;
  *) sed -n '2,22p' "$0"; exit 2 ;;
esac
