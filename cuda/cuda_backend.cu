// CUDA backend: the per-pixel algorithm of patchmatch_pixel.h, one thread per
// pixel. All state stays on the device from upload to download; the host only
// launches kernels (no per-iteration round trips).
#include <cuda_runtime.h>

#include <sstream>

#include "../src/mvs/backends.h"
#include "cuda_check.h"
#include "layered_texture.h"

namespace amhmvs {
namespace mvs {
namespace {

// One source view: a layer of the layered texture.
struct GpuSourceView {
  cudaTextureObject_t texture;
  int layer;

  __device__ float sample(float x, float y) const {
    // Texture coordinates put pixel centres at +0.5.
    return tex2DLayered<float>(texture, x + 0.5f, y + 0.5f, layer) * 255.0f;
  }
};

// Reference image from global memory (exact integer reads), sources from the
// layered texture (hardware bilinear filtering).
struct GpuSampler {
  const uint8_t* reference_pixels;
  int width, height;
  cudaTextureObject_t sources;

  // Intensity at an integer pixel, -1 outside the image.
  __device__ float reference(int x, int y) const {
    if (x < 0 || y < 0 || x >= width || y >= height) return -1.0f;
    return static_cast<float>(__ldg(reference_pixels + y * width + x));
  }
  __device__ GpuSourceView sourceView(int view) const { return {sources, view}; }
};

constexpr int kBlockX = 16, kBlockY = 8;
// Minimum resident blocks per multiprocessor asked of the compiler for the
// initialisation and update kernels, which caps their registers (65536 / (128 * blocks)). More
// resident warps hide texture latency; too few registers spill. Measured by
// scripts/gpu_check.sh (step "variants").
#ifndef AMHMVS_UPDATE_MIN_BLOCKS
#define AMHMVS_UPDATE_MIN_BLOCKS 4
#endif

// Reference window samples of the paper's window in shared memory, sample
// major so that a warp reads consecutive 8-byte words: 36 x 8 B per thread
// instead of 72 registers.
constexpr int kBlockThreads = kBlockX * kBlockY;
__device__ int threadInBlock() { return threadIdx.y * blockDim.x + threadIdx.x; }

struct SharedSamples {
  WindowSample* first;  // this thread's sample 0
  __device__ WindowSample& operator[](int i) const { return first[i * kBlockThreads]; }
};

// Storage of the reference window in the initialisation and update
// kernels, per window shape.
template <class Window>
struct WindowStorage {
  __device__ static InlineSamples get(int) { return {}; }
};
template <>
struct WindowStorage<PaperWindow> {
  __device__ static SharedSamples get(int thread) {
    constexpr int kSamples = PaperWindow::perAxis() * PaperWindow::perAxis();
    __shared__ WindowSample samples[kSamples * kBlockThreads];
    return {samples + thread};
  }
};

template <class Window>
__global__ void __launch_bounds__(kBlockThreads, AMHMVS_UPDATE_MIN_BLOCKS)
    initializeKernel(PatchMatchParams P, GpuSampler sampler, PixelState state) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x;
  const int y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x < P.width && y < P.height) {
    initializePixel<Window>(P, sampler, state, x, y, WindowStorage<Window>::get(threadInBlock()));
  }
}

// One thread per pixel of `colour`: thread column i handles x = 2 i + parity.
template <class Window>
__global__ void __launch_bounds__(kBlockThreads, AMHMVS_UPDATE_MIN_BLOCKS)
    updateKernel(PatchMatchParams P, GpuSampler sampler, PixelState state, int iteration,
                 int colour) {
  // Threads score hypotheses on different views after view selection: the
  // geometry is read from shared memory (kernel parameters serialise
  // divergent indices).
  __shared__ SourceGeometry sources[kMaxSourceViews];
  for (int j = threadInBlock(); j < P.num_sources; j += kBlockThreads) sources[j] = P.sources[j];
  __syncthreads();
  const int y = blockIdx.y * blockDim.y + threadIdx.y;
  const int x = 2 * (blockIdx.x * blockDim.x + threadIdx.x) + ((y + colour) & 1);
  if (x < P.width && y < P.height) {
    updatePixel<Window>(P, sources, sampler, state, iteration, x, y,
                        WindowStorage<Window>::get(threadInBlock()));
  }
}

__global__ void outputKernel(PatchMatchParams P, PixelState state, float* raw_depth,
                             float* normal, float* cost) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x;
  const int y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= P.width || y >= P.height) return;
  const int index = y * P.width + x;
  Vec3 n;
  pixelOutput(P, state, x, y, &raw_depth[index], &n, &cost[index]);
  normal[3 * index + 0] = n.x;
  normal[3 * index + 1] = n.y;
  normal[3 * index + 2] = n.z;
}

