// Conversions between ROS messages and the ROS-free core (images, cameras,
// poses) and the builders of the mapping nodelet's outputs.
//
// Functions that check input return an empty string on success and otherwise
// a readable reason (the caller drops the input and reports the reason).
#pragma once

#include <optional>
#include <string>

#include <Eigen/Geometry>
#include <geometry_msgs/Pose.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/PointCloud2.h>
#include <std_msgs/Header.h>
#include <visualization_msgs/Marker.h>

#include "amhmvs_mapping/core/camera.h"
#include "amhmvs_mapping/core/image.h"
#include "amhmvs_mapping/io/point_cloud_io.h"
#include "amhmvs_mapping/mapping/depth_confidence.h"
#include "amhmvs_mapping/mapping/keyframe_point.h"
#include "amhmvs_mapping/mvs/depth_estimator.h"

namespace amhmvs_mapping {

// Whether the encoding is one the nodelet reads: mono8, mono16, rgb8, bgr8,
// rgba8, bgra8, bayer_rggb8/bggr8/gbrg8/grbg8.
bool supportedEncoding(const std::string& encoding);

// Through cv_bridge: mono8 and mono16 (scaled to 8 bits) -> 1 channel; colour
// (alpha dropped) and Bayer mosaics (debayered) -> 3 channels RGB. Checks
// encoding, size, step and data length first.
std::string imageFromMsg(const sensor_msgs::Image& msg, amhmvs::ImageU8* image);

// Camera-to-world pose; rejects non-finite values and quaternions whose norm
// is not 1 (within 1e-3): a non-rigid pose.
std::string poseFromMsg(const geometry_msgs::Pose& msg, Eigen::Isometry3d* camera_to_world);
geometry_msgs::Pose poseToMsg(const Eigen::Isometry3d& camera_to_world);

// Checks that the CameraInfo matches an image of width x height (its size,
// K with positive finite focal lengths) and returns the pinhole camera with
// the given pose. `distorted` (optional) tells whether D has a non-zero
// coefficient (the nodelet undistorts with ros/image_rectifier.h).
std::string cameraFromMsg(const sensor_msgs::CameraInfo& info, int width, int height,
                          const Eigen::Isometry3d& camera_to_world, amhmvs::PinholeCamera* camera,
                          bool* distorted = nullptr);

// Output builders. `header`: keyframe stamp and the optical frame.
// REP-118: 32FC1, z-depth in metres, NaN where invalid.
sensor_msgs::ImagePtr depthImageMsg(const amhmvs::ImageF& depth, const std_msgs::Header& header);
// REP-118's integer form: 16UC1, z-depth in millimetres (rounded), 0 where
// invalid or beyond 65.535 m (what fits).
sensor_msgs::ImagePtr depthImageMillimetresMsg(const amhmvs::ImageF& depth, const std_msgs::Header& header);
// CameraInfo of the (possibly downscaled) camera: K, P, no distortion.
sensor_msgs::CameraInfoPtr cameraInfoMsg(const amhmvs::PinholeCamera& camera, const std_msgs::Header& header);
// 32FC1 confidence in [0, 1]: 1 - cost / 2 where the depth is valid, else 0
// (without the calibrated confidence, ~confidence/enabled false).
sensor_msgs::ImagePtr confidenceImageMsg(const amhmvs::DepthMap& map, const std_msgs::Header& header);
// 32FC1 calibrated confidence (depth_confidence.h): the probability that the
// depth is within 5 %, in [0, 1], 0 where the depth map has no estimate.
sensor_msgs::ImagePtr confidenceImageMsg(const amhmvs::PublishedDepth& published, const std_msgs::Header& header);
// bgr8 viridis colour map of the depth over its robust (2 %..98 %) range;
// null when the depth has no finite pixel.
sensor_msgs::ImagePtr depthPreviewMsg(const amhmvs::ImageF& depth, const std_msgs::Header& header);
// Point cloud with fields x y z rgb normal_x normal_y normal_z (float32; rgb
// packed 0x00RRGGBB): one point per entry of `cloud` (the global map in the
// fixed frame, or a keyframe's fused points in its optical frame). Entries
// with a non-finite position or normal are left out: no NaN points.
sensor_msgs::PointCloud2Ptr cloudMsg(const amhmvs::PointCloud& cloud, const std_msgs::Header& header);
// A triangle mesh as rviz draws it: one TRIANGLE_LIST marker (three points
// per triangle, a colour per point from the vertices' colours, grey where the
// mesh has none). Triangles with a non-finite vertex are left out.
visualization_msgs::MarkerPtr meshMarkerMsg(const amhmvs::TriangleMesh& mesh, const std_msgs::Header& header);
// A keyframe's fused points (camera frame) in the cloud layout.
amhmvs::PointCloud keyframeCloud(const amhmvs::KeyframePoints& points);

}  // namespace amhmvs_mapping
