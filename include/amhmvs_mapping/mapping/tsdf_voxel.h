// One voxel of the truncated signed distance field (Curless and Levoy 1996;
// projective, as KinectFusion): what a depth image adds to it, written once
// for the CPU loop and a CUDA kernel (mvs/hd.h).
//
// A voxel at z-depth z in a camera whose pixel holds depth d has the signed
// distance d - z along the optical axis: positive in front of the surface
// (free space), negative behind it. Behind by more than the truncation band
// the voxel is hidden and not updated; elsewhere it gets min(1, (d - z) / band)
// with the pixel's weight (its confidence). The voxel keeps the weighted
// sums, so a depth image integrated once can be taken out again exactly
// (sign -1): re-posing a keyframe is "subtract at the old pose, add at the new".
#pragma once

#include "amhmvs_mapping/mvs/hd.h"

namespace amhmvs {

struct TsdfVoxel {
  double distance_sum = 0;  // sum of weight x truncated distance (in bands, [-1, 1])
  double weight = 0;        // sum of weights
  float rgb_sum[3] = {0, 0, 0};  // sum of weight x colour (0..255)

  // The truncated distance in bands; only where weight > 0.
  AMHMVS_HD float distance() const { return static_cast<float>(distance_sum / weight); }
};

// The truncated distance in bands that a pixel of depth `pixel_depth` gives a
// voxel at z-depth `voxel_z`; false where the voxel gets nothing (no depth,
// behind the surface by more than the band).
AMHMVS_HD bool truncatedDistance(float pixel_depth, float voxel_z, float band, float* distance) {
  if (!(pixel_depth > 0) || !(voxel_z > 0)) return false;
  const float signed_distance = pixel_depth - voxel_z;
  if (signed_distance < -band) return false;
  *distance = signed_distance >= band ? 1.0f : signed_distance / band;
  return true;
}

// Adds (sign +1) or takes out (sign -1) one sample.
AMHMVS_HD void accumulateSample(float distance, float weight, const float rgb[3], float sign, TsdfVoxel* voxel) {
  const double w = static_cast<double>(sign) * weight;
  voxel->distance_sum += w * distance;
  voxel->weight += w;
  for (int c = 0; c < 3; ++c) voxel->rgb_sum[c] += sign * weight * rgb[c];
}

}  // namespace amhmvs
