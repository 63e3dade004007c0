// Every command of the README and of the reference pages under docs/ runs as
// written, as far as a test can tell without running minutes of work: each
// command line (```bash blocks, 4-space indented blocks, `roslaunch|rostest
// amhmvs_mapping ...` in backticks) that calls this package names a program,
// script, launch or test file that exists, and every option it passes exists:
// `--name` in the program's --help (or the script's text), `name:=` an <arg>
// of the launch or test file. A page that uses $AMHMVS_DATA_DIR explains it.
// Every file a page links to (or names under docs/results/) exists. And the
// checks can fail: wrong names in a made-up page are reported.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "test_helpers.h"

namespace amhmvs {
namespace {

namespace fs = std::filesystem;

std::string readText(const fs::path& path) {
  std::ifstream in(path);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// Command lines of a markdown text, continuation lines joined.
std::vector<std::string> commandLines(const std::string& markdown) {
  std::vector<std::string> lines;
  std::istringstream in(markdown);
  bool in_bash = false, continued = false;
  for (std::string line; std::getline(in, line);) {
    if (line.rfind("```", 0) == 0) {
      in_bash = !in_bash && line.rfind("```bash", 0) == 0;
      continue;
    }
    const bool indented = line.rfind("    ", 0) == 0 && !in_bash;
    if (!(in_bash || indented || continued)) {
      static const std::regex inline_command("`((roslaunch|rostest) amhmvs_mapping [^`]+)`");
      for (std::sregex_iterator it(line.begin(), line.end(), inline_command), end; it != end; ++it)
        lines.push_back((*it)[1]);
      continue;
    }
    const std::string text = line.substr(line.find_first_not_of(' ') == std::string::npos ? line.size()
                                                                                          : line.find_first_not_of(' '));
    if (continued) lines.back() += " " + text;
    else lines.push_back(text);
    continued = !lines.back().empty() && lines.back().back() == '\\';
    if (continued) lines.back().pop_back();
  }
  return lines;
}

std::vector<std::string> words(std::string line) {
  line = line.substr(0, line.find(" #"));  // a trailing comment
  std::istringstream in(line);
  std::vector<std::string> out;
  for (std::string word; in >> word;) out.push_back(word);
  return out;
}

// What a command may name: `help` texts of the programs, declared args of
// launch and test files.
struct Checker {
  fs::path root;
  std::string tools_dir;
  std::map<std::string, std::string> help;  // program -> --help output

  const std::string& helpOf(const std::string& program) {
    if (!help.count(program)) help[program] = test::runCommand(tools_dir + "/" + program + " --help").output;
    return help[program];
  }

  // Problems of one command line (empty when it names nothing of ours).
  std::vector<std::string> problems(const std::string& line) {
    std::vector<std::string> out;
    std::vector<std::string> w = words(line);
    if (w.empty()) return out;
    const auto options_in = [&](const std::string& text, size_t from) {
      for (size_t i = from; i < w.size(); ++i) {
        if (w[i].rfind("--", 0) != 0 || w[i] == "--") continue;
        const std::string name = w[i].substr(0, w[i].find('='));
        if (!std::regex_search(text, std::regex("(^|[^-\\w])" + name + "\\b")))
          out.push_back(line + ": option " + name + " is not known");
      }
    };
    const auto args_in = [&](const fs::path& file, size_t from) {
      const std::string text = readText(file);
      for (size_t i = from; i < w.size(); ++i) {
        const size_t assign = w[i].find(":=");
        if (assign == std::string::npos) continue;
        if (text.find("<arg name=\"" + w[i].substr(0, assign) + "\"") == std::string::npos)
          out.push_back(line + ": " + file.filename().string() + " has no arg " + w[i].substr(0, assign));
      }
    };
    const std::string tools_prefix = "build/devel/lib/amhmvs_mapping/";
    if (w[0].rfind(tools_prefix, 0) == 0) {
      const std::string program = w[0].substr(tools_prefix.size());
      if (!fs::exists(fs::path(tools_dir) / program)) return {line + ": no program " + program};
      options_in(helpOf(program), 1);
    } else if ((w[0] == "roslaunch" || w[0] == "rostest") && w.size() > 2 && w[1] == "amhmvs_mapping") {
      const fs::path file = root / (w[0] == "roslaunch" ? "launch" : "test/ros") / w[2];
      if (!fs::exists(file)) return {line + ": no file " + file.string()};
      args_in(file, 3);
    } else if ((w[0] == "bash" && w.size() > 1) || w[0].rfind("scripts/", 0) == 0) {
      const std::string script = w[0] == "bash" ? w[1] : w[0];
      if (!fs::exists(root / script)) return {line + ": no script " + script};
      options_in(readText(root / script), w[0] == "bash" ? 2 : 1);
    }
    return out;
  }
};

std::vector<std::string> readmeProblems(const std::string& readme, Checker* checker) {
  std::vector<std::string> problems;
  for (const std::string& line : commandLines(readme))
    for (const std::string& problem : checker->problems(line)) problems.push_back(problem);
  // A variable in a command is explained where it is used first.
  if (readme.find("$AMHMVS_DATA_DIR") != std::string::npos &&
      !std::regex_search(readme, std::regex("export AMHMVS_DATA_DIR=|`AMHMVS_DATA_DIR` is")))
    problems.push_back("$AMHMVS_DATA_DIR is used but never explained");
  return problems;
}

Checker makeChecker() { return Checker{AMHMVS_SOURCE_DIR, AMHMVS_TOOLS_DIR, {}}; }

// The pages whose commands are checked: the README and the reference pages.
const std::vector<std::string> kPages = {"README.md",        "docs/method.md",      "docs/cli.md",
                                         "docs/ros.md",      "docs/accuracy.md",    "docs/performance.md",
                                         "docs/reliability.md", "docs/design.md"};

// Files a page refers to that do not exist: relative markdown links (from the
// page's folder) and `docs/results/...` names (from the repository root).
std::vector<std::string> missingFiles(const std::string& page, const std::string& markdown, const fs::path& root) {
  std::vector<std::string> missing;
  static const std::regex link(R"(\]\(([^)#\s]+)(#[^)]*)?\))");
  for (std::sregex_iterator it(markdown.begin(), markdown.end(), link), end; it != end; ++it) {
    const std::string target = (*it)[1];
    if (target.find("://") != std::string::npos || target.rfind("mailto:", 0) == 0) continue;
    if (!fs::exists((root / page).parent_path() / target)) missing.push_back(page + ": link to " + target);
  }
  static const std::regex result("`(docs/results/[^`\\s]+)`");
  for (std::sregex_iterator it(markdown.begin(), markdown.end(), result), end; it != end; ++it) {
    if (!fs::exists(root / std::string((*it)[1]))) missing.push_back(page + ": names " + std::string((*it)[1]));
  }
  return missing;
}

TEST(ReadmeCommands, EveryCommandNamesWhatExists) {
  Checker checker = makeChecker();
  size_t total = 0;
  std::ostringstream all;
  for (const std::string& page : kPages) {
    const std::string text = readText(fs::path(AMHMVS_SOURCE_DIR) / page);
    EXPECT_FALSE(text.empty()) << page << " is missing or empty";
    const std::vector<std::string> lines = commandLines(text);
    if (page == "README.md") EXPECT_GE(lines.size(), 10u) << page;
    total += lines.size();
    for (const std::string& problem : readmeProblems(text, &checker)) all << page << ": " << problem << "\n";
  }
  EXPECT_GE(total, 40u);
  EXPECT_EQ(all.str(), "");
}

TEST(ReadmeCommands, EveryReferencedFileExists) {
  const fs::path root(AMHMVS_SOURCE_DIR);
  std::ostringstream all;
  for (const std::string& page : kPages)
    for (const std::string& missing : missingFiles(page, readText(root / page), root)) all << missing << "\n";
  EXPECT_EQ(all.str(), "");
}

TEST(ReadmeCommands, WrongNamesAreReported) {
  Checker checker = makeChecker();
  const std::string fake =
      "```bash\n"
      "build/devel/lib/amhmvs_mapping/amhmvs_map IN OUT --no_such_option 3 --max_image_size 256\n"
      "build/devel/lib/amhmvs_mapping/amhmvs_nothing IN\n"
      "```\n"
      "    roslaunch amhmvs_mapping replay_bag.launch \\\n"
      "      bag:=$AMHMVS_DATA_DIR/x.bag min_depth:=1\n"
      "Run `rostest amhmvs_mapping no_such.test` and `bash scripts/demo.sh --nope`.\n";
  const std::vector<std::string> problems = readmeProblems(fake, &checker);
  std::ostringstream all;
  for (const std::string& problem : problems) all << problem << "\n";
  EXPECT_EQ(problems.size(), 5u) << all.str();
  for (const char* expected : {"--no_such_option", "amhmvs_nothing", "no arg min_depth", "no_such.test",
                               "never explained"})
    EXPECT_NE(all.str().find(expected), std::string::npos) << expected << " not reported in:\n" << all.str();
  // Links and result files that do not exist are reported, ones that do are not.
  const std::vector<std::string> missing =
      missingFiles("docs/fake.md",
                   "[a](ros.md) [b](../README.md#top) [c](https://example.org/x) [d](no_such_page.md) "
                   "`docs/results/no_such_log.txt` ![e](images/no_such.png)\n",
                   fs::path(AMHMVS_SOURCE_DIR));
  std::ostringstream gone;
  for (const std::string& line : missing) gone << line << "\n";
  EXPECT_EQ(missing.size(), 3u) << gone.str();
  for (const char* expected : {"no_such_page.md", "no_such_log.txt", "no_such.png"})
    EXPECT_NE(gone.str().find(expected), std::string::npos) << expected << " not reported in:\n" << gone.str();
}

}  // namespace
}  // namespace amhmvs
