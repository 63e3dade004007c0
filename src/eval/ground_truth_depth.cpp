#include "amhmvs_mapping/eval/ground_truth_depth.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/io/image_io.h"
#include "amhmvs_mapping/io/pfm.h"
#include "amhmvs_mapping/mapping/keyframe_store.h"

namespace amhmvs {

namespace {

bool isPfm(const std::string& path) {
  return path.size() > 4 && (path.compare(path.size() - 4, 4, ".pfm") == 0 ||
                             path.compare(path.size() - 4, 4, ".PFM") == 0);
}

}  // namespace

DepthMapView readGroundTruthDepth(const GroundTruthDepthSource& source, const PinholeCamera& color_camera) {
  DepthMapView view;
  view.camera = source.registered ? color_camera : source.depth_camera;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  if (isPfm(source.path)) {
    view.depth = readPfm(source.path);
    for (float& d : view.depth.data) d = d > 0 && std::isfinite(d) ? static_cast<float>(d * source.metres_per_unit) : nan;
  } else {
    const Image<uint16_t> raw = readImage16(source.path);
    view.depth = ImageF(raw.width, raw.height, 1, nan);
    for (size_t i = 0; i < raw.data.size(); ++i) {
      const uint16_t v = raw.data[i];
      if (v != 0 && v != source.invalid_value) view.depth.data[i] = static_cast<float>(v * source.metres_per_unit);
    }
  }
  if (view.depth.channels != 1) throw InputError(source.path + ": a depth map must have 1 channel");
  return view;
}

DepthMapView trueSurfaceView(const DepthMapView& truth, const PosedFrame& frame) {
  DepthMapView view = truth;
  if (frame.true_camera && frame.ground_truth.registered) {
    view.camera.R = frame.true_camera->R;
    view.camera.t = frame.true_camera->t;
  } else if (frame.true_camera) {
    // A depth camera of its own, where it sits on the colour camera (the
    // tracker's poses of both are rigid), at the true colour pose.
    const Eigen::Isometry3d color_on_depth = cameraToWorld(view.camera).inverse() * cameraToWorld(frame.camera);
    setCameraToWorld(cameraToWorld(*frame.true_camera) * color_on_depth.inverse(), &view.camera);
  }
  return view;
}

ImageF resampleNearest(const ImageF& image, int width, int height) {
  if (image.sameSize(width, height)) return image;
  ImageF out(width, height, image.channels);
  for (int y = 0; y < height; ++y) {
    const int sy = std::min(image.height - 1, static_cast<int>((y + 0.5) * image.height / height));
    for (int x = 0; x < width; ++x) {
      const int sx = std::min(image.width - 1, static_cast<int>((x + 0.5) * image.width / width));
      for (int c = 0; c < image.channels; ++c) out.at(x, y, c) = image.at(sx, sy, c);
    }
  }
  return out;
}

ImageF reprojectDepth(const DepthMapView& from, const PinholeCamera& to) {
  return renderPointDepth(backprojectDepthMaps({from}, 1), to, 0);
}

ImageF groundTruthDepthIn(const DepthMapView& truth, bool registered, const PinholeCamera& camera) {
  return registered ? resampleNearest(truth.depth, camera.width, camera.height) : reprojectDepth(truth, camera);
}

ImageF groundTruthDepthIn(const GroundTruthDepthSource& source, const PinholeCamera& camera) {
  return groundTruthDepthIn(readGroundTruthDepth(source, camera), source.registered, camera);
}

}  // namespace amhmvs
