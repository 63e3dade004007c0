// The parameter table is the one list: config/mapping.yaml and
// docs/parameters.md are what it writes, amhmvs_map reads the same names and
// defaults the nodelet does, and bad names and values are refused with the
// name, the value and the closest known name.
#include <gtest/gtest.h>

#include <cstdio>
#include <cmath>
#include <fstream>
#include <functional>
#include <limits>
#include <set>
#include <sstream>
#include <string>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/mapping/mapping_parameters.h"
#include "map_options.h"
#include "test_helpers.h"

namespace amhmvs {
namespace {

std::string sourceFile(const std::string& relative) {
  std::ifstream in(std::string(AMHMVS_SOURCE_DIR) + "/" + relative);
  EXPECT_TRUE(in.good()) << relative;
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

std::string writeTemporary(const std::string& name, const std::string& text) {
  const std::string path = ::testing::TempDir() + "/mapping_parameters_" + name;
  std::ofstream(path) << text;
  return path;
}

std::string errorOf(const std::function<void()>& action) {
  try {
    action();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

const char* kRegenerate = "regenerate: amhmvs_map --print_parameters yaml > config/mapping.yaml, "
                          "--print_parameters markdown > docs/parameters.md";

TEST(MappingParameters, ShippedYamlIsTheTable) {
  EXPECT_EQ(sourceFile("config/mapping.yaml"), mappingParametersYaml()) << kRegenerate;
}

TEST(MappingParameters, ParameterDocsAreTheTable) {
  EXPECT_EQ(sourceFile("docs/parameters.md"), mappingParametersMarkdown()) << kRegenerate;
}

TEST(MappingParameters, EveryDefaultReadsBackAsItself) {
  const MappingParameters defaults;
  for (const MappingParameter& parameter : mappingParameterTable()) {
    SCOPED_TRACE(parameter.name);
    MappingParameters parsed;
    parameter.set(parsed, parameter.get(defaults));
    EXPECT_EQ(parameter.get(parsed), parameter.get(defaults));
  }
  EXPECT_EQ(defaults.validate(), "");
}

TEST(MappingParameters, NamesAndAliasesAreUnique) {
  std::set<std::string> names;
  for (const MappingParameter& parameter : mappingParameterTable()) {
    EXPECT_TRUE(names.insert(parameter.name).second) << parameter.name;
    if (!parameter.alias.empty() && parameter.alias != parameter.name)
      EXPECT_TRUE(names.insert(parameter.alias).second) << parameter.alias;
  }
  EXPECT_GT(names.size(), 100u);
}

TEST(MappingParameters, ShippedYamlReadsBackToTheDefaults) {
  MappingParameters read;
  applyParameterFile(std::string(AMHMVS_SOURCE_DIR) + "/config/mapping.yaml", &read);
  const MappingParameters defaults;
  for (const MappingParameter& parameter : mappingParameterTable())
    EXPECT_EQ(parameter.get(read), parameter.get(defaults)) << parameter.name;
}

TEST(MappingParameters, UnknownNameNamesTheClosest) {
  const std::string path = writeTemporary("typo.yaml", "sources:\n  max_source: 4\n");
  const std::string error = errorOf([&] {
    MappingParameters p;
    applyParameterFile(path, &p);
  });
  EXPECT_NE(error.find("sources/max_source"), std::string::npos) << error;
  EXPECT_NE(error.find("did you mean 'sources/max_sources'"), std::string::npos) << error;
  EXPECT_NE(error.find(path), std::string::npos) << error;
}

TEST(MappingParameters, BadValueNamesParameterAndValue) {
  const std::string error = errorOf([] {
    MappingParameters p;
    setMappingParameter("map/voxel_size", "two", &p);
  });
  EXPECT_NE(error.find("map/voxel_size"), std::string::npos) << error;
  EXPECT_NE(error.find("'two'"), std::string::npos) << error;
  EXPECT_NE(errorOf([] {
              MappingParameters p;
              setMappingParameter("store/max_keyframes", "-3", &p);
            }).find("must not be negative"),
            std::string::npos);
  const std::string nested = writeTemporary("nested.yaml", "map:\n  region:\n    min: 1\n");
  EXPECT_NE(errorOf([&] {
              MappingParameters p;
              applyParameterFile(nested, &p);
            }).find(":2:"),
            std::string::npos);
}

TEST(MappingParameters, FusionZeroIsOffAndRegionsAreLists) {
  MappingParameters p;
  setMappingParameter("fusion/max_cost", "0", &p);
  EXPECT_TRUE(std::isinf(p.pipeline.mapper.fusion.max_cost));
  setMappingParameter("map/region_min", "[-1, -2, -3.5]", &p);
  EXPECT_EQ(p.pipeline.mapper.map.region_min, Eigen::Vector3d(-1, -2, -3.5));
  setMappingParameter("map/region_min", "[]", &p);
  EXPECT_TRUE(std::isinf(p.pipeline.mapper.map.region_min.x()) && p.pipeline.mapper.map.region_min.x() < 0);
  EXPECT_NE(errorOf([&] { setMappingParameter("map/region_max", "[1, 2]", &p); }).find("[x, y, z]"),
            std::string::npos);
}

TEST(MappingParameters, StoreMemoryZeroIsNoBound) {
  MappingParameters p;
  setMappingParameter("store/max_memory_mb", "0", &p);
  EXPECT_EQ(p.pipeline.mapper.store.max_bytes, std::numeric_limits<size_t>::max());
  EXPECT_EQ(p.validate(), "");
  ASSERT_NE(findMappingParameter("store/max_memory_mb"), nullptr);
  EXPECT_EQ(findMappingParameter("store/max_memory_mb")->get(p), "0");
  setMappingParameter("store/max_memory_mb", "2", &p);
  EXPECT_EQ(p.pipeline.mapper.store.max_bytes, size_t{2} << 20);
}

TEST(MappingParameters, MapToolRunsTheNodeletDefaults) {
  const MapToolOptions tool = parseMapToolArguments({});
  const MappingParameters product;
  for (const MappingParameter& parameter : mappingParameterTable()) {
    if (isNodeParameter(parameter) || parameter.name == "queue_size" || parameter.name == "max_image_size") continue;
    MappingParameters from_tool;
    from_tool.pipeline = tool.pipeline;
    from_tool.keyframes = tool.frames.picking;
    EXPECT_EQ(parameter.get(from_tool), parameter.get(product)) << parameter.name;
  }
  EXPECT_EQ(tool.max_image_size, -1);  // auto, resolved by the backend as in the nodelet
  EXPECT_EQ(tool.pipeline.mapper.sources.max_sources, 4);
  EXPECT_EQ(tool.pipeline.mapper.store.max_keyframes, 50u);
  EXPECT_FLOAT_EQ(tool.pipeline.mapper.fusion.max_cost, 0.6f);
  EXPECT_EQ(effectiveMaxImageSize(-1, Backend::kCpu), 320);
  EXPECT_EQ(effectiveMaxImageSize(-1, Backend::kCuda), 0);
}

TEST(MappingParameters, MapToolTakesEveryNameInOrder) {
  const std::string config = writeTemporary("config.yaml", "sources:\n  max_sources: 6\nmap:\n  voxel_size: 0.05\n");
  const MapToolOptions options = parseMapToolArguments(
      {"--config", config, "--set", "sources/max_sources=7", "--map.min_points_per_voxel", "2", "--confidence_level",
       "0.9", "--estimator/iterations=3", "--pose_refinement_max_features", "900"});
  EXPECT_EQ(options.pipeline.mapper.sources.max_sources, 7);  // --set after --config wins
  EXPECT_DOUBLE_EQ(options.pipeline.mapper.map.leaf_size, 0.05);
  EXPECT_EQ(options.pipeline.mapper.map.min_points_per_voxel, 2);
  EXPECT_FLOAT_EQ(options.pipeline.mapper.confidence.min_probability, 0.9f);
  EXPECT_EQ(options.pipeline.estimator.num_iterations, 3);
  EXPECT_EQ(options.pipeline.mapper.pose_refinement.max_features, 900);
  EXPECT_TRUE(parseMapToolArguments({"--refinement/fuse_neighbours_again"}).pipeline.mapper.refinement.fuse_neighbours_again);
  // The shipped file, which holds the node's own parameters too, is read whole.
  EXPECT_EQ(parseMapToolArguments({"--config", std::string(AMHMVS_SOURCE_DIR) + "/config/mapping.yaml"})
                .pipeline.mapper.sources.max_sources,
            4);
  const std::string error = errorOf([] { parseMapToolArguments({"--sources/max_sourcs", "3"}); });
  EXPECT_NE(error.find("did you mean --sources/max_sources"), std::string::npos) << error;
  EXPECT_NE(errorOf([] { parseMapToolArguments({"--input_mode", "tf"}); }).find("ROS node only"), std::string::npos);
}

}  // namespace
}  // namespace amhmvs