__global__ void medianKernel(int width, int height, int size, const float* raw_depth,
                             float* depth) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x;
  const int y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x < width && y < height) depth[y * width + x] = medianDepth(raw_depth, width, height, x, y, size);
}

dim3 gridFor(int width, int height) {
  return dim3((width + kBlockX - 1) / kBlockX, (height + kBlockY - 1) / kBlockY);
}

// Initialisation and all iterations, kernels queued back to back.
template <class Window>
void runPatchMatch(const PatchMatchParams& P, const GpuSampler& sampler, PixelState state,
                   int iterations) {
  const dim3 block(kBlockX, kBlockY);
  initializeKernel<Window><<<gridFor(P.width, P.height), block>>>(P, sampler, state);
  AMHMVS_CUDA_CHECK_LAUNCH();
  const dim3 half_grid = gridFor((P.width + 1) / 2, P.height);
  for (int iteration = 0; iteration < iterations; ++iteration) {
    for (int colour = 0; colour < 2; ++colour) {
      updateKernel<Window><<<half_grid, block>>>(P, sampler, state, iteration, colour);
      AMHMVS_CUDA_CHECK_LAUNCH();
    }
  }
}

}  // namespace

bool cudaDeviceUsable(std::string* description) {
  int count = 0;
  const cudaError_t status = cudaGetDeviceCount(&count);
  if (status != cudaSuccess || count == 0) {
    cudaGetLastError();
    if (description) {
      *description = status != cudaSuccess ? std::string("no usable GPU: ") + cudaGetErrorString(status)
                                           : std::string("no GPU found");
    }
    return false;
  }
  int device = 0;
  cudaDeviceProp props;
  if (cudaGetDevice(&device) != cudaSuccess || cudaGetDeviceProperties(&props, device) != cudaSuccess) {
    cudaGetLastError();
    if (description) *description = "no usable GPU: device properties unavailable";
    return false;
  }
  if (description) {
    std::ostringstream out;
    out << props.name << " (compute " << props.major << "." << props.minor << ", "
        << props.totalGlobalMem / (1024 * 1024) << " MiB)";
    *description = out.str();
  }
  return true;
}

DepthMap estimateOnCuda(const PatchMatchOptions& options, const PatchMatchParams& P,
                        const DepthProblem& problem) {
  using cuda::DeviceBuffer;
  cuda::CudaEvent start, stop;
  start.record();
  size_t free_before = 0, free_after = 0, total = 0;
  AMHMVS_CUDA_CHECK(cudaMemGetInfo(&free_before, &total));

  const int width = P.width, height = P.height;
  const size_t pixels = static_cast<size_t>(width) * height;
  DeviceBuffer<uint8_t> reference(pixels);
  reference.upload(problem.reference_image.data.data());
  std::vector<const ImageU8*> layers;
  for (const ImageU8& image : problem.source_images) layers.push_back(&image);
  cuda::LayeredTexture8 sources(layers);

  DeviceBuffer<Plane> planes(pixels);
  DeviceBuffer<float> costs(pixels);
  DeviceBuffer<uint32_t> selected(pixels);
  DeviceBuffer<int8_t> best_view(pixels);
  const PixelState state{planes.get(), costs.get(), selected.get(), best_view.get()};
  const GpuSampler sampler{reference.get(), width, height, sources.object()};
  DeviceBuffer<float> raw_depth(pixels), depth(pixels), normal(3 * pixels), cost(pixels);
  cuda::CudaEvent uploaded;
  uploaded.record();

  if (isPaperWindow(P.cost)) {
    runPatchMatch<PaperWindow>(P, sampler, state, options.num_iterations);
  } else {
    runPatchMatch<RuntimeWindow>(P, sampler, state, options.num_iterations);
  }
  const dim3 block(kBlockX, kBlockY);
  outputKernel<<<gridFor(width, height), block>>>(P, state, raw_depth.get(), normal.get(), cost.get());
  AMHMVS_CUDA_CHECK_LAUNCH();
  medianKernel<<<gridFor(width, height), block>>>(width, height, options.median_filter_size,
                                                  raw_depth.get(), depth.get());
  AMHMVS_CUDA_CHECK_LAUNCH();

  AMHMVS_CUDA_CHECK(cudaMemGetInfo(&free_after, &total));
  DepthMap out;
  out.backend = Backend::kCuda;
  out.gpu_memory_bytes = free_before > free_after ? free_before - free_after : 0;
  out.depth = ImageF(width, height);
  out.normal = ImageF(width, height, 3);
  out.cost = ImageF(width, height);
  depth.download(out.depth.data.data());
  normal.download(out.normal.data.data());
  cost.download(out.cost.data.data());
  stop.record();
  out.milliseconds = stop.millisecondsSince(start);
  out.compute_milliseconds = stop.millisecondsSince(uploaded);
  return out;
}

}  // namespace mvs
}  // namespace amhmvs
