// A scratch folder removed with its content when the owner goes: shared by
// the unit tests (test/unit/test_helpers.h) and the fuzzers (test/fuzz), so it
// needs nothing but the standard library.
#pragma once

#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <system_error>

namespace amhmvs {
namespace test {

// A fresh folder <system temp dir>/<prefix><random>.
class TempDir {
 public:
  explicit TempDir(const std::string& prefix = "amhmvs_test_") {
    std::random_device rd;
    path_ = std::filesystem::temp_directory_path() / (prefix + std::to_string(rd()) + "_" + std::to_string(rd()));
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ignored;
    std::filesystem::remove_all(path_, ignored);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  std::string path() const { return path_.string(); }
  std::string file(const std::string& name) const { return (path_ / name).string(); }

  // Writes `content` to `name` (creating parent folders) and returns its path.
  std::string write(const std::string& name, const std::string& content) const {
    return writeTo((path_ / name).string(), content);
  }

  // Writes `content` to an absolute path (creating parent folders).
  static std::string writeTo(const std::string& path, const std::string& content) {
    const std::filesystem::path p(path);
    std::filesystem::create_directories(p.parent_path());
    std::ofstream out(p, std::ios::binary | std::ios::trunc);
    out << content;
    return p.string();
  }

 private:
  std::filesystem::path path_;
};

}  // namespace test
}  // namespace amhmvs
