// CUDA backend: the per-pixel algorithm of patchmatch_pixel.h, one thread per
// pixel. All state stays on the device from upload to download; the host only
// launches kernels (no per-iteration round trips). Each estimator has one
// stream, a pool of resident images (device_image_pool.h) and per-pixel work
// buffers that are reused across estimates (grow only).
#include <cuda_runtime.h>

#include <cstring>
#include <sstream>

#include "mvs/backends.h"
#include "amhmvs_mapping/mvs/plane_map.h"
#include "cuda_check.h"
#include "device_image_pool.h"
#include "gpu_sampler.h"

namespace amhmvs {
namespace mvs {
namespace {

constexpr int kBlockX = 16, kBlockY = 8;
// Minimum resident blocks per multiprocessor asked of the compiler for the
// initialisation and update kernels, which caps their registers (65536 / (128 * blocks)). More
// resident warps hide texture latency; too few registers spill. Measured by
// scripts/gpu_machine/gpu_check.sh (step "variants").
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

// A coarser scale's planes carried to this scale (resamplePixel): the start
// of a coarse-to-fine estimate's next scale, NaN depth and zero normal where
// nothing is carried.
__global__ void resampleKernel(PlaneResampling r, float* depth, float* normal) {
  const int x = blockIdx.x * blockDim.x + threadIdx.x;
  const int y = blockIdx.y * blockDim.y + threadIdx.y;
  if (x >= r.to.width || y >= r.to.height) return;
  const int index = y * r.to.width + x;
  Vec3 n = {0.0f, 0.0f, 0.0f};
  if (!resamplePixel(r, x, y, &depth[index], &n)) depth[index] = nanf_hd();
  normal[3 * index + 0] = n.x;
  normal[3 * index + 1] = n.y;
  normal[3 * index + 2] = n.z;
}

dim3 gridFor(int width, int height) {
  return dim3((width + kBlockX - 1) / kBlockX, (height + kBlockY - 1) / kBlockY);
}

// Initialisation and all iterations, kernels queued back to back.
template <class Window>
void runPatchMatch(const PatchMatchParams& P, const GpuSampler& sampler, PixelState state,
                   int iterations, cudaStream_t stream) {
  const dim3 block(kBlockX, kBlockY);
  initializeKernel<Window><<<gridFor(P.width, P.height), block, 0, stream>>>(P, sampler, state);
  AMHMVS_CUDA_CHECK_LAUNCH();
  const dim3 half_grid = gridFor((P.width + 1) / 2, P.height);
  for (int iteration = 0; iteration < iterations; ++iteration) {
    for (int colour = 0; colour < 2; ++colour) {
      updateKernel<Window><<<half_grid, block, 0, stream>>>(P, sampler, state, P.first_iteration + iteration,
                                                            colour);
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
      // No driver or no device is the ordinary CPU-only machine: say so plainly.
      const bool absent = status == cudaSuccess || status == cudaErrorNoDevice ||
                          status == cudaErrorInsufficientDriver;
      *description = absent ? std::string("no GPU found")
                            : std::string("no usable GPU: ") + cudaGetErrorString(status);
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

// An estimate's outputs on the device.
struct OutputBuffers {
  cuda::DeviceBuffer<float> depth, normal, cost;

  void reserve(size_t pixels) {
    depth.reserve(pixels);
    normal.reserve(3 * pixels);
    cost.reserve(pixels);
  }
  size_t bytes() const { return depth.bytes() + normal.bytes() + cost.bytes(); }
};

// Per-pixel buffers of the estimates, reused (grow only).
struct WorkBuffers {
  cuda::DeviceBuffer<uint8_t> reference;
  cuda::DeviceBuffer<Plane> planes;
  cuda::DeviceBuffer<float> costs;
  cuda::DeviceBuffer<uint32_t> selected;
  cuda::DeviceBuffer<int8_t> best_view;
  cuda::DeviceBuffer<float> raw_depth;
  // Two sets, used in turn: the last estimate's outputs stay valid during
  // the next one (the pipeline fuses a keyframe while the next is estimated).
  OutputBuffers outputs[2];
  int next_output = 0;
  // The coarser scales' outputs of a coarse-to-fine estimate: never one of
  // the two sets above, which may hold the last result while it is fused;
  // with the reference image they were estimated on, the next scale's start
  // is carried from them on the device.
  OutputBuffers intermediate;
  cuda::DeviceBuffer<uint8_t> intermediate_reference;
  // A full-size first pass that a second one refines (the planar prior): its
  // own set, since it reads the intermediate set (its coarser scale) while
  // it runs, and the last result may still be fused.
  OutputBuffers first_pass;
  const float* intermediate_host_depth = nullptr;  // their download, while it is the last estimate's
  int intermediate_width = 0, intermediate_height = 0;
  // Geometric pass only: source depth maps, prior depth and normals.
  cuda::DeviceBuffer<float> source_depths, prior_depth, prior_normal;
  // The planar prior's planes (planar_prior_pixel.h).
  cuda::DeviceBuffer<float> planar_depth, planar_normal;

  void reserve(size_t pixels) {
    reference.reserve(pixels);
    planes.reserve(pixels);
    costs.reserve(pixels);
    selected.reserve(pixels);
    best_view.reserve(pixels);
    raw_depth.reserve(pixels);
  }
  size_t bytes() const {
    return reference.bytes() + planes.bytes() + costs.bytes() + selected.bytes() + best_view.bytes() +
           raw_depth.bytes() + outputs[0].bytes() + outputs[1].bytes() + intermediate.bytes() + first_pass.bytes() +
           intermediate_reference.bytes() + source_depths.bytes() +
           prior_depth.bytes() + prior_normal.bytes() + planar_depth.bytes() + planar_normal.bytes();
  }
};

class CudaState {
 public:
  explicit CudaState(const EstimatorResources& resources)
      : budget_bytes(resources.device_image_budget_bytes), pool(budget_bytes), coarser_pool(0) {}

  // The pool of an estimate's images: coarse-to-fine's coarser copies have
  // their own, with slots of their size (in the full-size pool a quarter-size
  // copy took a whole slot, and the first full-size estimate after it grew
  // the slots and dropped every resident image). Once coarser copies are
  // used, they get a fifth of the budget: as many images as the other four
  // fifths hold at twice their width and height.
  cuda::DeviceImagePool& poolFor(CudaOutputUse use) {
    if (use != CudaOutputUse::kIntermediate) return pool;
    if (!coarser_pool_used) {
      coarser_pool_used = true;
      pool.setBudget(budget_bytes - budget_bytes / 5);
      coarser_pool.setBudget(budget_bytes / 5);
    }
    return coarser_pool;
  }
  void forget(int64_t key) {
    pool.forget(key);
    coarser_pool.forget(key);
  }
  void forgetAll() {
    pool.forgetAll();
    coarser_pool.forgetAll();
  }
  DeviceCacheStats stats() const {
    DeviceCacheStats both = pool.stats();
    both.budget_bytes = budget_bytes;
    both.add(coarser_pool.stats());
    both.work_bytes = work.bytes();
    return both;
  }

  const size_t budget_bytes;
  cuda::CudaStream stream;
  cuda::DeviceImagePool pool;          // full-size images (one per scale-1 estimate)
  cuda::DeviceImagePool coarser_pool;  // coarse-to-fine's coarser copies
  bool coarser_pool_used = false;
  WorkBuffers work;
  cuda::PinnedBuffer<uint8_t> source_staging, reference_staging;
  cuda::CudaEvent start, uploaded, stop;
  DeviceDepthMap last_outputs;  // work.outputs of the last estimate
};

CudaState* createCudaState(const EstimatorResources& resources) { return new CudaState(resources); }
void destroyCudaState(CudaState* state) { delete state; }
void forgetOnCuda(CudaState& state, int64_t key) { state.forget(key); }
void forgetAllOnCuda(CudaState& state) { state.forgetAll(); }

DeviceDepthMap cudaLastOutputs(const CudaState& state) { return state.last_outputs; }

DeviceCacheStats cudaCacheStats(const CudaState& state) { return state.stats(); }

namespace {

// The images of `problem` in the pool (sources, then a keyed reference) and
// the reference in the linear buffer the kernels read; sets each source's
// layer in `P`. Everything is queued on the state's stream.
void placeImages(CudaState& state, cuda::DeviceImagePool& pool, const DepthProblem& problem, PatchMatchParams* P) {
  const cudaStream_t stream = state.stream.get();
  std::vector<cuda::PoolRequest> requests;
  for (size_t j = 0; j < problem.source_images.size(); ++j) {
    requests.push_back({problem.source_images[j], problem.source_keys.empty() ? kNoImageKey : problem.source_keys[j]});
  }
  const bool keyed_reference = problem.reference_key != kNoImageKey;
  // A keyed reference is a later keyframe's source: upload it once, into the pool.
  if (keyed_reference) requests.push_back({problem.reference_image, problem.reference_key});
  const std::vector<int> layers = pool.place(requests, stream, &state.source_staging);
  for (int j = 0; j < P->num_sources; ++j) P->sources[j].layer = layers[j];

  const ImageViewU8& reference = problem.reference_image;
  const size_t pixels = reference.pixelCount();
  if (keyed_reference) {
    pool.copyToLinear(layers.back(), reference.width, reference.height, state.work.reference.get(), stream);
  } else {
    state.reference_staging.reserve(pixels);
    std::memcpy(state.reference_staging.get(), reference.data, pixels);
    state.work.reference.uploadAsync(state.reference_staging.get(), pixels, stream);
  }
}

// The start of this scale of a coarse-to-fine estimate: the coarser scale's
// planes carried into the prior buffers, on the device. They come from the
// intermediate outputs when the coarser estimate was the last one here (the
// driver's order), else they are uploaded first. Queued on the state's
// stream after placeImages (it reads this scale's reference image).
void carryCoarserPlanes(CudaState& state, const DepthProblem& problem, bool coarser_on_device, PatchMatchParams* P) {
  const DepthProblem::CoarserScale& coarser = *problem.coarser;
  const cudaStream_t stream = state.stream.get();
  WorkBuffers& work = state.work;
  if (!coarser_on_device) {
    const size_t from_pixels = coarser.image.pixelCount();
    work.intermediate.reserve(from_pixels);
    work.intermediate_reference.reserve(from_pixels);
    work.intermediate.depth.uploadAsync(coarser.depth.data, from_pixels, stream);
    work.intermediate.normal.uploadAsync(coarser.normal.data, 3 * from_pixels, stream);
    work.intermediate_reference.uploadAsync(coarser.image.data, from_pixels, stream);
  }
  const size_t pixels = static_cast<size_t>(P->width) * P->height;
  work.prior_depth.reserve(pixels);
  work.prior_normal.reserve(3 * pixels);
  const PlaneResampling resampling{rayCamera(coarser.camera),
                                   rayCamera(problem.reference_camera),
                                   work.intermediate.depth.get(),
                                   work.intermediate.normal.get(),
                                   work.intermediate_reference.get(),
                                   work.reference.get(),
                                   -0.5f / (kResamplingSigmaIntensity * kResamplingSigmaIntensity)};
  resampleKernel<<<gridFor(P->width, P->height), dim3(kBlockX, kBlockY), 0, stream>>>(
      resampling, work.prior_depth.get(), work.prior_normal.get());
  AMHMVS_CUDA_CHECK_LAUNCH();
  P->prior_depth = work.prior_depth.get();
  P->prior_normal = work.prior_normal.get();
}

}  // namespace

DepthMap estimateOnCuda(CudaState& state, const PatchMatchOptions& options, const PatchMatchParams& params,
                        const DepthProblem& problem, CudaOutputUse use) {
  const cudaStream_t stream = state.stream.get();
  PatchMatchParams P = params;
  const int width = P.width, height = P.height;
  const size_t pixels = static_cast<size_t>(width) * height;
  WorkBuffers& work = state.work;
  // The set the estimate before the last one wrote (the last one's stays
  // valid); a failed estimate leaves it to the next.
  const bool result = use == CudaOutputUse::kResult;
  const bool intermediate = use == CudaOutputUse::kIntermediate;
  const int output_set = work.next_output;
  OutputBuffers& output = result ? work.outputs[output_set] : intermediate ? work.intermediate : work.first_pass;
  cuda::DeviceImagePool& pool = state.poolFor(use);
  DepthMap out;
  state.last_outputs = DeviceDepthMap();
  // A coarser scale estimated here just before: its maps are on the device.
  const bool coarser_on_device = problem.coarser && work.intermediate_host_depth == problem.coarser->depth.data &&
                                 work.intermediate_width == problem.coarser->camera.width &&
                                 work.intermediate_height == problem.coarser->camera.height;
  work.intermediate_host_depth = nullptr;  // this estimate replaces or invalidates them
  try {
    state.start.record(stream);
    work.reserve(pixels);
    output.reserve(pixels);
    placeImages(state, pool, problem, &P);
    // Host buffers live until the stream is synchronised below.
    const std::vector<float> source_depths = concatenateSourceDepths(problem, &P);
    if (!source_depths.empty()) {
      work.source_depths.reserve(source_depths.size());
      work.source_depths.uploadAsync(source_depths.data(), source_depths.size(), stream);
      P.source_depths = work.source_depths.get();
    }
    if (problem.coarser) carryCoarserPlanes(state, problem, coarser_on_device, &P);
    // A plane map of the problem (depth, 3-channel normals) into device buffers.
    const auto uploadPlaneMap = [&](const ImageViewF& depth, const ImageViewF& normal,
                                    cuda::DeviceBuffer<float>* device_depth, cuda::DeviceBuffer<float>* device_normal,
                                    const float** depth_out, const float** normal_out) {
      if (!depth.data) return;
      device_depth->reserve(pixels);
      device_normal->reserve(3 * pixels);
      device_depth->uploadAsync(depth.data, pixels, stream);
      device_normal->uploadAsync(normal.data, 3 * pixels, stream);
      *depth_out = device_depth->get();
      *normal_out = device_normal->get();
    };
    uploadPlaneMap(problem.prior_depth, problem.prior_normal, &work.prior_depth, &work.prior_normal, &P.prior_depth,
                   &P.prior_normal);
    uploadPlaneMap(problem.planar_prior_depth, problem.planar_prior_normal, &work.planar_depth, &work.planar_normal,
                   &P.planar.depth, &P.planar.normal);
    const PixelState pixel_state{work.planes.get(), work.costs.get(), work.selected.get(), work.best_view.get()};
    const GpuSampler sampler{work.reference.get(), width, height, pool.texture()};
    state.uploaded.record(stream);

    withWindowType(P, [&](auto window) {
      runPatchMatch<typename decltype(window)::type>(P, sampler, pixel_state, options.num_iterations, stream);
    });
    const dim3 block(kBlockX, kBlockY);
    outputKernel<<<gridFor(width, height), block, 0, stream>>>(P, pixel_state, work.raw_depth.get(),
                                                               output.normal.get(), output.cost.get());
    AMHMVS_CUDA_CHECK_LAUNCH();
    medianKernel<<<gridFor(width, height), block, 0, stream>>>(width, height, options.median_filter_size,
                                                               work.raw_depth.get(), output.depth.get());
    AMHMVS_CUDA_CHECK_LAUNCH();

    out.backend = Backend::kCuda;
    out.depth = ImageF(width, height);
    out.normal = ImageF(width, height, 3);
    out.cost = ImageF(width, height);
    output.depth.downloadAsync(out.depth.data.data(), pixels, stream);
    output.normal.downloadAsync(out.normal.data.data(), 3 * pixels, stream);
    output.cost.downloadAsync(out.cost.data.data(), pixels, stream);
    if (intermediate) {  // the next scale carries these maps from its reference image
      work.intermediate_reference.reserve(pixels);
      AMHMVS_CUDA_CHECK(cudaMemcpyAsync(work.intermediate_reference.get(), work.reference.get(), pixels,
                                        cudaMemcpyDeviceToDevice, stream));
    }
    state.stop.record(stream);
    state.stream.synchronize();
    pool.finish();
  } catch (...) {
    // Nothing half-uploaded may stay resident; the stream must be idle
    // before the staging memory is reused.
    cudaStreamSynchronize(stream);
    pool.finish();
    pool.forgetAll();
    throw;
  }
  out.milliseconds = state.stop.millisecondsSince(state.start);
  out.compute_milliseconds = state.stop.millisecondsSince(state.uploaded);
  const DeviceCacheStats memory = state.stats();
  out.gpu_memory_bytes = memory.pool_bytes + memory.work_bytes;
  if (intermediate) {
    work.intermediate_host_depth = out.depth.data.data();
    work.intermediate_width = width;
    work.intermediate_height = height;
  }
  if (!result) return out;
  work.next_output = output_set ^ 1;
  state.last_outputs.host_depth = out.depth.data.data();
  state.last_outputs.host_normal = out.normal.data.data();
  state.last_outputs.host_cost = out.cost.data.data();
  state.last_outputs.depth = output.depth.get();
  state.last_outputs.normal = output.normal.get();
  state.last_outputs.cost = output.cost.get();
  state.last_outputs.width = width;
  state.last_outputs.height = height;
  return out;
}

}  // namespace mvs
}  // namespace amhmvs
