#!/usr/bin/env bash
# The whole test suite (what CI runs): installs missing Debian packages,
# builds, makes a real COLMAP workspace from the fountain images, then runs the
# gtest suite (unit tests, CLI tests, real-data accuracy floors), the ROS
# tests and the demo in a short configuration, and prints
# "N passed, N failed, N skipped". GPU tests run on a GPU machine instead:
# scripts/gpu_machine/gpu_check.sh.
#
# Real data: $AMHMVS_DATA_DIR, else ../shared/data beside the repository.
#
# --fast: the edit loop's tier: builds the unit tests and the programs they
# run, then runs the unit tests without the slow ones (the real-data floors,
# the CLI runs on whole sequences, the repeated estimator runs: `slow`
# below); no sanitizers, fuzzers, rostests or demo.
set -euo pipefail
fast=false
case ${1:-} in
  --fast) fast=true ;;
  -h|--help) awk 'NR > 1 && !/^#/ {exit} NR > 1 {sub(/^# ?/, ""); print}' "$0"; exit 0 ;;
  "") ;;
  *) echo "run_tests.sh: unknown option $1 (--help)" >&2; exit 2 ;;
esac
here=$(cd "$(dirname "$0")/.." && pwd)
export PATH=/usr/bin:/bin:/usr/sbin:/sbin:/usr/local/cuda/bin:$PATH
build=${AMHMVS_BUILD_DIR:-$here/build}
data=${AMHMVS_DATA_DIR:-$here/../shared/data}

"$here/scripts/install_dependencies.sh"
export AMHMVS_DATA_DIR=$data

# The unit tests left out of the fast tier and of the sanitizer run: the
# real-data floors, the CLI runs on whole sequences (the odometry on
# redkitchen among them), the repeated estimator
# runs and the geometric pass on the four Middlebury scenes.
slow='RealData.*:FuseCliRealData.*:DepthCliColmap.*:MapCli.*:OdometryCli.Redkitchen*:EstimatorOnSyntheticScene.*:GeometricConsistency.GeometricPassImproves*'

# run_unit_programs BUILD EXCLUDED OUT [PREFIX...]: every unit-test program
# of BUILD (one per library, as its unit_test_programs.txt lists them) without
# the EXCLUDED tests (a gtest pattern list), each with its XML result in OUT,
# run under PREFIX (e.g. env VAR=...). Appends the XML files to unit_results;
# fails when any program fails.
unit_results=()
run_unit_programs() {
  local build_dir=$1 excluded=$2 out=$3 rc=0 program xml
  shift 3
  mkdir -p "$out"
  while read -r program; do
    xml=$out/$(basename "$program").xml
    "$@" "$program" --gtest_filter="*-$excluded" --gtest_output=xml:"$xml" || rc=1
    unit_results+=("$xml")
  done < "$build_dir/unit_test_programs.txt"
  return $rc
}

