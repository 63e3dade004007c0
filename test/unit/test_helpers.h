// Shared helpers for the unit tests: locating the real data set and scratch
// folders for malformed inputs.
#pragma once

#include <gtest/gtest.h>

#include <sys/wait.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "amhmvs_mapping/core/camera.h"
#include "amhmvs_mapping/core/image.h"
#include "../common/temp_dir.h"

namespace amhmvs {
namespace test {

// A width x height camera with focal length `focal` (px), the principal point
// at the image centre, at the world origin looking along +z.
inline PinholeCamera centredCamera(int width, int height, double focal) {
  PinholeCamera camera;
  camera.fx = camera.fy = focal;
  camera.cx = 0.5 * (width - 1);
  camera.cy = 0.5 * (height - 1);
  camera.width = width;
  camera.height = height;
  return camera;
}

// Mean absolute grey difference of two images of one size, over the pixels
// at least `margin` from the border.
inline double meanDifference(const ImageU8& a, const ImageU8& b, int margin = 0) {
  double sum = 0;
  int count = 0;
  for (int y = margin; y < a.height - margin; ++y) {
    for (int x = margin; x < a.width - margin; ++x) {
      for (int c = 0; c < a.channels; ++c) sum += std::abs(static_cast<int>(a.at(x, y, c)) - b.at(x, y, c));
      count += a.channels;
    }
  }
  return sum / count;
}

// Root of the shared real data: $AMHMVS_DATA_DIR, else <source dir>/../shared/data.
inline std::string dataDir() {
  if (const char* env = std::getenv("AMHMVS_DATA_DIR")) return env;
#ifdef AMHMVS_SOURCE_DIR
  return std::string(AMHMVS_SOURCE_DIR) + "/../shared/data";
#else
  return "../shared/data";
#endif
}

// Full path of `relative` under dataDir(), or "" when it does not exist.
inline std::string dataPath(const std::string& relative) {
  const std::string path = dataDir() + "/" + relative;
  return std::filesystem::exists(path) ? path : "";
}

struct CommandResult {
  int exit_code;
  std::string output;  // stdout and stderr together
};

// Runs a shell command line, capturing its output and exit code (-1 when it
// did not exit normally).
inline CommandResult runCommand(const std::string& command_line) {
  CommandResult result{-1, ""};
  FILE* pipe = popen((command_line + " 2>&1").c_str(), "r");
  if (!pipe) return result;
  std::array<char, 4096> buffer;
  size_t n;
  while ((n = fread(buffer.data(), 1, buffer.size(), pipe)) > 0) result.output.append(buffer.data(), n);
  const int status = pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

#ifdef AMHMVS_TOOLS_DIR
// Runs one of the built command-line tools (AMHMVS_TOOLS_DIR/<tool>).
inline CommandResult runTool(const std::string& tool, const std::string& arguments) {
  return runCommand(std::string(AMHMVS_TOOLS_DIR) + "/" + tool + " " + arguments);
}
#endif

// The whole of a text file ("" when it cannot be read).
inline std::string readText(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

// The number after "key": that follows "section": in a JSON text (section
// "" = from the start); NaN when absent or null.
inline double jsonNumber(const std::string& json, const std::string& section, const std::string& key) {
  size_t pos = section.empty() ? 0 : json.find("\"" + section + "\":");
  if (pos == std::string::npos) return NAN;
  pos = json.find("\"" + key + "\":", pos);
  if (pos == std::string::npos) return NAN;
  const char* start = json.c_str() + pos + key.size() + 3;
  char* end = nullptr;
  const double value = std::strtod(start, &end);
  return end == start ? NAN : value;
}

// An image of uniformly random bytes, reproducible from `seed`.
inline ImageU8 randomImage(int width, int height, int channels, unsigned seed) {
  std::mt19937 rng(seed);
  ImageU8 image(width, height, channels);
  for (auto& v : image.data) v = static_cast<uint8_t>(rng() & 0xFF);
  return image;
}

}  // namespace test
}  // namespace amhmvs

// Skips the current test when real data is absent (a user's machine).
#define AMHMVS_REQUIRE_DATA(var, relative)                                            \
  const std::string var = ::amhmvs::test::dataPath(relative);                         \
  if (var.empty()) {                                                                  \
    GTEST_SKIP() << "real data not found: " << ::amhmvs::test::dataDir() << "/"       \
                 << (relative) << " (set AMHMVS_DATA_DIR to the shared data folder)"; \
  }

// Expects `statement` to throw amhmvs::InputError whose message contains both
// `needle1` and `needle2` (e.g. the file name and a word for the problem).
#define EXPECT_INPUT_ERROR(statement, needle1, needle2)                              \
  do {                                                                               \
    try {                                                                            \
      statement;                                                                     \
      ADD_FAILURE() << "expected InputError from: " #statement;                      \
    } catch (const ::amhmvs::InputError& e) {                                        \
      const std::string message = e.what();                                          \
      EXPECT_NE(message.find(needle1), std::string::npos) << "message: " << message; \
      EXPECT_NE(message.find(needle2), std::string::npos) << "message: " << message; \
    }                                                                                \
  } while (0)
