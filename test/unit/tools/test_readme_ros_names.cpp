// The nodelet section of docs/ros.md (the ROS interface's reference page;
// the README links to it) documents only ROS names that exist: topics
// and services advertised or subscribed in src/ros/*.cpp, parameters
// (`~name`) that are keys of config/mapping.yaml, amhmvs_mapping/Type that are
// messages or services of this package. And the check can fail: fake names
// put into the section are reported.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace amhmvs {
namespace {

namespace fs = std::filesystem;

// The page and the heading of its section that is checked.
const char* kRosPage = "docs/ros.md";
const char* kNodeletHeading = "## Online mapping: `amhmvs_mapping/MappingNodelet`";

std::string readText(const fs::path& path) {
  std::ifstream in(path);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// Group 1 of every match of `pattern` in `text`.
std::vector<std::string> captures(const std::string& text, const std::regex& pattern) {
  std::vector<std::string> out;
  for (std::sregex_iterator it(text.begin(), text.end(), pattern), end; it != end; ++it) out.push_back((*it)[1]);
  return out;
}

struct KnownNames {
  std::set<std::string> communication;     // topics and services, relative as in the code ("depth/image")
  std::set<std::string> private_services;  // advertised on the private node handle ("reset")
  std::set<std::string> parameters;        // yaml keys, nested as "estimator/iterations"
  std::set<std::string> words;             // option values compared in the code, executables, namespaces
  std::set<std::string> types;             // "amhmvs_mapping/Keyframe" (msg/, srv/, nodelet plugins)
};

// First string literal of every statement that advertises or subscribes.
void addCommunicationNames(const std::string& code, KnownNames* known) {
  static const std::regex call(R"((advertiseService|advertiseCamera|advertise(?:Latched)?|subscribe|Subscriber(Filter)?\b))"
                               R"((<[^;(]*>)?\s*\([^;"]*"([^"]+)\")");
  for (std::sregex_iterator it(code.begin(), code.end(), call), end; it != end; ++it) {
    const std::string name = (*it)[4];
    known->communication.insert(name);
    if ((*it)[1] == "advertiseCamera") {  // the camera_info beside the image
      known->communication.insert(name.substr(0, name.rfind('/') + 1) + "camera_info");
    }
    // Services on the private node handle are documented as ~name.
    const size_t line_start = code.rfind('\n', it->position()) + 1;
    if ((*it)[1] == "advertiseService" &&
        code.substr(line_start, it->position() - line_start).find("pnh.") != std::string::npos) {
      known->private_services.insert(name);
    }
  }
  if (code.find("diagnostic_updater::Updater") != std::string::npos) known->communication.insert("/diagnostics");
}

// Top-level keys and keys nested one level ("estimator/iterations").
void addYamlKeys(const std::string& yaml, KnownNames* known) {
  static const std::regex key(R"(^(  )?([A-Za-z_][A-Za-z0-9_]*):)");
  std::istringstream lines(yaml);
  std::string parent;
  for (std::string line; std::getline(lines, line);) {
    std::smatch m;
    if (!std::regex_search(line, m, key)) continue;
    if (m[1].length() == 0) {
      parent = m[2];
      known->parameters.insert(parent);
    } else {
      known->parameters.insert(parent + "/" + std::string(m[2]));
      known->words.insert(m[2]);  // a group's row of the table lists its keys bare
    }
  }
}

