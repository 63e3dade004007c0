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
  // Keyframes that come with the tracker's velocity (Keyframe::velocity) are
  // rectified with its turn rate instead, and with `translation` each row's
  // camera centre (linear velocity) enters the matching cost
  // (mvs/matching_cost.h) and the keyframe bundle adjustment. Off by
  // default: with exact poses it lifts the realism map from 93.2 to 95.8 %
  // within 2 cm, behind the realism tracker it lowers it (README "The
  // tracker's velocity"). Without it (or without a velocity) the rotation
  // only is rectified, with the angular velocity from the previous
  // keyframe's pose: a chord between keyframes misses the velocity by too
  // much for the translation (docs/results/realism_map_session14.md,
  // session 19).
  bool use_tracker_velocity = false;
  bool translation = true;
  // With the keyframe bundle adjustment (pose_refinement.h), a keyframe
  // rectified from chords is rectified again from its adjusted poses: the
  // mean of the chords to the adjusted keyframes before and after it (one
  // side at the ends), as often as they move it by more than 1e-4 rad over
  // a readout. The depth maps that read a re-rectified image are estimated
  // again (pose_refinement's max_pose_reestimates), and its cached features
  // move with it (rectifiedAgain). On the realism room the tracker's chords
  // miss the turn rate by 0.4-5 deg/s, the adjusted ones by 0.1-1.4 inside
  // the run (1.2-2.7 at its ends). Off by default: at 320 px (8 views) the
  // map gains 1.7 points on average (7 of 8 seeds), at 160 px (6 views) it
  // loses 4.2, where even the true turn rate loses 8.4 (README "Rectified
  // again from the adjusted poses").
  bool from_adjusted_poses = false;
  // The noise of the tracker's velocity (std dev per axis of its turn rate,
  // rad/s, and of its linear velocity, m/s). Both > 0, with
  // use_tracker_velocity, translation and the keyframe bundle adjustment:
  // the adjustment solves each such keyframe's velocity too, with the
  // tracker's as the prior (VelocityPrior); the image is rectified again
  // with the solved turn rate (its features move with it) and its rows'
  // centres move with the solved velocity, and the depth maps that read it
  // are estimated again (as from_adjusted_poses). 0: the tracker's velocity
  // is used as it comes. README "Solving the tracker's velocity".
  double tracker_velocity_sigma_rad_s = 0;
  double tracker_velocity_sigma_m_s = 0;

  bool solvesTrackerVelocity() const {
    return use_tracker_velocity && translation && tracker_velocity_sigma_rad_s > 0 && tracker_velocity_sigma_m_s > 0;
  }
  bool enabled() const { return readout_s > 0; }
  // Empty when valid; otherwise one line per problem.
  std::string validate() const;
};

// The image (the size of `camera`) as a global shutter at the middle row's
// orientation would have seen it, see the file comment. Positions outside
// the input take the nearest input pixel.
ImageU8 rectifyRollingShutter(const ImageU8& image, const PinholeCamera& camera, const Eigen::Vector3d& angular_velocity,
                              double readout_s);

// Where a point at `pixel` of the image rectified with angular velocity
// `used` lies in the same (unrectified) image rectified with `wanted`: its
// ray as the rolling shutter saw it, then rectified with `wanted`. Moves
// features found in one rectification into the next.
Eigen::Vector2d rectifiedAgain(const Eigen::Vector2d& pixel, const PinholeCamera& camera, const Eigen::Vector3d& used,
                               const Eigen::Vector3d& wanted, double readout_s);

}  // namespace amhmvs
