// SceneImageCache: problems of one scene with each image read once, the view
// ids as image keys, and a byte bound that never drops an image of the
// problem being built (the fountain x0.25 views at 96 px).
#include <gtest/gtest.h>

#include <cstring>
#include <set>
#include <vector>

#include "amhmvs_mapping/mvs/problem_builder.h"
#include "depth_job.h"
#include "test_helpers.h"

namespace amhmvs {
namespace {

ProblemOptions smallProblems() {
  ProblemOptions options;
  options.max_sources = 4;
  options.max_image_size = 96;
  return options;
}

bool sameProblem(const DepthProblem& a, const DepthProblem& b) {
  auto same_pixels = [](const ImageViewU8& x, const ImageViewU8& y) {
    return x.width == y.width && x.height == y.height &&
           std::memcmp(x.data, y.data, x.pixelCount() * x.channels) == 0;
  };
  if (!same_pixels(a.reference_image, b.reference_image) || a.source_images.size() != b.source_images.size() ||
      a.depth_min != b.depth_min || a.depth_max != b.depth_max)
    return false;
  for (size_t j = 0; j < a.source_images.size(); ++j) {
    if (!same_pixels(a.source_images[j], b.source_images[j]) ||
        a.source_cameras[j].fx != b.source_cameras[j].fx)
      return false;
  }
  return true;
}

TEST(SceneImageCache, SameProblemsAsMakeDepthProblemWithViewIdsAsKeys) {
  AMHMVS_REQUIRE_DATA(folder, "mvsnet/fountain_x0.25");
  const Scene scene = readInputFolder(folder, 4);
  SceneImageCache cache(scene, smallProblems());
  for (int id : {0, 5, 10}) {
    const DepthProblem problem = cache.makeProblem(id);
    const OwnedDepthProblem owned = makeDepthProblem(scene, id, smallProblems());
    EXPECT_TRUE(sameProblem(problem, owned.problem)) << "view " << id;
    EXPECT_EQ(problem.reference_key, id);
    ASSERT_EQ(problem.source_keys.size(), problem.source_images.size());
    const auto& ranked = scene.sources.at(id);
    for (size_t j = 0; j < problem.source_keys.size(); ++j) EXPECT_EQ(problem.source_keys[j], ranked[j].view_id);
  }
}

TEST(SceneImageCache, ByteBoundDropsLeastRecentlyUsedButNeverTheCurrentProblem) {
  AMHMVS_REQUIRE_DATA(folder, "mvsnet/fountain_x0.25");
  const Scene scene = readInputFolder(folder, 4);
  const size_t image_bytes = 96 * 64;  // 768x512 scaled to 96 px
  SceneImageCache cache(scene, smallProblems(), 6 * image_bytes);
  std::vector<int64_t> dropped;
  cache.onDrop([&](int64_t id) { dropped.push_back(id); });
  for (const SceneView& view : scene.views) {
    const DepthProblem problem = cache.makeProblem(view.id);
    EXPECT_LE(cache.bytes(), 6 * image_bytes) << "view " << view.id;
    std::set<int64_t> used(problem.source_keys.begin(), problem.source_keys.end());
    used.insert(problem.reference_key);
    for (int64_t id : dropped) EXPECT_EQ(used.count(id), 0u) << "dropped " << id << " while view " << view.id << " uses it";
    // The views must still be readable: the pixels of a dropped image would be gone.
    const OwnedDepthProblem owned = makeDepthProblem(scene, view.id, smallProblems());
    EXPECT_TRUE(sameProblem(problem, owned.problem)) << "view " << view.id;
    dropped.clear();
  }
  // A bound below one problem's images keeps that problem whole.
  SceneImageCache tiny(scene, smallProblems(), 1);
  const DepthProblem problem = tiny.makeProblem(5);
  EXPECT_EQ(tiny.bytes(), 5 * image_bytes);
  EXPECT_TRUE(sameProblem(problem, makeDepthProblem(scene, 5, smallProblems()).problem));
}

}  // namespace
}  // namespace amhmvs
