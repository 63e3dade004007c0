// RefinedRelativePoses (refined_relative_poses.h): the pose refinement's
// relative poses, placed at the reference's current pose, either direction.
#include "amhmvs_mapping/mapping/refined_relative_poses.h"

#include <gtest/gtest.h>

#include "amhmvs_mapping/mapping/keyframe_store.h"
#include "mapping_test_helpers.h"

namespace amhmvs {
namespace {

PinholeCamera cameraAt(const Eigen::Isometry3d& camera_to_world) {
  PinholeCamera camera;
  camera.fx = camera.fy = 100;
  camera.cx = 31.5;
  camera.cy = 23.5;
  camera.width = 64;
  camera.height = 48;
  setCameraToWorld(camera_to_world, &camera);
  return camera;
}

void expectSamePose(const PinholeCamera& a, const PinholeCamera& b) {
  EXPECT_LT((a.R - b.R).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((a.t - b.t).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(RefinedRelativePoses, PlacesTheRefinedSourceAtTheReferencesPose) {
  const PinholeCamera reference = cameraAt(test::poseAt({1, 0, 0}, 10));
  const PinholeCamera refined_source = cameraAt(test::poseAt({1.3, 0.02, -0.01}, 14));
  RefinedRelativePoses poses;
  poses.record(7, reference, 9, refined_source);
  EXPECT_EQ(poses.size(), 1u);

  PinholeCamera tracker = cameraAt(test::poseAt({1.28, 0, 0}, 13));  // the tracker's, a little off
  ASSERT_TRUE(poses.place(7, reference, 9, &tracker));
  expectSamePose(tracker, refined_source);
  EXPECT_EQ(tracker.fx, 100);  // intrinsics kept

  // The other direction: the reference at its pose relative to the source.
  PinholeCamera back = cameraAt(Eigen::Isometry3d::Identity());
  ASSERT_TRUE(poses.place(9, refined_source, 7, &back));
  expectSamePose(back, reference);

  // A loop closure moves both: the pair keeps its relative pose.
  const Eigen::Isometry3d moved = test::poseAt({-2, 5, 0.5}, 40);
  const PinholeCamera moved_reference = cameraAt(moved * cameraToWorld(reference));
  ASSERT_TRUE(poses.place(7, moved_reference, 9, &tracker));
  expectSamePose(tracker, cameraAt(moved * cameraToWorld(refined_source)));
}

TEST(RefinedRelativePoses, UnknownDroppedAndForgottenPairsLeaveTheCameraAlone) {
  const PinholeCamera a = cameraAt(test::poseAt({0, 0, 0}));
  const PinholeCamera b = cameraAt(test::poseAt({0.2, 0, 0}, 3));
  const PinholeCamera untouched = cameraAt(test::poseAt({5, 5, 5}, 90));
  RefinedRelativePoses poses;
  poses.record(1, a, 2, b);
  poses.record(1, a, 3, b);
  poses.record(4, a, 1, b);
  PinholeCamera camera = untouched;
  EXPECT_FALSE(poses.place(2, b, 3, &camera));  // never recorded together
  expectSamePose(camera, untouched);

  poses.drop(1, 3);
  EXPECT_FALSE(poses.place(1, a, 3, &camera));
  expectSamePose(camera, untouched);
  EXPECT_EQ(poses.size(), 2u);

  poses.forget(1);  // both pairs with keyframe 1, as reference and as source
  EXPECT_EQ(poses.size(), 0u);
  EXPECT_FALSE(poses.place(1, a, 2, &camera));
  EXPECT_FALSE(poses.place(4, a, 1, &camera));
  expectSamePose(camera, untouched);
}

}  // namespace
}  // namespace amhmvs
