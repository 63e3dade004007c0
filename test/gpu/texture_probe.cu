#include <algorithm>

#include "cuda_check.h"
#include "layered_texture.h"
#include "texture_probe.h"

namespace amhmvs {
namespace {

__global__ void sampleKernel(cudaTextureObject_t texture, const float* xs, const float* ys, int n,
                             float* out) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) out[i] = tex2DLayered<float>(texture, xs[i] + 0.5f, ys[i] + 0.5f, 0) * 255.0f;
}

constexpr int kFetchesPerThread = 512;

// Independent fetches at coordinates that move by a fraction of a texel, so
// every fetch filters and all hit the texture cache.
__global__ void fetchRateKernel(cudaTextureObject_t texture, float* sink) {
  const float x0 = 8.0f + 0.37f * (threadIdx.x & 31), y0 = 8.0f + 0.61f * (threadIdx.x >> 5);
  float sum[4] = {0, 0, 0, 0};
#pragma unroll 16
  for (int i = 0; i < kFetchesPerThread; ++i) {
    sum[i & 3] += tex2DLayered<float>(texture, x0 + 0.013f * i, y0 + 0.007f * i, 0);
  }
  const float total = sum[0] + sum[1] + sum[2] + sum[3];
  if (total == -1.0f) sink[blockIdx.x] = total;  // never true: keeps the fetches
}

}  // namespace

double measureBilinearFetchRate(int runs) {
  ImageU8 image(64, 64);
  for (size_t i = 0; i < image.data.size(); ++i) image.data[i] = static_cast<uint8_t>(i * 37 + 11);
  cuda::LayeredTexture8 texture({ImageViewU8(image)});
  int device = 0, sms = 0;
  AMHMVS_CUDA_CHECK(cudaGetDevice(&device));
  AMHMVS_CUDA_CHECK(cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, device));
  const int blocks = sms * 32, threads = 256;
  cuda::DeviceBuffer<float> sink(blocks);
  std::vector<float> ms;
  for (int r = 0; r <= runs; ++r) {
    cuda::CudaEvent start, stop;
    start.record();
    fetchRateKernel<<<blocks, threads>>>(texture.object(), sink.get());
    AMHMVS_CUDA_CHECK_LAUNCH();
    stop.record();
    const float elapsed = stop.millisecondsSince(start);
    if (r > 0) ms.push_back(elapsed);  // run 0 is the warm-up
  }
  std::sort(ms.begin(), ms.end());
  const double fetches = static_cast<double>(blocks) * threads * kFetchesPerThread;
  return fetches / (ms[ms.size() / 2] * 1e-3);
}

std::vector<float> sampleTextureOnGpu(const ImageU8& image, const std::vector<float>& xs,
                                      const std::vector<float>& ys) {
  cuda::LayeredTexture8 texture({ImageViewU8(image)});
  const int n = static_cast<int>(xs.size());
  cuda::DeviceBuffer<float> dx(n), dy(n), out(n);
  dx.upload(xs.data());
  dy.upload(ys.data());
  sampleKernel<<<(n + 255) / 256, 256>>>(texture.object(), dx.get(), dy.get(), n, out.get());
  AMHMVS_CUDA_CHECK_LAUNCH();
  std::vector<float> values(n);
  out.download(values.data());
  return values;
}

}  // namespace amhmvs
