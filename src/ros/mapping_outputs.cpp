#include "amhmvs_mapping/ros/mapping_outputs.h"

#include <sensor_msgs/PointCloud2.h>
#include <visualization_msgs/MarkerArray.h>

#include "amhmvs_mapping/mapping/view_anchor.h"
#include "amhmvs_mapping/ros/keyframe_markers.h"
#include "amhmvs_mapping/ros/ros_conversions.h"

namespace amhmvs_mapping {
namespace {
// Frusta drawn to this fraction of the scene depth: visible, not cluttering.
constexpr double kFrustumDepthFraction = 0.15;
}  // namespace

void KeyframeHeaders::set(int64_t id, const std_msgs::Header& header) {
  std::lock_guard<std::mutex> lock(mutex_);
  headers_[id] = header;
}

bool KeyframeHeaders::get(int64_t id, std_msgs::Header* header) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto found = headers_.find(id);
  if (found == headers_.end()) return false;
  *header = found->second;
  return true;
}

void KeyframeHeaders::erase(int64_t id) {
  std::lock_guard<std::mutex> lock(mutex_);
  headers_.erase(id);
}

void KeyframeHeaders::clear() {
  std::lock_guard<std::mutex> lock(mutex_);
  headers_.clear();
}

namespace {

// Latched: a late subscriber (rviz) gets the last map at once, and its
// connection asks the worker for a current one (no export without subscribers).
template <typename Message>
ros::Publisher advertiseLatched(ros::NodeHandle& nh, const std::string& topic,
                                const std::function<void()>& on_subscriber) {
  return nh.advertise<Message>(
      topic, 1, [on_subscriber](const ros::SingleSubscriberPublisher&) { on_subscriber(); },
      ros::SubscriberStatusCallback(), ros::VoidConstPtr(), true);
}

}  // namespace

MappingOutputs::MappingOutputs(ros::NodeHandle& nh, const MappingConfig& config,
                               std::function<void()> on_map_subscriber)
    : config_(config) {
  it_.reset(new image_transport::ImageTransport(nh));
  depth_pub_ = it_->advertiseCamera("depth/image", 5);
  if (config_.node.publish_depth_mm) depth_mm_pub_ = it_->advertiseCamera("depth_mm/image", 5);
  confidence_pub_ = it_->advertise("confidence/image", 5);
  preview_pub_ = it_->advertise("depth/preview", 5);
  cloud_pub_ = nh.advertise<sensor_msgs::PointCloud2>("keyframe_cloud", 5);
  map_pub_ = advertiseLatched<sensor_msgs::PointCloud2>(nh, "map", on_map_subscriber);
  if (amhmvs::keptSurface(config_.pipeline.mapper).enabled) {
    mesh_pub_ = advertiseLatched<visualization_msgs::Marker>(nh, "mesh", on_map_subscriber);
    surface_pub_ = advertiseLatched<sensor_msgs::PointCloud2>(nh, "surface", on_map_subscriber);
  }
  markers_pub_ = nh.advertise<visualization_msgs::MarkerArray>("keyframe_markers", 5);
  if (!config_.node.view_frame.empty()) view_broadcaster_.reset(new tf2_ros::StaticTransformBroadcaster());
}

void MappingOutputs::publishViewFrame(const amhmvs::KeyframeResult& result, const ros::Time& stamp) {
  Eigen::Vector3d anchor;
  if (!view_broadcaster_ || view_published_ || !result.has_depth ||
      !amhmvs::viewAnchor(result.camera, result.depth->depth, &anchor))
    return;
  geometry_msgs::TransformStamped view;
  view.header.stamp = stamp;
  view.header.frame_id = config_.node.fixed_frame;
  view.child_frame_id = config_.node.view_frame;
  view.transform.translation.x = anchor.x();
  view.transform.translation.y = anchor.y();
  view.transform.translation.z = anchor.z();
  // rviz's orbit view keeps the fixed frame's z up: the view frame's z is the world's up.
  const Eigen::Vector3d up = amhmvs::viewUp(config_.node.view_up, amhmvs::cameraToWorld(result.camera).linear());
  const Eigen::Quaterniond orientation = amhmvs::viewOrientation(up);
  view.transform.rotation.x = orientation.x();
  view.transform.rotation.y = orientation.y();
  view.transform.rotation.z = orientation.z();
  view.transform.rotation.w = orientation.w();
  view_broadcaster_->sendTransform(view);
  view_published_ = true;
  ROS_INFO("view frame %s at (%.2f, %.2f, %.2f) in %s, where keyframe %ld looks, its z up along (%.2f, %.2f, %.2f)",
           config_.node.view_frame.c_str(), anchor.x(), anchor.y(), anchor.z(), config_.node.fixed_frame.c_str(),
           static_cast<long>(result.id), up.x(), up.y(), up.z());
}

void MappingOutputs::publishRefinedDepths(const amhmvs::KeyframeResult& result, const KeyframeHeaders& headers) {
  // depth_filter: a keyframe's depth again, refined by the frames since (its own stamp and frame).
  for (const amhmvs::RefinedDepth& refined : result.refined_depths) {
    std_msgs::Header refined_header;
    if (!headers.get(refined.id, &refined_header)) continue;
    publishDepth(refined.published.depth, refined.camera, refined_header,
                 [&] { return confidenceImageMsg(refined.published, refined_header); });
  }
}

