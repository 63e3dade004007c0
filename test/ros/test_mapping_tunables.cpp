// The runtime tunables are parameters of the table: their defaults (read by
// cfg/MappingTunables.cfg from config/mapping.yaml) are the table's, and a
// change goes into the parameter it names, 0 switching a fusion check off.
#include <gtest/gtest.h>

#include <cmath>

#include <dynamic_reconfigure/Config.h>

#include "amhmvs_mapping/ros/mapping_tunables.h"

namespace amhmvs_mapping {
namespace {

TEST(MappingTunables, DefaultsAreTheParameterTables) {
  const MappingTunablesConfig from_table = tunablesFrom(MappingConfig());
  const MappingTunablesConfig cfg = MappingTunablesConfig::__getDefault__();
  EXPECT_EQ(from_table.iterations, cfg.iterations);
  EXPECT_EQ(from_table.max_sources, cfg.max_sources);
  EXPECT_DOUBLE_EQ(from_table.keyframe_min_translation, cfg.keyframe_min_translation);
  EXPECT_DOUBLE_EQ(from_table.keyframe_min_rotation_deg, cfg.keyframe_min_rotation_deg);
  EXPECT_DOUBLE_EQ(from_table.max_reprojection_error, cfg.max_reprojection_error);
  EXPECT_DOUBLE_EQ(from_table.max_relative_depth_difference, cfg.max_relative_depth_difference);
  EXPECT_DOUBLE_EQ(from_table.max_normal_angle_deg, cfg.max_normal_angle_deg);
  EXPECT_EQ(from_table.min_consistent_views, cfg.min_consistent_views);
  EXPECT_DOUBLE_EQ(from_table.max_cost, cfg.max_cost);
  EXPECT_DOUBLE_EQ(from_table.voxel_size, cfg.voxel_size);
  EXPECT_EQ(from_table.min_points_per_voxel, cfg.min_points_per_voxel);
  EXPECT_EQ(cfg.max_sources, 4);  // the product's default, not the component's 8
  EXPECT_DOUBLE_EQ(cfg.max_cost, 0.6);
}

// Every value a tunable's range offers is one the mapper accepts: each
// tunable at both ends of its range (cfg/MappingTunables.cfg), the others at
// their defaults, goes through the parameter table and validates. A range
// wider than the option's checks would make rqt_reconfigure offer values the
// nodelet then refuses.
TEST(MappingTunables, EveryValueOfTheRangesIsAccepted) {
  const MappingConfig defaults;
  const MappingTunablesConfig start = tunablesFrom(defaults);
  const auto& descriptions = MappingTunablesConfig::__getParamDescriptions__();
  ASSERT_EQ(descriptions.size(), 11u);
  for (const auto& description : descriptions) {
    for (const bool at_max : {false, true}) {
      dynamic_reconfigure::Config message;
      (at_max ? MappingTunablesConfig::__getMax__() : MappingTunablesConfig::__getMin__()).__toMessage__(message);
      MappingTunablesConfig tunables = start;
      ASSERT_TRUE(description->fromMessage(message, tunables)) << description->name;
      MappingConfig config = defaults;
      applyTunables(tunables, &config);
      EXPECT_EQ(config.validate(), "") << description->name << " at its " << (at_max ? "maximum" : "minimum");
    }
  }
}

TEST(MappingTunables, ChangesReachTheirParameters) {
  MappingConfig config;
  MappingTunablesConfig t = tunablesFrom(config);
  t.iterations = 3;
  t.max_sources = 7;
  t.keyframe_min_rotation_deg = 12.5;
  t.max_cost = 0;  // off
  t.max_relative_depth_difference = 0.05;
  t.voxel_size = 0.05;
  t.min_points_per_voxel = 4;
  applyTunables(t, &config);
  EXPECT_EQ(config.pipeline.estimator.num_iterations, 3);
  EXPECT_EQ(config.pipeline.mapper.sources.max_sources, 7);
  EXPECT_DOUBLE_EQ(config.keyframes.min_rotation_deg, 12.5);
  EXPECT_TRUE(std::isinf(config.pipeline.mapper.fusion.max_cost));
  EXPECT_FLOAT_EQ(config.pipeline.mapper.fusion.max_relative_depth_difference, 0.05f);
  EXPECT_DOUBLE_EQ(config.pipeline.mapper.map.leaf_size, 0.05);
  EXPECT_EQ(config.pipeline.mapper.map.min_points_per_voxel, 4);
  EXPECT_DOUBLE_EQ(tunablesFrom(config).max_cost, 0.0);  // and reads back as 0
}

}  // namespace
}  // namespace amhmvs_mapping
