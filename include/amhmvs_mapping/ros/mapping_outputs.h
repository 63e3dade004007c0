// Outputs of the mapping nodelet (in its namespace):
//   depth/image (REP-118 32FC1 z-depth, NaN invalid) + depth/camera_info,
//   depth_mm/image (16UC1 millimetres, 0 invalid) + depth_mm/camera_info
//     with ~publish_depth_mm,
//   confidence/image, depth/preview (bgr8): per depth map, with the
//     keyframe's own stamp and optical frame (late and refined maps too);
//     with ~confidence/enabled (default) when the keyframe is fused, the
//     depth NaN where the calibrated confidence is below
//     ~confidence/min_probability;
//   keyframe_cloud: a keyframe's fused points (its optical frame), when it is
//     fused (again, after a refinement);
//   map: the global voxel map in the fixed frame, latched, published when it
//     changed (at most once per ~map_publish_period) and to a new subscriber;
//   mesh (visualization_msgs/Marker, TRIANGLE_LIST) and surface (its
//     vertices as a cloud): with ~surface/enabled, the surface map in the
//     fixed frame, latched, published with the map;
//   keyframe_markers: keyframe frusta and the newest source links;
//   tf: ~view_frame (static, child of the fixed frame) where the first
//     keyframe with depth looked, the target of the rviz config's view.
// Each is built only while someone subscribes (the view frame once).
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>

#include <image_transport/image_transport.h>
#include <ros/ros.h>
#include <std_msgs/Header.h>
#include <tf2_ros/static_transform_broadcaster.h>

#include "amhmvs_mapping/mapping/mapping_pipeline.h"
#include "amhmvs_mapping/ros/mapping_config.h"

namespace amhmvs_mapping {

// The ROS header (stamp, optical frame) of each keyframe id: set by the input
// threads, read by the worker when a keyframe's outputs are published.
class KeyframeHeaders {
 public:
  void set(int64_t id, const std_msgs::Header& header);
  // False when the id is unknown (e.g. forgotten by a reset).
  bool get(int64_t id, std_msgs::Header* header) const;
  void erase(int64_t id);
  void clear();

 private:
  mutable std::mutex mutex_;
  std::map<int64_t, std_msgs::Header> headers_;
};

class MappingOutputs {
 public:
  // `on_map_subscriber`: called when a subscriber connects to `map` (the
  // worker then publishes a current map at once).
  MappingOutputs(ros::NodeHandle& nh, const MappingConfig& config, std::function<void()> on_map_subscriber);

  // Publishes what one pipeline result produced.
  void publish(const amhmvs::KeyframeResult& result, const KeyframeHeaders& headers,
               const amhmvs::MappingPipeline& pipeline);
  // Publishes the global map when it changed and the period has passed, or
  // when `requested` (a new subscriber); only while someone subscribes.
  void publishMap(const amhmvs::MappingPipeline& pipeline, bool requested);
  uint64_t mapPublications() const { return map_publications_; }
  // The next keyframe with depth places the view frame again (after a reset).
  void replaceViewFrame() { view_published_ = false; }

 private:
  MappingConfig config_;
  std::unique_ptr<image_transport::ImageTransport> it_;
  image_transport::CameraPublisher depth_pub_, depth_mm_pub_;  // depth_mm_pub_: with publish_depth_mm
  image_transport::Publisher confidence_pub_, preview_pub_;
  ros::Publisher cloud_pub_, map_pub_, markers_pub_;
  ros::Publisher mesh_pub_, surface_pub_;  // with surface/enabled
  uint64_t published_map_revision_ = 0;
  bool published_map_ = false;
  ros::WallTime last_map_publish_;
  std::unique_ptr<tf2_ros::StaticTransformBroadcaster> view_broadcaster_;
  std::atomic<bool> view_published_{false};
  void publishViewFrame(const amhmvs::KeyframeResult& result, const ros::Time& stamp);
  void publishRefinedDepths(const amhmvs::KeyframeResult& result, const KeyframeHeaders& headers);
  // depth/image, depth_mm/image, confidence/image (made only when
  // subscribed) and depth/preview of one depth map.
  void publishDepth(const amhmvs::ImageF& depth, const amhmvs::PinholeCamera& camera, const std_msgs::Header& header,
                    const std::function<sensor_msgs::ImagePtr()>& confidence);
  uint64_t map_publications_ = 0;
};

}  // namespace amhmvs_mapping
