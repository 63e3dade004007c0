// A calibrated multi-view scene as read from disk: cameras, image paths,
// optional per-view depth ranges and ranked source views.
#pragma once

#include <limits>
#include <map>
#include <string>
#include <vector>

#include "amhmvs_mapping/core/camera.h"

namespace amhmvs {

struct SceneView {
  int id = -1;             // MVSNet view number, or COLMAP image id
  std::string name;        // file name of the image (e.g. "00000003.png")
  std::string image_path;  // absolute or relative path to the image file
  PinholeCamera camera;    // at the resolution of the image file
  // Optional depth range of the view (NaN when the input gives none).
  double depth_min = std::numeric_limits<double>::quiet_NaN();
  double depth_max = std::numeric_limits<double>::quiet_NaN();
};

struct SourceCandidate {
  int view_id = -1;
  double score = 0;
};

struct Scene {
  std::vector<SceneView> views;
  // Reference view id -> source candidates, best first.
  std::map<int, std::vector<SourceCandidate>> sources;

  // Index into `views` of the view with this id, or -1.
  int indexOf(int view_id) const;
};

}  // namespace amhmvs