# run_unit_programs_two_at_a_time: as run_unit_programs, two programs at a
# time (the sanitizer suite: single-threaded tests), each with its output in
# OUT/PROGRAM.log, printed in order at the end.
run_unit_programs_two_at_a_time() {
  local build_dir=$1 excluded=$2 out=$3 rc=0 program name finished pid
  shift 3
  mkdir -p "$out"
  local -a running=() logs=() still=()
  while read -r program; do
    name=$(basename "$program")
    if [ ${#running[@]} -ge 2 ]; then
      wait -n -p finished "${running[@]}" || rc=1
      still=()
      for pid in "${running[@]}"; do [ "$pid" = "$finished" ] || still+=("$pid"); done
      running=("${still[@]}")
    fi
    "$@" "$program" --gtest_filter="*-$excluded" --gtest_output=xml:"$out/$name.xml" > "$out/$name.log" 2>&1 &
    running+=($!)
    logs+=("$out/$name.log")
    unit_results+=("$out/$name.xml")
  done < "$build_dir/unit_test_programs.txt"
  for pid in "${running[@]}"; do wait "$pid" || rc=1; done
  cat "${logs[@]}"
  return $rc
}

if [ "$fast" = true ]; then
  AMHMVS_MAKE_TARGETS="amhmvs_unit_tests" "$here/scripts/build.sh"
  mkdir -p "$build/test_results"
  log=$build/test_results/fast_unit_tests.log
  start=$(date +%s)
  status=0
  run_unit_programs "$build" "$slow" "$build/test_results/fast" > "$log" 2>&1 || status=1
  grep -E "^\[  FAILED  \]" "$log" || true
  python3 "$here/scripts/count_test_results.py" "${unit_results[@]}"
  echo "fast tier: unit tests in $(( $(date +%s) - start )) s (log: $build/test_results/fast_unit_tests.log)"
  exit $status
fi

AMHMVS_MAKE_TARGETS="all tests" "$here/scripts/build.sh"

# with_progress DESCRIPTION LOG COMMAND...: runs COMMAND with its output in
# LOG and prints a line every 30 s (seconds so far, the log's last line), so
# that a step of minutes does not look hung; returns COMMAND's exit code.
with_progress() {
  local description=$1 log=$2 start pid seconds
  shift 2
  start=$(date +%s)
  "$@" > "$log" 2>&1 &
  pid=$!
  while kill -0 "$pid" 2>/dev/null; do
    sleep 1
    seconds=$(( $(date +%s) - start ))
    if [ $(( seconds % 30 )) -eq 0 ] && kill -0 "$pid" 2>/dev/null; then
      echo "  $description: ${seconds} s, $(tail -n 1 "$log" | cut -c1-120)"
    fi
  done
  wait "$pid"
}

if [ -d "$data/mvsnet/fountain_x0.25/images" ] && command -v colmap >/dev/null; then
  workspace=$build/colmap_fountain/dense
  if [ ! -f "$workspace/sparse/cameras.bin" ]; then
    echo "== making a COLMAP workspace from the fountain images (CPU SIFT) =="
    rm -rf "$build/colmap_fountain"
    with_progress "COLMAP" "$build/colmap_fountain.log" \
      "$here/scripts/make_colmap_model.sh" "$data/mvsnet/fountain_x0.25/images" "$build/colmap_fountain" ||
      { tail -20 "$build/colmap_fountain.log"; exit 1; }
  fi
  export AMHMVS_COLMAP_WORKSPACE=$workspace
fi

if [ -d "$data/mvsnet/fountain_x0.25" ]; then
  # Depth maps for the fusion test on real data (384x256, CPU, a few minutes).
  fountain_depth=$build/fountain_depth_384
  if [ ! -f "$fountain_depth/00000010/depth.pfm" ]; then
    echo "== fountain depth maps at 384 px for the fusion test =="
    with_progress "fountain depth maps" "$build/fountain_depth_384.log" \
      "$build/devel/lib/amhmvs_mapping/amhmvs_depth" "$data/mvsnet/fountain_x0.25" "$fountain_depth" \
      --max_image_size 384 --backend cpu ||
      { tail -20 "$build/fountain_depth_384.log"; exit 1; }
  fi
  export AMHMVS_FOUNTAIN_DEPTH_DIR=$fountain_depth
fi

# run_logged DESCRIPTION LOG COMMAND...: runs COMMAND with its output in LOG,
# prints its exit code and time, and on failure the log's tail; sets $rc.
run_logged() {
  local description=$1 log=$2 start
  shift 2
  start=$(date +%s)
  set +e
  "$@" > "$log" 2>&1
  rc=$?
  set -e
  echo "$description: exit $rc in $(( $(date +%s) - start )) s (log: $log)"
  if [ $rc -ne 0 ]; then
    tail -40 "$log"
    status=1
  fi
}

# The core suite again without catkin, built by clang (-O1) with
# AddressSanitizer + UndefinedBehaviorSanitizer (any finding aborts the test;
# the same build holds the fuzz targets; only the programs the tests run are
# built). The sanitizers make the code 10-15x slower, so this run is the fast
# tier less the tests that take over 10 s under them (listed below: the
# keyframe bundle adjustment's larger problems, the realism renderer, the
# synthetic scenes' consistency checks, the exact-room map, the
# ten-thousand-keyframe store, the larger fusion and coarse-to-fine scenes,
# the interrupted amhmvs_map run, whose realtime replay is too slow there to
# stop where the test expects). Every one of those
# suites keeps smaller tests here, on the same code.
core_results=$build/test_results/core
rm -rf "$core_results"
mkdir -p "$core_results"
asan_build=${AMHMVS_ASAN_BUILD_DIR:-$here/build-clang-asan}
slow_under_sanitizers='DepthFilter.StartsAFewPerCentOffConvergeOnRenderedFrames:DepthFilter.StartsWithinTheSearchAreCorrectedOthersAreNotPublished:SyntheticRealism.WritesTheTrackersPosesBesideTheExactTruth:SyntheticRealism.DefaultOutputIsTodaysBitForBit:MapCliRoom.MapsTheRoomWithExactGroundTruth:KeyframeStore.TenThousandKeyframesThroughStoreAndMapStayInBudget:KeyframeBundleAdjustment.MismatchesDoNotSpoilIt:KeyframeBundleAdjustment.CoarseFeaturesWeighByTheirSize:Fusion.ExactDepthMapsFuseOntoTheTrueSurface:Fusion.OutliersOfOneViewAreRejectedAndTheRestRemains:SyntheticScene.IndoorGroundTruthIsConsistentBetweenFrames:SyntheticScene.RendersQuickly*:SyntheticSequence.GroundTruthDepthAgreesAcrossFramesWhereVisible:RealisticCapture.MotionBlurReducesGradientEnergyAndKeepsTheMidExposureDepth:CoarseToFine.TwoScalesImproveMiddleburyPlaytable:CoarseToFine.TwoScalesFindMoreOfAWeaklyTexturedWall:CoarseToFine.KeyedImagesGiveTheSameMapFromTheCache:MapCliRoom.InterruptedRunWritesTheMapAndSummaryOfWhatItDid'
fuzz_seconds=${AMHMVS_FUZZ_SECONDS:-10}
sanitizer_job() {
  renice -n 19 -p "$BASHPID" > /dev/null  # what it starts inherits the priority
  local start rc=0 fuzzers
  start=$(date +%s)
  CC=clang CXX=clang++ AMHMVS_BUILD_TYPE=RelWithDebInfo \
    AMHMVS_MAKE_TARGETS="amhmvs_unit_tests amhmvs_depth amhmvs_synthetic amhmvs_map amhmvs_fuse amhmvs_cloud_metrics fuzzers" \
    "$here/scripts/build_core.sh" "$asan_build" -DAMHMVS_FUZZERS=ON -DAMHMVS_SANITIZERS=address,undefined \
    -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -DNDEBUG" -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O1 -DNDEBUG" \
    > "$core_results/build_asan.log" 2>&1 || { tail -30 "$core_results/build_asan.log"; return 1; }
  echo "sanitizer build: $(( $(date +%s) - start )) s"
  # The fuzzers run for a set time each: beside the suite, not after it.
  (
    status=0
    run_logged "fuzzers ($fuzz_seconds s each)" "$core_results/fuzzers.log" \
      env AMHMVS_FUZZ_SECONDS="$fuzz_seconds" AMHMVS_FUZZ_BUILD_DIR="$asan_build" \
      AMHMVS_FUZZ_RESULTS="$core_results/fuzzers.xml" "$here/scripts/run_fuzzers.sh"
    grep -E "executions|FINDING" "$core_results/fuzzers.log" || true
    exit $status
  ) > "$core_results/fuzzers_job.log" 2>&1 &
  fuzzers=$!
  status=0
  run_logged "sanitizer core suite" "$core_results/asan_unit_tests.log" \
    run_unit_programs_two_at_a_time "$asan_build" "$slow:$slow_under_sanitizers" "$core_results/asan" \
    env ASAN_OPTIONS=detect_leaks=1 UBSAN_OPTIONS=print_stacktrace=1
  wait "$fuzzers" || status=1
  cat "$core_results/fuzzers_job.log"
  return $status
}
# The tests below leave much of the 2 cores idle (the rostests use about a
# third of them): the sanitizer build, its suite and the fuzzers run beside
# them at the lowest priority, so that they take only idle time, and are
# waited for at the end.
echo "== core unit tests: clang + ASan/UBSan; fuzzers (in the background: $core_results/sanitizer_job.log) =="
sanitizer_job > "$core_results/sanitizer_job.log" 2>&1 &
sanitizer_pid=$!
# kill_tree PID: the process and everything it started (the job, should this
# script stop before it waits for it).
kill_tree() {
  local child
  for child in $(pgrep -P "$1"); do kill_tree "$child"; done
  kill "$1" 2> /dev/null || true
}
trap 'kill_tree "$sanitizer_pid"' EXIT

echo "== unit, CLI and real-data tests =="
status=0
run_unit_programs "$build" "" "$build/test_results/unit" || status=1
all_unit_results=("${unit_results[@]}")

# ROS tests: the gtest of the nodelet's message conversions, then rostests,
# each with its own roscore: the fountain bag through the nodelet loaded into
# a manager (pose topic), through the standalone node (tf; it saves its map
# when shut down), and as Keyframe
# messages with sparse points from a small SLAM adapter, the temple bag
# (odometry input, the object's box as the map's region of interest: every
# map point in the box), the ICL bag (plumbing), keyframe mode with the
# services and a loop closure, a missing and a late transform, silent input topics, bad
# and hostile input, a hostile stream (encoding, camera_info, size and poses
# change, the clock jumps back); the fountain and temple bags again on the shipped
# config/mapping.yaml (nothing tuned: a depth image for every keyframe, nothing
# dropped) and the redkitchen bag on it (real Kinect video, depth against the
# Kinect's; at KinectFusion's poses and at a real odometry's), depth_image_proc/point_cloud_xyz + the 16UC1 output on ours,
# the fountain bag as JPEG through the `compressed` transport, and a part of
# it played by mapping.launch's rate/start/duration (with the rviz view frame).
echo "== ROS tests (message conversions; rostest) =="
ros_results=$build/test_results/ros
rm -rf "$ros_results"
mkdir -p "$ros_results"
ros_runs=("$ros_results/amhmvs_ros_unit_tests.xml")
set +e
"$build/devel/lib/amhmvs_mapping/amhmvs_ros_unit_tests" --gtest_output=xml:"$ros_results/amhmvs_ros_unit_tests.xml"
[ $? -ne 0 ] && status=1
set -e

# The rostests: name, test file, launch arguments (the bags and the realism
# folder are written below when the fountain bag is there).
kitchen_bag=$build/bags/redkitchen_7scenes_40.bag
kitchen_odometry_bag=$build/bags/redkitchen_7scenes_40_odometry.bag
realism_dir=$build/realism_room8
realism_bag=$build/bags/realism_room8.bag
ros_tests=(
  "fountain_manager_pose replay_fountain.test standalone:=false input_mode:=pose shutdown_map:=$ros_results/fountain_manager_pose_shutdown_map.ply"
  "fountain_standalone_tf replay_fountain.test standalone:=true input_mode:=tf shutdown_map:=$ros_results/fountain_standalone_tf_shutdown_map.ply"
  "fountain_manager_keyframe replay_fountain.test standalone:=false input_mode:=keyframe"
  "fountain_slow_replay replay_fountain.test rate:=0.1"
  "temple_map_odometry_region replay_map.test scene:=temple input_mode:=odometry region:=true"
  "icl_plumbing replay_map.test scene:=icl"
  "keyframe_services keyframe_services.test"
  "missing_tf missing_tf.test"
  "silent_inputs silent_inputs.test"
  "hostile_input hostile_input.test"
  "hostile_stream hostile_stream.test"
  "bad_input bad_input.test"
  "fountain_shipped_defaults replay_fountain.test defaults:=true shutdown_map:=$ros_results/fountain_shipped_defaults_shutdown_map.ply"
  "temple_shipped_defaults replay_map.test scene:=temple defaults:=true"
  "redkitchen_shipped_defaults replay_map.test scene:=redkitchen defaults:=true bag:=$kitchen_bag"
  "redkitchen_odometry_shipped_defaults replay_map.test scene:=redkitchen defaults:=true poses:=odometry bag:=$kitchen_odometry_bag"
  "saturated_input saturated_input.test bag:=$kitchen_bag"
  "realism_tracker_settings replay_map.test scene:=realism bag:=$realism_bag truth_dir:=$realism_dir"
  "depth_interop depth_interop.test"
  "fountain_compressed_jpeg replay_fountain.test compressed:=jpeg"
  "replay_part replay_part.test"
)

bag=$data/bags/strecha_fountain_x0.25.bag
if [ -f "$bag" ]; then
  set +u
  source "$build/devel/setup.bash"
  set -u
  export ROS_PACKAGE_PATH=$here${ROS_PACKAGE_PATH:+:$ROS_PACKAGE_PATH}
  export ROS_HOME=${ROS_HOME:-$build/ros_home}
  # The bags the data folder has none of, written beside the first rostests
  # (they wait for them): redkitchen, 40 frames of the 7-Scenes folder;
  # realism, issue 12's realism room (tracker noise, rolling shutter, blur)
  # rendered here, its true cameras and depth kept.
  make_bags() {
    mkdir -p "$build/bags"
    if [ -d "$data/redkitchen_7scenes" ]; then
      python3 "$here/scripts/seven_scenes_to_bag.py" "$data/redkitchen_7scenes" "$kitchen_bag"
      # The same frames at a real tracker's poses: the odometry over every
      # frame file up to the bag's last (0-78), as a tracker sees them.
      "$build/devel/lib/amhmvs_mapping/amhmvs_odometry" "$data/redkitchen_7scenes" "$build/bags/redkitchen_odometry_79.txt" \
        --count 79 --report "$build/bags/redkitchen_odometry_79.json"
      python3 "$here/scripts/seven_scenes_to_bag.py" "$data/redkitchen_7scenes" "$kitchen_odometry_bag" \
        --trajectory "$build/bags/redkitchen_odometry_79.txt"
    fi
    "$build/devel/lib/amhmvs_mapping/amhmvs_synthetic" "$realism_dir" --scene room --views 8 --realism default \
      > "$build/realism_room8.log" 2>&1 || { tail -5 "$build/realism_room8.log"; return 1; }
    python3 "$here/scripts/dense_folder_to_bag.py" "$realism_dir" "$realism_bag"
  }
  make_bags > "$build/test_results/bags.log" 2>&1 &
  bags_pid=$!
  for run in "${ros_tests[@]}"; do
    read -r name file args <<< "$run"
    if [[ $args == *"$build/bags/"* ]] && [ -n "$bags_pid" ]; then
      wait "$bags_pid" || { status=1; tail -20 "$build/test_results/bags.log"; }
      bags_pid=
    fi
    dir=$ros_results/$name
    mkdir -p "$dir"
    # shellcheck disable=SC2086
    run_logged "$name ($file $args)" "$dir.log" \
      env ROS_TEST_RESULTS_DIR="$dir" rostest --results-base-dir "$dir" amhmvs_mapping "$file" $args
    ros_runs+=("$dir")
  done
else
  echo "rostest: skipped, no bag at $bag"
  for _ in "${ros_tests[@]}"; do ros_runs+=(skipped); done
fi

# The package installed the way a ROS user's workspace installs it: a fresh
# catkin workspace (temporary, outside the repository) gets its setup files
# from `catkin_make install` and the package from `cmake --install` of the
# build above (building it again there, CPU only, took 4 minutes:
# scripts/test_catkin_workspace.sh without --from-build does that), then
# from the install space `rosrun amhmvs_mapping amhmvs_depth --help` and the
# rostest missing_tf.
echo "== catkin install space (rosrun and rostest from install/) =="
run_logged "catkin install space" "$build/test_results/catkin_workspace.log" \
  "$here/scripts/test_catkin_workspace.sh" --from-build "$build" "$build/test_results/catkin_workspace"
ros_runs+=("script:$rc")

# The README's first command in a short configuration (4 frames at 160x120 on
# the CPU, no install or build; about a minute with the rviz picture), its
# summary and outputs checked against floors (measured: 68.6 / 81.1 % of the
# pixels within 1 / 5 %; the nodelet's map 11127 points, 87.2 % within 2 cm:
# deferred fusion, the first keyframe's late depth map, 2 refinements; 4514
# points, 97.5 % before late depth maps and refinement).
echo "== demo (scripts/demo.sh, tiny sequence) =="
demo_out=$build/test_results/demo
picture=()
command -v Xvfb >/dev/null && command -v rviz >/dev/null && picture=(--picture --follow_picture)
demo_and_checks() {
  "$here/scripts/demo.sh" "$demo_out" --views 4 --size 160x120 --skip-build --timeout 300 &&
    if [ ${#picture[@]} -gt 0 ]; then  # the saved map again, with the view that follows it
      "$here/scripts/render_rviz_snapshot.sh" "$demo_out/map.ply" "$demo_out/map_follow_rviz.png" --up 0,0,1
    fi &&
    python3 "$here/test/demo/check_demo_summary.py" "$demo_out" --keyframes 4 --min_within_1 60 --min_within_5 75 \
      --min_map_points 8000 --min_on_surface 80 "${picture[@]}"
}
run_logged "demo" "$demo_out.log" demo_and_checks
ros_runs+=("script:$rc")

echo "== waiting for the sanitizer suite and the fuzzers =="
wait_start=$(date +%s)
wait "$sanitizer_pid" || status=1
trap - EXIT
cat "$core_results/sanitizer_job.log"
echo "(waited $(( $(date +%s) - wait_start )) s for them)"
shopt -s nullglob
all_unit_results+=("$core_results"/asan/*.xml)
shopt -u nullglob
python3 "$here/scripts/count_test_results.py" "${all_unit_results[@]}" "$core_results/fuzzers.xml" "${ros_runs[@]}"
exit $status
