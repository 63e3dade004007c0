// config/mapping.yaml documents every estimator option of the table, with the
// table's default value, under `estimator:`.
#include <gtest/gtest.h>

#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include "amhmvs_mapping/mvs/patchmatch_options.h"

TEST(MappingConfigDoc, EveryEstimatorOptionDocumentedWithItsDefault) {
  std::ifstream file(std::string(AMHMVS_SOURCE_DIR) + "/config/mapping.yaml");
  ASSERT_TRUE(file.good());
  std::map<std::string, std::string> documented;  // option -> value text
  bool in_estimator = false;
  for (std::string line; std::getline(file, line);) {
    if (line.rfind("estimator:", 0) == 0) { in_estimator = true; continue; }
    if (!in_estimator || line.rfind("  ", 0) != 0) continue;
    std::istringstream words(line);
    std::string key, value;
    words >> key >> value;
    if (!key.empty() && key.back() == ':') documented[key.substr(0, key.size() - 1)] = value;
  }
  const amhmvs::PatchMatchOptions defaults;
  for (const amhmvs::OptionInfo& option : amhmvs::patchMatchOptionTable()) {
    SCOPED_TRACE(option.name);
    ASSERT_TRUE(documented.count(option.name)) << "estimator/" << option.name << " missing in config/mapping.yaml";
    amhmvs::PatchMatchOptions parsed;
    option.set(parsed, documented[option.name]);
    EXPECT_EQ(option.get(parsed), option.get(defaults));
  }
  EXPECT_EQ(documented.size(), amhmvs::patchMatchOptionTable().size());
}
