#!/usr/bin/env bash
# Stages what the mapping nodelet needs to run on a machine without ROS (the
# GPU machine: Ubuntu 24.04, CUDA, no ROS, no Python ROS, no internet) into
# one archive: the test driver test/gpu_ros/nodelet_replay (the nodelet
# loaded by nodelet::Loader, its own ROS master in-process), the package's
# libraries from the build, Debian 12's ROS and other shared libraries they
# need (not glibc, libstdc++, libgcc_s: the target's are newer), the plugin
# libraries and package.xml / plugin xml files pluginlib looks for, the
# fountain bag and a run script.
#
#   bash scripts/gpu_machine/stage_ros_gpu.sh [OUT_DIR]     (default: ./.rosgpu)
#
# OUT_DIR gets rosgpu.tar.xz (about 35 MB). On the target:
#   tar xJf rosgpu.tar.xz -C /tmp && /tmp/rosgpu/run.sh --backend cuda --report r.txt
# or the four replays of docs/results/nodelet_gpu_h100.md:
#   tar xJf rosgpu.tar.xz -C /tmp && /tmp/rosgpu/check.sh OUT_DIR
# Build first (scripts/build.sh; with CUDA for the target's GPU).
#
# Libraries that only OpenCV's image codecs need for formats the nodelet
# never reads or writes (GDAL, GDCM/DICOM, OpenEXR) would triple the size
# (GDAL alone pulls in ~120 MB): they are replaced by stubs that define the
# symbols libopencv_imgcodecs imports from them (ud2 if ever called).
set -euo pipefail
here=$(cd "$(dirname "$0")/../.." && pwd)
export PATH=/usr/bin:/bin:/usr/sbin:/sbin:$PATH
build=${AMHMVS_BUILD_DIR:-$here/build}
data=${AMHMVS_DATA_DIR:-$here/../shared/data}
out=$(mkdir -p "${1:-$here/.rosgpu}" && cd "${1:-$here/.rosgpu}" && pwd)
work=$(mktemp -d /tmp/stage_ros_gpu.XXXXXX)
trap 'rm -rf "$work"' EXIT
tree=$work/rosgpu
mkdir -p "$tree"/{bin,lib,share,data,config}
multiarch=/usr/lib/x86_64-linux-gnu

for f in "$build/devel/lib/libamhmvs_mapping_nodelet.so" "$build"/devel/lib/libamhmvs_{core,io,mvs,mapping}.so \
         "$data/bags/strecha_fountain_x0.25.bag" "$data/mvsnet/fountain_x0.25/sparse_points.txt"; do
  [ -e "$f" ] || { echo "missing $f" >&2; exit 1; }
done

echo "== driver"
g++ -O2 -std=c++17 -I/usr/include/xmlrpcpp -I/usr/include/pluginlib -I/usr/include/class_loader \
  -I/usr/include/rcutils -I/usr/include/rcpputils -I/usr/include/ament_index_cpp \
  -o "$tree/bin/nodelet_replay" "$here/test/gpu_ros/nodelet_replay.cpp" "$here/test/gpu_ros/mini_master.cpp" \
  -Wl,-rpath,'$ORIGIN/../lib' -lnodeletlib -lrosbag_storage -lroscpp -lroscpp_serialization -lrosconsole \
  -lrostime -lxmlrpcpp -lcpp_common -lboost_system -lpthread
strip "$tree/bin/nodelet_replay"

echo "== libraries"
cp "$build/devel/lib/libamhmvs_mapping_nodelet.so" "$build"/devel/lib/libamhmvs_{core,io,mvs,mapping}.so "$tree/lib/"
cp "$multiarch/ros/libimage_transport_plugins.so" "$multiarch/ros/librosbag_default_encryption_plugins.so" "$tree/lib/"
python3 "$here/scripts/gpu_machine/library_closure.py" "$tree" "$build/devel/lib" "$tree/bin/nodelet_replay" \
  --stub libgdal.so.32 --stub libgdcmMSFF.so.3.0 --stub libgdcmDSED.so.3.0 --stub libOpenEXR-3_1.so.30

echo "== ROS package files (ROS_PACKAGE_PATH=share)"
mkdir -p "$tree/share"/{amhmvs_mapping,nodelet,image_transport,rosbag_storage}
cp "$here/package.xml" "$here/nodelet_plugins.xml" "$tree/share/amhmvs_mapping/"
cp /usr/share/nodelet/package.xml "$tree/share/nodelet/"
cp /usr/share/image_transport/package.xml /usr/share/image_transport/default_plugins.xml "$tree/share/image_transport/"
cp /usr/share/rosbag_storage/package.xml /usr/share/rosbag_storage/encryptor_plugins.xml "$tree/share/rosbag_storage/"

