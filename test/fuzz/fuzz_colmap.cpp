// libFuzzer target: a COLMAP model (cameras, images, points3D) read as text or
// binary (AMHMVS_FUZZ_COLMAP_BINARY 0/1): the input is the three files joined
// by the separator line of fuzz_input.h. The image folder holds header-only
// 64x48 PGM files 0.pgm .. 9.pgm, the names the seeds use, so that inputs get
// past the image checks into the scene assembly.
#include <cstdio>

#include "amhmvs_mapping/io/colmap_model.h"
#include "fuzz_input.h"

namespace {

const std::string& imageDir() {
  static const std::string dir = [] {
    const std::string header = "P5\n64 48\n255\n";
    for (int i = 0; i < 10; ++i) {
      amhmvs::fuzz::writeScratch("images/" + std::to_string(i) + ".pgm",
                                 reinterpret_cast<const uint8_t*>(header.data()), header.size());
    }
    return amhmvs::fuzz::scratchDir() + "/images";
  }();
  return dir;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const char* ext = AMHMVS_FUZZ_COLMAP_BINARY ? ".bin" : ".txt";
  const std::vector<std::string> parts = amhmvs::fuzz::splitParts(data, size, 3);
  const char* names[3] = {"cameras", "images", "points3D"};
  for (int i = 0; i < 3; ++i) {
    amhmvs::fuzz::writeScratch(std::string("sparse/") + names[i] + ext,
                               reinterpret_cast<const uint8_t*>(parts[i].data()), parts[i].size());
  }
  amhmvs::ColmapOptions options;
  options.format = AMHMVS_FUZZ_COLMAP_BINARY ? amhmvs::ColmapOptions::Format::kBinary
                                             : amhmvs::ColmapOptions::Format::kText;
  amhmvs::fuzz::expectOnlyInputErrors([&] {
    const amhmvs::Scene scene =
        amhmvs::readColmapModel(amhmvs::fuzz::scratchDir() + "/sparse", imageDir(), options);
    for (const amhmvs::SceneView& view : scene.views) {
      // What the reader promises of every view it accepts.
      if (view.id < 0 || !view.camera.validate().empty() ||
          !amhmvs::conditioningProblem(view.camera, view.depth_min, view.depth_max).empty()) {
        std::abort();
      }
    }
  });
  return 0;
}
