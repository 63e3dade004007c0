// config/mapping.yaml documents every option of the option tables, with the
// table's default value: the estimator's under `estimator:`, the pose
// refinement's under `pose_refinement:`.
#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include "amhmvs_mapping/mapping/pose_refinement.h"
#include "amhmvs_mapping/mvs/patchmatch_options.h"

namespace {

// The `key: value` lines of a top-level section of config/mapping.yaml.
std::map<std::string, std::string> documentedOptions(const std::string& section) {
  std::ifstream file(std::string(AMHMVS_SOURCE_DIR) + "/config/mapping.yaml");
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

TEST(MappingConfigDoc, EveryEstimatorOptionDocumentedWithItsDefault) {
  expectDocumented("estimator", amhmvs::patchMatchOptionTable());
}

TEST(MappingConfigDoc, EveryPoseRefinementOptionDocumentedWithItsDefault) {
  expectDocumented("pose_refinement", amhmvs::poseRefinementOptionTable());
}

}  // namespace
