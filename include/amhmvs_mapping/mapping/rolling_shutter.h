// Rolling-shutter rectification of keyframe images (issue 12). A rolling
// shutter exposes row y at  t(y) = t_mid + readout_s (y / (height - 1) - 0.5):
// while the camera turns, every row sees the scene from another orientation,
// and a pinhole stereo method fed such an image matches rows against the
// wrong epipolar lines (on the realism room, at the TRUE poses, the map falls
// from 95.6 to 76.4 % within 2 cm with the default profile's 25 ms readout).
//
// The rectified image is what a global shutter at the middle row's pose
// would have seen, for the rotation (the translation during a readout moves
// the image by far less at room distances): with the camera's angular
// velocity w (camera frame), the ray d of an output pixel is seen by the
// rolling shutter in row y' at
//     d' = Exp(-w t(y')) d,      y' = row of K d'      (a fixed point, solved
// by two iterations from y' = y), and the output pixel samples the input there.
// w comes from the tracker's poses of the keyframe and the one before it:
// w = Log(R_prev^T R) / dt (R camera-to-world): the mean over the interval.
#pragma once

#include <string>

#include <Eigen/Core>

#include "amhmvs_mapping/core/camera.h"
#include "amhmvs_mapping/core/image.h"

namespace amhmvs {

struct RollingShutterOptions {
  // Time from the first row's exposure to the last's, seconds (datasheets and
  // calibration tools call it readout or line delay x rows); 0: a global
  // shutter, images are used as they come.
  double readout_s = 0;
  // The angular velocity is taken from the previous keyframe's pose only when
  // it is at most this long before (further back it says little about the
  // motion now); otherwise the image is used as it comes (counted).
  double max_interval_s = 1.0;
  bool enabled() const { return readout_s > 0; }
  // Empty when valid; otherwise one line per problem.
  std::string validate() const;
};

// The image (the size of `camera`) as a global shutter at the middle row's
// orientation would have seen it, see the file comment. Positions outside
// the input take the nearest input pixel.
ImageU8 rectifyRollingShutter(const ImageU8& image, const PinholeCamera& camera, const Eigen::Vector3d& angular_velocity,
                              double readout_s);

}  // namespace amhmvs
