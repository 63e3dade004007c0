// config/mapping.yaml documents every option of the option tables, with the
// table's default value: the estimator's under `estimator:`, the pose
// refinement's under `pose_refinement:`.
#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include "amhmvs_mapping/mapping/mapping_parameters.h"
#include "amhmvs_mapping/mapping/online_mapper.h"
#include "amhmvs_mapping/mapping/pose_refinement.h"
#include "amhmvs_mapping/mvs/patchmatch_options.h"

namespace {

// The `key: value` lines of a top-level section of config/mapping.yaml (or
// of another yaml in config/).
std::map<std::string, std::string> documentedOptions(const std::string& section,
                                                     const std::string& yaml = "mapping.yaml") {
  std::ifstream file(std::string(AMHMVS_SOURCE_DIR) + "/config/" + yaml);
  EXPECT_TRUE(file.good());
  std::map<std::string, std::string> documented;  // option -> value text
  bool in_section = false;
  for (std::string line; std::getline(file, line);) {
    if (!line.empty() && line[0] != ' ' && line[0] != '#') in_section = line.rfind(section + ":", 0) == 0;
    if (!in_section || line.rfind("  ", 0) != 0) continue;
    std::istringstream words(line);
    std::string key, value;
    words >> key >> value;
    if (!key.empty() && key.back() == ':') documented[key.substr(0, key.size() - 1)] = value;
  }
  return documented;
}

// Every option of `table` in `section` with the default of `Options`.
template <typename Options>
void expectDocumented(const std::string& section, const std::vector<amhmvs::OptionField<Options>>& table,
                      const Options& defaults = Options()) {
  std::map<std::string, std::string> documented = documentedOptions(section);
  for (const amhmvs::OptionField<Options>& option : table) {
    SCOPED_TRACE(option.name);
    ASSERT_TRUE(documented.count(option.name)) << section << "/" << option.name << " missing in config/mapping.yaml";
    Options parsed;
    option.set(parsed, documented[option.name]);
    EXPECT_EQ(option.get(parsed), option.get(defaults));
  }
  EXPECT_EQ(documented.size(), table.size());
}

// With the product's defaults (MappingParameters: two scales), not the
// paper's that PatchMatchOptions keeps.
TEST(MappingConfigDoc, EveryEstimatorOptionDocumentedWithItsDefault) {
  expectDocumented("estimator", amhmvs::patchMatchOptionTable(), amhmvs::MappingParameters().pipeline.estimator);
}

TEST(MappingConfigDoc, EveryPoseRefinementOptionDocumentedWithItsDefault) {
  expectDocumented("pose_refinement", amhmvs::poseRefinementOptionTable());
}

// The refinement section (no option table: the nodelet reads it field by
// field) with RefinementOptions' defaults, as the yaml's text gives them.
TEST(MappingConfigDoc, RefinementSectionHasTheDefaults) {
  const amhmvs::RefinementOptions defaults;
  std::map<std::string, std::string> documented = documentedOptions("refinement");
  const auto flag = [](bool value) { return std::string(value ? "true" : "false"); };
  EXPECT_EQ(documented["max_refinements"], std::to_string(defaults.max_refinements));
  EXPECT_EQ(std::stod(documented["min_score_gain"]), defaults.min_score_gain);
  EXPECT_EQ(documented["keep_only_better"], flag(defaults.keep_only_better));
  EXPECT_EQ(std::stod(documented["confident_cost"]), defaults.confident_cost);
  EXPECT_EQ(std::stod(documented["max_confident_loss"]), defaults.max_confident_loss);
  EXPECT_EQ(documented["fuse_neighbours_again"], flag(defaults.fuse_neighbours_again));
  EXPECT_EQ(documented.size(), 6u);
}

}  // namespace
