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
#   bash scripts/stage_ros_gpu.sh [OUT_DIR]     (default: ./.rosgpu)
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
here=$(cd "$(dirname "$0")/.." && pwd)
export PATH=/usr/bin:/bin:/usr/sbin:/sbin:$PATH
build=${AMHMVS_BUILD_DIR:-$here/build}
data=${AMHMVS_DATA_DIR:-$here/../shared/data}
out=$(mkdir -p "${1:-$here/.rosgpu}" && cd "${1:-$here/.rosgpu}" && pwd)
work=$(mktemp -d /tmp/stage_ros_gpu.XXXXXX)
trap 'rm -rf "$work"' EXIT
tree=$work/rosgpu
mkdir -p "$tree"/{bin,lib,share,data,config}
multiarch=/usr/lib/x86_64-linux-gnu

for f in "$build/devel/lib/libamhmvs_mapping_nodelet.so" "$build/devel/lib/libamhmvs_core.so" \
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
cp "$build/devel/lib/libamhmvs_mapping_nodelet.so" "$build/devel/lib/libamhmvs_core.so" "$tree/lib/"
cp "$multiarch/ros/libimage_transport_plugins.so" "$multiarch/ros/librosbag_default_encryption_plugins.so" "$tree/lib/"
python3 - "$tree" "$build/devel/lib" <<'EOF'
import os, re, shutil, subprocess, sys
tree, devel = sys.argv[1], sys.argv[2]
lib = os.path.join(tree, 'lib')
# From the target system (glibc and the compiler's runtime, newer there).
SYSTEM = {'libc.so.6', 'libm.so.6', 'libpthread.so.0', 'libdl.so.2', 'librt.so.1', 'libresolv.so.2',
          'ld-linux-x86-64.so.2', 'libstdc++.so.6', 'libgcc_s.so.1'}
STUBS = {'libgdal.so.32', 'libgdcmMSFF.so.3.0', 'libgdcmDSED.so.3.0', 'libOpenEXR-3_1.so.30'}
DIRS = [devel, '/usr/local/cuda/lib64', '/usr/local/cuda/lib', '/lib/x86_64-linux-gnu', '/usr/lib/x86_64-linux-gnu',
        '/lib', '/usr/lib']

def needed(path):
    out = subprocess.run(['readelf', '-dW', path], capture_output=True, text=True, check=True).stdout
    return re.findall(r'\(NEEDED\).*\[(.*)\]', out)

def find(name):
    for d in DIRS:
        p = os.path.join(d, name)
        if os.path.exists(p):
            return p
    sys.exit('library not found: ' + name)

roots = [os.path.join(tree, 'bin', 'nodelet_replay')] + [os.path.join(lib, f) for f in os.listdir(lib)]
kept, stubbed_by = {}, {}   # soname -> source path; stub -> libraries needing it
todo = list(roots)
while todo:
    path = todo.pop()
    for n in needed(path):
        if n in SYSTEM or n in kept:
            continue
        if n in STUBS:
            stubbed_by.setdefault(n, set()).add(path)
            continue
        if os.path.exists(os.path.join(lib, n)):  # staged already (the package's own)
            continue
        kept[n] = find(n)
        todo.append(kept[n])
for n, src in kept.items():
    shutil.copyfile(os.path.realpath(src), os.path.join(lib, n))

def dynsyms(path, defined):
    out = subprocess.run(['readelf', '--dyn-syms', '-W', path], capture_output=True, text=True, check=True).stdout
    syms = {}
    for line in out.splitlines():
        f = line.split()
        if len(f) < 8 or not f[0].endswith(':') or f[0] == 'Num:':
            continue
        size, typ, bind, ndx, name = f[2], f[3], f[4], f[6], f[7]
        if '@' in name or bind == 'LOCAL':
            continue
        if defined == (ndx != 'UND'):
            syms[name] = (typ, int(size, 0) if size.startswith('0x') else int(size))
    return syms

defined_elsewhere = set()
for p in [os.path.join(lib, f) for f in os.listdir(lib)] + roots:
    defined_elsewhere.update(dynsyms(p, True))
for stub, users in sorted(stubbed_by.items()):
    real = dynsyms(find(stub), True)
    wanted = set()
    for u in users:
        wanted.update(s for s in dynsyms(u, False) if s in real and s not in defined_elsewhere)
    asm = ['.text']
    for s in sorted(wanted):
        typ, size = real[s]
        if typ in ('FUNC', 'IFUNC', 'NOTYPE'):
            asm += ['.globl "%s"' % s, '.type "%s", @function' % s, '"%s": ud2' % s]
    asm.append('.bss')
    for s in sorted(wanted):
        typ, size = real[s]
        if typ == 'OBJECT':
            asm += ['.globl "%s"' % s, '.type "%s", @object' % s, '.size "%s", %d' % (s, size), '.balign 16',
                    '"%s": .zero %d' % (s, max(size, 1))]
        elif typ not in ('FUNC', 'IFUNC', 'NOTYPE'):
            sys.exit('cannot stub %s %s of %s' % (typ, s, stub))
    src = os.path.join(tree, '..', stub + '.s')
    open(src, 'w').write('\n'.join(asm) + '\n')
    subprocess.run(['gcc', '-shared', '-nostdlib', '-Wl,-soname,' + stub, '-o', os.path.join(lib, stub), src],
                   check=True)
    print('stub %s: %d symbols for %s' % (stub, len(wanted), ', '.join(sorted(os.path.basename(u) for u in users))))
total = sum(os.path.getsize(os.path.join(lib, f)) for f in os.listdir(lib))
print('%d libraries, %.1f MB' % (len(os.listdir(lib)), total / 1e6))
EOF

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
rm -f "$work"/*.s
du -sh "$tree"
tar -C "$work" -cf - rosgpu | xz -T2 -6 > "$out/rosgpu.tar.xz"
ls -l "$out/rosgpu.tar.xz"
