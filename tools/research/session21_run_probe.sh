# Session 21: times the CUDA start of a minimal program (session21_startup_probe.cu, next to this file).
cd "$(dirname "$0")" && nvcc -O2 -arch=sm_90 session21_startup_probe.cu -o /tmp/startup_probe || exit 1
t() { local s=$(date +%s%N); "$@" > /tmp/probe_out.txt; local e=$(date +%s%N); cat /tmp/probe_out.txt; echo "  exec to exit: $(( (e - s) / 1000000 )) ms"; }
for i in 1 2; do echo "== props"; t /tmp/startup_probe p; done
echo "== attribute"; t /tmp/startup_probe a
echo "== attribute, _Exit"; t /tmp/startup_probe a x
echo "== CUDA_DEVICE_MAX_CONNECTIONS=1"; CUDA_DEVICE_MAX_CONNECTIONS=1 t /tmp/startup_probe a
echo "== CUDA_MODULE_LOADING=LAZY"; CUDA_MODULE_LOADING=LAZY t /tmp/startup_probe a
