// A keyframe's pose correction (w: rotation vector, dc: shift of its centre)
// in units of the tracker's noise: the prior of the star bundle adjustment
// and of the keyframe pose graph (Ceres autodiff functor, 6 residuals).
#pragma once

namespace amhmvs {

struct PosePriorResidual {
  double inverse_rotation_sigma = 1, inverse_position_sigma = 1;

  template <typename T>
  bool operator()(const T* w, const T* dc, T* residual) const {
    for (int i = 0; i < 3; ++i) {
      residual[i] = w[i] * T(inverse_rotation_sigma);
      residual[3 + i] = dc[i] * T(inverse_position_sigma);
    }
    return true;
  }
};

}  // namespace amhmvs
