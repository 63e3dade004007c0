// A minimal owning image: row-major, interleaved channels.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

namespace amhmvs {

template <typename T>
struct Image {
  int width = 0;
  int height = 0;
  int channels = 1;
  std::vector<T> data;

  Image() = default;
  Image(int w, int h, int c = 1, T fill = T())
      : width(w), height(h), channels(c), data(static_cast<size_t>(w) * h * c, fill) {}

  bool empty() const { return data.empty(); }
  size_t pixelCount() const { return static_cast<size_t>(width) * height; }
  size_t index(int x, int y, int c = 0) const {
    return (static_cast<size_t>(y) * width + x) * channels + c;
  }
  T& at(int x, int y, int c = 0) { return data[index(x, y, c)]; }
  const T& at(int x, int y, int c = 0) const { return data[index(x, y, c)]; }
  bool sameSize(int w, int h) const { return width == w && height == h; }
};

using ImageU8 = Image<uint8_t>;
using ImageF = Image<float>;

// A read-only view of pixels owned elsewhere (an Image, a ROS message, a
// mapped file): what problems, samplers and fusion take, so that no image is
// copied on its way to the estimator. The owner must outlive the view; a view
// of a temporary Image cannot be made (that constructor is deleted).
template <typename T>
struct ImageView {
  const T* data = nullptr;
  int width = 0;
  int height = 0;
  int channels = 1;

  ImageView() = default;
  ImageView(const T* pixels, int w, int h, int c = 1) : data(pixels), width(w), height(h), channels(c) {}
  ImageView(const Image<T>& image)  // NOLINT: implicit on purpose (borrowing is free)
      : data(image.data.data()), width(image.width), height(image.height), channels(image.channels) {}
  ImageView(Image<T>&&) = delete;  // would dangle at the end of the statement

  bool empty() const { return data == nullptr || width <= 0 || height <= 0; }
  size_t pixelCount() const { return static_cast<size_t>(width) * height; }
  size_t index(int x, int y, int c = 0) const {
    return (static_cast<size_t>(y) * width + x) * channels + c;
  }
  const T& at(int x, int y, int c = 0) const { return data[index(x, y, c)]; }
  bool sameSize(int w, int h) const { return width == w && height == h; }
};

using ImageViewU8 = ImageView<uint8_t>;
using ImageViewF = ImageView<float>;

// Luma of an interleaved RGB image (ITU-R BT.601 weights), rounded to 8 bits.
// Single-channel input is returned unchanged.
ImageU8 toGray(const ImageU8& image);

// Area-averaging resize to exactly (width, height); used to scale input images
// down. Pixel centres follow the "about pixel centres" convention
// (x' + 0.5 = (x + 0.5) * s).
ImageU8 resizeArea(const ImageViewU8& image, int width, int height);
inline ImageU8 resizeArea(const ImageU8& image, int width, int height) {
  return resizeArea(ImageViewU8(image), width, height);
}

}  // namespace amhmvs