KnownNames collectKnownNames(const fs::path& root) {
  KnownNames known;
  for (const auto& entry : fs::directory_iterator(root / "src/ros")) {
    if (entry.path().extension() == ".cpp") addCommunicationNames(readText(entry.path()), &known);
  }
  addYamlKeys(readText(root / "config/mapping.yaml"), &known);
  // Option values the code compares with (e.g. the backend names in src/mvs).
  static const std::regex compared(R"([!=]=\s*"([^"]+)\")");
  for (const auto& entry : fs::recursive_directory_iterator(root / "src")) {
    if (entry.path().extension() == ".cpp")
      for (const std::string& value : captures(readText(entry.path()), compared)) known.words.insert(value);
  }
  // Diagnostic keys the nodelet reports: its status entries and the typed
  // counters' name tables of the inputs and the pipeline.
  static const std::regex status(R"(status\.add\(\s*"([^"]+)\")");
  static const std::regex counter(R"(\{\s*"([^"]+)\",\s*&(?:Input|Pipeline)Stats::)");
  for (const char* folder : {"src/ros", "src/mapping"}) {
    for (const auto& entry : fs::directory_iterator(root / folder)) {
      if (entry.path().extension() != ".cpp") continue;
      for (const std::regex* pattern : {&status, &counter})
        for (const std::string& key : captures(readText(entry.path()), *pattern)) known.words.insert(key);
    }
  }
  // Message and service types, and their field names (a service's `path`).
  static const std::regex field(R"((?:^|\n)\s*[A-Za-z][\w/]*(?:\[\d*\])?\s+(\w+)\s*(?:#[^\n]*)?(?=\n|$))");
  for (const char* folder : {"msg", "srv"}) {
    for (const auto& entry : fs::directory_iterator(root / folder)) {
      known.types.insert("amhmvs_mapping/" + entry.path().stem().string());
      for (const std::string& name : captures(readText(entry.path()), field)) known.words.insert(name);
    }
  }
  static const std::regex plugin(R"(<class name="(amhmvs_mapping/\w+)\")");
  static const std::regex executable(R"(add_executable\((\w+))"), ns(R"(<arg name="ns" default="(\w+)\")");
  for (const std::string& type : captures(readText(root / "nodelet_plugins.xml"), plugin)) known.types.insert(type);
  for (const std::string& program : captures(readText(root / "CMakeLists.txt"), executable)) known.words.insert(program);
  for (const std::string& name : captures(readText(root / "launch/mapping.launch"), ns)) known.words.insert("/" + name);
  // Launch arguments (`iterations:=3`).
  static const std::regex launch_arg(R"re(<arg name="(\w+)")re");
  for (const auto& entry : fs::directory_iterator(root / "launch")) {
    if (entry.path().extension() == ".launch")
      for (const std::string& name : captures(readText(entry.path()), launch_arg)) known.words.insert(name);
  }
  return known;
}

std::string section(const std::string& markdown, const std::string& heading) {
  const size_t start = markdown.find("\n" + heading + "\n");
  if (start == std::string::npos) return "";
  const size_t end = markdown.find("\n## ", start + 1);
  return markdown.substr(start, end == std::string::npos ? std::string::npos : end - start);
}

// Backticked names that are not known, each with the reason.
std::vector<std::string> unknownNames(const std::string& text, const KnownNames& known) {
  static const std::regex backticked("`([^`\n]+)`");
  static const std::regex ros_name(R"(/?[a-z][a-z0-9_]*(/[a-z][a-z0-9_]*)*/?)");
  static const std::regex type_name(R"(amhmvs_mapping/[A-Z]\w*)");
  std::vector<std::string> unknown;
  for (std::sregex_iterator it(text.begin(), text.end(), backticked), end; it != end; ++it) {
    const std::string token = (*it)[1];
    if (std::regex_match(token, type_name)) {
      if (!known.types.count(token)) unknown.push_back(token + ": no msg/, srv/ file or nodelet plugin of that name");
    } else if (token[0] == '~' && std::regex_match(token.substr(1), ros_name)) {
      const std::string name = token.substr(1);
      const bool prefix = name.back() == '/' && known.parameters.lower_bound(name) != known.parameters.end() &&
                          known.parameters.lower_bound(name)->rfind(name, 0) == 0;
      if (!known.parameters.count(name) && !known.private_services.count(name) && !prefix)
        unknown.push_back(token + ": not a key of config/mapping.yaml nor a private service in src/ros");
    } else if (std::regex_match(token, ros_name)) {
      const bool group = token.back() == '/' && known.parameters.count(token.substr(0, token.size() - 1));  // `store/`
      if (!known.communication.count(token) && !known.parameters.count(token) && !known.words.count(token) && !group)
        unknown.push_back(token + ": not a topic or service in src/ros, a parameter, an option value or a program");
    }
  }
  return unknown;
}

std::string joined(const std::vector<std::string>& lines) {
  std::string out;
  for (const std::string& line : lines) out += "  " + line + "\n";
  return out;
}

class ReadmeRosNames : public ::testing::Test {
 protected:
  void SetUp() override {
    section_ = section(readText(fs::path(AMHMVS_SOURCE_DIR) / kRosPage), kNodeletHeading);
    ASSERT_FALSE(section_.empty()) << kRosPage << " has no section " << kNodeletHeading;
    known_ = collectKnownNames(AMHMVS_SOURCE_DIR);
  }
  std::string section_;
  KnownNames known_;
};

TEST_F(ReadmeRosNames, EveryDocumentedNameExistsInTheCode) {
  // The code side is read, not empty: the names the first slice had.
  for (const char* name : {"depth/image", "depth/camera_info", "keyframe_cloud", "image", "pose", "keyframe_poses"})
    EXPECT_TRUE(known_.communication.count(name)) << name;
  EXPECT_TRUE(known_.private_services.count("reset"));
  EXPECT_TRUE(known_.parameters.count("estimator/iterations"));
  const std::vector<std::string> unknown = unknownNames(section_, known_);
  EXPECT_TRUE(unknown.empty()) << kRosPage << " section '" << kNodeletHeading << "' documents names the code lacks:\n"
                               << joined(unknown);
}

TEST_F(ReadmeRosNames, FakeNamesAreReported) {
  const std::string faked = section_ + "\n| `depth/no_such_topic` | `~no_such_parameter` | `~no_such_service` "
                                       "| `amhmvs_mapping/NoSuchMessage` | `~estimator/no_such_option` |\n";
  const std::vector<std::string> unknown = unknownNames(faked, known_);
  ASSERT_EQ(unknown.size(), 5u) << joined(unknown);
  const char* expected[] = {"depth/no_such_topic:", "~no_such_parameter:", "~no_such_service:",
                            "amhmvs_mapping/NoSuchMessage:", "~estimator/no_such_option:"};
  for (size_t i = 0; i < 5; ++i) EXPECT_EQ(unknown[i].rfind(expected[i], 0), 0u) << unknown[i];
}

}  // namespace
}  // namespace amhmvs
