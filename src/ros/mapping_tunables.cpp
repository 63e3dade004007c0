#include "amhmvs_mapping/ros/mapping_tunables.h"

#include <cmath>

namespace amhmvs_mapping {
namespace {

double thresholdParam(float value) { return std::isinf(value) ? 0.0 : value; }
float thresholdFrom(double param) { return param == 0 ? amhmvs::FusionOptions::kOff : static_cast<float>(param); }

}  // namespace

MappingTunablesConfig tunablesFrom(const MappingConfig& config) {
  const amhmvs::FusionOptions& fusion = config.pipeline.mapper.fusion;
  MappingTunablesConfig t = MappingTunablesConfig::__getDefault__();
  t.iterations = config.pipeline.estimator.num_iterations;
  t.max_sources = config.pipeline.mapper.sources.max_sources;
  t.keyframe_min_translation = config.keyframes.min_translation_m;
  t.keyframe_min_rotation_deg = config.keyframes.min_rotation_deg;
  t.max_reprojection_error = thresholdParam(fusion.max_reprojection_error);
  t.max_relative_depth_difference = thresholdParam(fusion.max_relative_depth_difference);
  t.max_normal_angle_deg = thresholdParam(fusion.max_normal_angle_deg);
  t.min_consistent_views = fusion.min_consistent_views;
  t.max_cost = thresholdParam(fusion.max_cost);
  t.voxel_size = config.pipeline.mapper.map.leaf_size;
  t.min_points_per_voxel = config.pipeline.mapper.map.min_points_per_voxel;
  return t;
}

void applyTunables(const MappingTunablesConfig& t, MappingConfig* config) {
  amhmvs::FusionOptions& fusion = config->pipeline.mapper.fusion;
  config->pipeline.estimator.num_iterations = t.iterations;
  config->pipeline.mapper.sources.max_sources = t.max_sources;
  config->keyframes.min_translation_m = t.keyframe_min_translation;
  config->keyframes.min_rotation_deg = t.keyframe_min_rotation_deg;
  fusion.max_reprojection_error = thresholdFrom(t.max_reprojection_error);
  fusion.max_relative_depth_difference = thresholdFrom(t.max_relative_depth_difference);
  fusion.max_normal_angle_deg = thresholdFrom(t.max_normal_angle_deg);
  fusion.min_consistent_views = t.min_consistent_views;
  fusion.max_cost = thresholdFrom(t.max_cost);
  config->pipeline.mapper.map.leaf_size = t.voxel_size;
  config->pipeline.mapper.map.min_points_per_voxel = t.min_points_per_voxel;
}

}  // namespace amhmvs_mapping
