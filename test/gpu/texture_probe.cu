#include "../../cuda/cuda_check.h"
#include "../../cuda/layered_texture.h"
#include "texture_probe.h"

namespace amhmvs {
namespace {

__global__ void sampleKernel(cudaTextureObject_t texture, const float* xs, const float* ys, int n,
                             float* out) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < n) out[i] = tex2DLayered<float>(texture, xs[i] + 0.5f, ys[i] + 0.5f, 0) * 255.0f;
}

}  // namespace

std::vector<float> sampleTextureOnGpu(const ImageU8& image, const std::vector<float>& xs,
                                      const std::vector<float>& ys) {
  cuda::LayeredTexture8 texture({&image});
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