echo "== data"
cp "$data/bags/strecha_fountain_x0.25.bag" "$tree/data/"
cp "$data/mvsnet/fountain_x0.25/sparse_points.txt" "$tree/data/"
cp "$here/test/ros/replay_fountain.yaml" "$tree/config/"

cat > "$tree/run.sh" <<'EOF'
#!/usr/bin/env bash
# The nodelet on the fountain bag with nothing but this folder (and the
# system's glibc, libstdc++ and GPU driver): replay_fountain.test's settings
# (256 px, 3 iterations, pose input, its floors); arguments after these
# override them (e.g. --backend cpu, --max-image-size 768 --iterations 6).
T=$(cd "$(dirname "$0")" && pwd)
unset AMENT_PREFIX_PATH ROS_MASTER_URI ROS_IP ROS_HOSTNAME ROS_ROOT ROS_DISTRO ROS_ETC_DIR ROSCONSOLE_CONFIG_FILE PYTHONPATH
# The target's own path stays behind ours: it may be where its GPU driver
# (libcuda.so.1) is found.
export LD_LIBRARY_PATH=$T/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
export ROS_PACKAGE_PATH=$T/share CMAKE_PREFIX_PATH=$T
export ROS_HOME=${ROS_HOME:-$T/home} ROS_LOG_DIR=${ROS_LOG_DIR:-$T/home/log}
exec "$T/bin/nodelet_replay" --stage "$T/" --bag "$T/data/strecha_fountain_x0.25.bag" \
  --config "$T/config/replay_fountain.yaml" --sparse-points "$T/data/sparse_points.txt" \
  --expected-frames 11 --max-image-size 256 --iterations 3 --timeout 300 \
  --depth-floors 82.5,88.5,90.0 --map-floors 88.5,96.5,98.0 --min-map-coverage 85 "$@"
EOF
chmod +x "$tree/run.sh"

cat > "$tree/check.sh" <<'EOF'
#!/usr/bin/env bash
# The GPU check of the nodelet: check.sh OUT_DIR [extra run.sh arguments].
# Four replays of the fountain bag, each with a report in OUT_DIR
# (report_NAME.txt) and the logs of all in OUT_DIR/logs.txt:
#   cuda256         replay_fountain.test's settings and floors, CUDA backend
#   cuda768         full resolution, 6 iterations (the paper's), CUDA, no floors
#   cuda256_rate20  as cuda256 with the bag played 20x faster than recorded
#   cpu256          as cuda256 on the CPU backend, for comparison
S=$(cd "$(dirname "$0")" && pwd)
out=${1:?usage: check.sh OUT_DIR}; shift
mkdir -p "$out"
nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader 2>&1 | tee "$out/device.txt"
r() {
  n=$1; shift; t=$SECONDS
  echo "==== $n: run.sh $*" >> "$out/logs.txt"
  "$S/run.sh" --report "$out/report_$n.txt" "$@" >> "$out/logs.txt" 2>&1
  echo "== $n: rc=$? in $((SECONDS - t)) s"
  [ -f "$out/report_$n.txt" ] || tail -30 "$out/logs.txt"
  grep -vE "^    (stamp|/)|^diagnostics" "$out/report_$n.txt" | cut -c1-300
  grep -oE "\{(backend|gpu memory MiB|last estimate ms|last keyframe ms|keyframes_fused|refined_depth_maps)[^}]*\}" \
    "$out/report_$n.txt" | tr '\n' ' '
  echo
}
r cuda256 --backend cuda --timeout 90 "$@"
r cuda768 --backend cuda --max-image-size 768 --iterations 6 --depth-floors 0,0,0 --map-floors 0,0,0 \
  --min-map-coverage 0 --timeout 120 "$@"
r cuda256_rate20 --backend cuda --rate 20 --timeout 60 "$@"
r cpu256 --backend cpu --timeout 150 "$@"
EOF
chmod +x "$tree/check.sh"

echo "== archive"
du -sh "$tree"
tar -C "$work" -cf - rosgpu | xz -T2 -6 > "$out/rosgpu.tar.xz"
ls -l "$out/rosgpu.tar.xz"