void MappingOutputs::publish(const amhmvs::KeyframeResult& result, const KeyframeHeaders& headers,
                             const amhmvs::MappingPipeline& pipeline) {
  if (result.frame_only) {  // a frame between keyframes: refined depths only
    publishRefinedDepths(result, headers);
    return;
  }
  std_msgs::Header header;
  if (!headers.get(result.id, &header)) return;  // forgotten by a reset meanwhile
  publishViewFrame(result, header.stamp);
  if (markers_pub_.getNumSubscribers() > 0) {
    std::vector<MarkerCamera> cameras;
    pipeline.withMapper([&](const amhmvs::OnlineMapper& mapper) {
      for (int64_t id : mapper.store().ids()) cameras.push_back({id, mapper.store().keyframe(id).camera});
    });
    std_msgs::Header fixed;
    fixed.stamp = header.stamp;
    fixed.frame_id = config_.node.fixed_frame;
    const double frustum_depth = kFrustumDepthFraction * result.selection.scene_depth.depth;
    markers_pub_.publish(keyframeMarkers(cameras, result.id, result.selection.source_ids, frustum_depth, fixed));
  }
  // With the calibrated confidence a depth map is published when its
  // keyframe is fused (masked; possibly after later keyframes), else at once.
  if (config_.pipeline.mapper.confidence.enabled) {
    for (const amhmvs::FusedKeyframe& fused : result.fused) {
      std_msgs::Header fused_header;
      if (fused.published.empty() || !headers.get(fused.id, &fused_header)) continue;
      publishDepth(fused.published.depth, fused.camera, fused_header,
                   [&] { return confidenceImageMsg(fused.published, fused_header); });
    }
  } else if (result.has_depth) {
    publishDepth(result.depth->depth, result.camera, header, [&] { return confidenceImageMsg(result.depth, header); });
  }
  publishRefinedDepths(result, headers);
  // keyframe_cloud: each keyframe this result fused (this one, earlier ones
  // that waited for enough consistency views, or a refined one again), with
  // that keyframe's header.
  if (cloud_pub_.getNumSubscribers() == 0) return;
  for (const amhmvs::FusedKeyframe& fused : result.fused) {
    std_msgs::Header fused_header;
    if (headers.get(fused.id, &fused_header)) cloud_pub_.publish(cloudMsg(keyframeCloud(fused.points), fused_header));
  }
}

void MappingOutputs::publishDepth(const amhmvs::ImageF& depth, const amhmvs::PinholeCamera& camera,
                                  const std_msgs::Header& header,
                                  const std::function<sensor_msgs::ImagePtr()>& confidence) {
  if (depth_pub_.getNumSubscribers() > 0) depth_pub_.publish(depthImageMsg(depth, header), cameraInfoMsg(camera, header));
  if (depth_mm_pub_.getNumSubscribers() > 0)
    depth_mm_pub_.publish(depthImageMillimetresMsg(depth, header), cameraInfoMsg(camera, header));
  if (confidence_pub_.getNumSubscribers() > 0) confidence_pub_.publish(confidence());
  if (preview_pub_.getNumSubscribers() > 0) {
    sensor_msgs::ImagePtr preview = depthPreviewMsg(depth, header);
    if (preview) preview_pub_.publish(preview);
  }
}

void MappingOutputs::publishMap(const amhmvs::MappingPipeline& pipeline, bool requested) {
  const auto subscribed = [](const ros::Publisher& publisher) { return publisher && publisher.getNumSubscribers() > 0; };
  const bool map_wanted = subscribed(map_pub_), mesh_wanted = subscribed(mesh_pub_),
             surface_wanted = subscribed(surface_pub_);
  if (!map_wanted && !mesh_wanted && !surface_wanted) return;  // a new subscriber's connection asks for one
  const ros::WallTime now = ros::WallTime::now();
  const bool due = (now - last_map_publish_).toSec() >= config_.node.map_publish_period;
  sensor_msgs::PointCloud2Ptr map_msg, surface_msg;
  visualization_msgs::MarkerPtr mesh_msg;
  bool exported = false;
  pipeline.withMapper([&](const amhmvs::OnlineMapper& mapper) {
    const bool changed = !published_map_ || mapper.mapRevision() != published_map_revision_;
    if (!requested && !(changed && due)) return;  // unchanged: the latched messages stand
    std_msgs::Header header;
    header.stamp = ros::Time::now();
    header.frame_id = config_.node.fixed_frame;
    if (map_wanted) map_msg = cloudMsg(mapper.map().exportCloud(), header);
    if (mapper.surface() && mesh_wanted) mesh_msg = meshMarkerMsg(mapper.surface()->mesh(), header);
    if (mapper.surface() && surface_wanted) surface_msg = cloudMsg(mapper.surface()->surfaceCloud(), header);
    published_map_revision_ = mapper.mapRevision();
    exported = true;
  });
  if (!exported) return;
  published_map_ = true;
  last_map_publish_ = now;
  if (map_msg) map_pub_.publish(map_msg);
  if (mesh_msg) mesh_pub_.publish(mesh_msg);
  if (surface_msg) surface_pub_.publish(surface_msg);
  ++map_publications_;
}

}  // namespace amhmvs_mapping
