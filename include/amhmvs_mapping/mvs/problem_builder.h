// Builds estimator problems from a Scene read from disk: loads and scales the
// images, picks the source views and the depth range of a reference view.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <string>

#include "amhmvs_mapping/io/scene.h"
#include "amhmvs_mapping/mvs/depth_estimator.h"

namespace amhmvs {

struct ProblemOptions {
  int max_sources = 10;       // first N of the ranked source list
  int max_image_size = 0;     // longest image side after scaling; 0 = no limit
  double scale = 1.0;         // image scale factor applied before max_image_size
  double depth_min = 0;       // > 0: overrides the view's depth range
  double depth_max = 0;

  std::string validate() const;
};

// Problem for reference view `reference_id`; throws InputError naming the
// view and the problem (unknown id, no sources, no depth range, unreadable
// image, image that does not match its camera). The images are owned by the
// returned object (its `problem` borrows them).
OwnedDepthProblem makeDepthProblem(const Scene& scene, int reference_id, const ProblemOptions& options);

// Problems of one scene whose images are read once: each view's grey image
// at the processed resolution is kept while the total fits in `max_bytes`
// (least recently used dropped first, never one of the current problem).
// Problems borrow the cached images and carry the view ids as image keys, so
// a GPU estimator keeps each image resident as well; on_drop(view id) is
// called when an image leaves the cache (forget its key there).
class SceneImageCache {
 public:
  // `scene` must outlive the cache. Throws InputError for invalid options.
  SceneImageCache(const Scene& scene, const ProblemOptions& options, size_t max_bytes = size_t(1) << 30);
  SceneImageCache(const SceneImageCache&) = delete;
  SceneImageCache& operator=(const SceneImageCache&) = delete;

  void onDrop(std::function<void(int64_t)> on_drop) { on_drop_ = std::move(on_drop); }
  // As makeDepthProblem(); the problem is valid until the next call.
  DepthProblem makeProblem(int reference_id);
  size_t bytes() const { return bytes_; }

 private:
  struct Entry {
    PinholeCamera camera;  // scaled to the image
    ImageU8 image;
    uint64_t last_problem = 0;
  };
  const Entry& view(int index);
  void dropOldImages();

  const Scene& scene_;
  const ProblemOptions options_;
  const size_t max_bytes_;
  std::map<int, Entry> entries_;  // by view id
  size_t bytes_ = 0;
  uint64_t problems_ = 0;
  std::function<void(int64_t)> on_drop_;
};

// Image size after applying scale and max_image_size to (width, height).
void scaledSize(int width, int height, const ProblemOptions& options, int* out_width,
                int* out_height);

}  // namespace amhmvs
