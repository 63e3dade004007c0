#!/usr/bin/env bash
# Installs the Debian 12 packages that amhmvs_mapping needs (ROS 1 from
# Debian's own packages, Eigen, OpenCV, PCL, Ceres, gtest; rviz, Xvfb and
# ImageMagick for the demo's headless rviz picture) and, for the test
# command, its test-only tools: COLMAP for the COLMAP input tests, clang with
# its sanitizer/libFuzzer runtimes, OpenMP and llvm-symbolizer for the core
# suites and fuzzers.
#
# usage: scripts/install_dependencies.sh [--demo]
#   --demo  only what building and running the demo needs (the test-only
#           tools left out; the build configuration is the same, so the test
#           command later installs them and rebuilds nothing)
# Installs only what is missing; needs root (or sudo). apt's output goes to
# AMHMVS_INSTALL_LOG (default /tmp/amhmvs_install_dependencies.log); the
# console gets one line (what is installed, how long, where the log is), and
# the log's tail if apt fails.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config git
  catkin python3-catkin-pkg python3-rospkg python3-empy ros-base-dev
  ros-message-generation ros-message-runtime
  libnodeletlib-dev libnodeletlib-tools libnodelet-dev python3-nodelet
  libtf2-ros-dev libtf2-eigen-dev libtf2-geometry-msgs-dev python3-tf2-ros
  libcv-bridge-dev libimage-transport-dev libimage-geometry-dev image-transport-tools
  libdepth-image-proc-dev
  libpcl-ros-dev libpcl-dev
  python3-rostest rosbash librosbag-dev python3-rosbag python3-roslaunch
  libdiagnostic-updater-dev python3-diagnostic-updater
  libdynamic-reconfigure-config-init-mutex-dev python3-dynamic-reconfigure
  ros-sensor-msgs ros-geometry-msgs ros-nav-msgs ros-visualization-msgs
  ros-std-srvs libstd-srvs-dev python3-std-srvs
  libmessage-filters-dev python3-message-filters
  python3-sensor-msgs python3-geometry-msgs python3-nav-msgs python3-visualization-msgs
  libeigen3-dev libopencv-dev libopencv-contrib-dev libceres-dev libgtest-dev googletest python3-numpy python3-opencv
  rviz xvfb imagemagick libgl1-mesa-dri python3-tf2-msgs python3-diagnostic-msgs python3-rosnode python3-yaml
)
test_packages=(colmap clang libclang-rt-14-dev libomp-14-dev llvm-14 procps libopen3d-dev)
case ${1:-} in
  --demo) ;;
  "") packages+=("${test_packages[@]}") ;;
  *) echo "install_dependencies.sh: unknown option $1 (--demo or nothing)" >&2; exit 2 ;;
esac

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install_dependencies: all ${#packages[@]} packages present"
  exit 0
fi
sudo=""
[ "$(id -u)" = 0 ] || sudo=sudo
log=${AMHMVS_INSTALL_LOG:-/tmp/amhmvs_install_dependencies.log}
start=$(date +%s)
echo "install_dependencies: installing ${#missing[@]} packages: ${missing[*]}" > "$log"
if ! { $sudo apt-get update -qq &&
       DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"; } >> "$log" 2>&1; then
  tail -n 20 "$log" >&2
  echo "install_dependencies: apt-get failed installing ${#missing[@]} packages (full log: $log)" >&2
  exit 1
fi
echo "install_dependencies: installed ${#missing[@]} missing packages in $(( $(date +%s) - start )) s (apt log: $log)"
