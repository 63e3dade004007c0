// Times each CUDA call of amhmvs_depth's estimator start, then exits.
#include <cuda_runtime.h>
#include <chrono>
#include <cstdio>
#include <cstdlib>
using Clock = std::chrono::steady_clock;
static Clock::time_point t0;
static double ms() { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }
__global__ void k(float* x) { if (x) x[threadIdx.x] = 1.0f; }
int main(int argc, char** argv) {
  t0 = Clock::now();
  double last = 0;
  auto step = [&](const char* name) { double now = ms(); std::printf("%-34s %7.1f ms (at %7.1f)\n", name, now - last, now); last = now; };
  int count = 0;
  cudaGetDeviceCount(&count); step("cudaGetDeviceCount (cuInit)");
  int dev = 0; cudaGetDevice(&dev); step("cudaGetDevice");
  if (argc > 1 && argv[1][0] == 'a') {
    int v; cudaDeviceGetAttribute(&v, cudaDevAttrMultiProcessorCount, dev); step("cudaDeviceGetAttribute");
  } else {
    cudaDeviceProp p; cudaGetDeviceProperties(&p, dev); step("cudaGetDeviceProperties");
  }
  cudaFree(0); step("cudaFree(0) (context)");
  cudaStream_t s; cudaStreamCreateWithFlags(&s, cudaStreamNonBlocking); step("stream");
  void* d; cudaMalloc(&d, 64 << 20); step("cudaMalloc 64 MiB");
  void* h; cudaHostAlloc(&h, 8 << 20, cudaHostAllocDefault); step("cudaHostAlloc 8 MiB");
  k<<<1, 32, 0, s>>>((float*)d); cudaStreamSynchronize(s); step("first kernel");
  cudaFreeHost(h); cudaFree(d); cudaStreamDestroy(s); step("frees");
  if (argc > 2) std::_Exit(0);
  return 0;
}
