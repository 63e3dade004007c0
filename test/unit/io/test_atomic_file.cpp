// Atomic writes: every writer of the io layer either puts its whole file
// under the final name or leaves the previous file as it was. Write failures
// are injected with a file-size limit (RLIMIT_FSIZE) in a child process at
// many cut points; kills are SIGKILLs of a child that keeps rewriting a file.
#include "amhmvs_mapping/io/atomic_file.h"

#include <gtest/gtest.h>

#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/io/image_io.h"
#include "amhmvs_mapping/io/mvsnet_folder.h"
#include "amhmvs_mapping/io/pfm.h"
#include "amhmvs_mapping/io/point_cloud_io.h"
#include "amhmvs_mapping/io/tum_trajectory.h"
#include "../test_helpers.h"

namespace amhmvs {
namespace {

std::vector<std::string> folderEntries(const std::string& folder) {
  std::vector<std::string> names;
  for (const auto& entry : std::filesystem::directory_iterator(folder)) names.push_back(entry.path().filename());
  std::sort(names.begin(), names.end());
  return names;
}

// One writer of the io layer, writing a file of a few kilobytes to `path`.
struct Writer {
  const char* name;
  const char* file_name;
  std::function<void(const std::string& path)> write;
};

std::vector<Writer> writers() {
  ImageF depth(24, 16, 1, 2.5f);
  const ImageU8 image = test::randomImage(24, 16, 3, 7);
  PointCloud cloud;
  for (int i = 0; i < 200; ++i) {
    cloud.points.push_back(Eigen::Vector3f(i, 0.5f * i, 1.0f));
    cloud.colors.push_back({static_cast<uint8_t>(i), 0, 255});
  }
  std::vector<StampedPose> poses;
  for (int i = 0; i < 40; ++i) poses.push_back({0.1 * i, Eigen::Isometry3d::Identity()});
  const PinholeCamera camera = test::centredCamera(24, 16, 20.0);
  return {
      {"PFM", "depth.pfm", [depth](const std::string& p) { writePfm(p, depth); }},
      {"PNG", "preview.png", [image](const std::string& p) { writePng(p, image); }},
      {"PNM", "image.ppm", [image](const std::string& p) { writePnm(p, image); }},
      {"PLY", "map.ply", [cloud](const std::string& p) { writePly(p, cloud); }},
      {"PCD", "map.pcd", [cloud](const std::string& p) { writePcd(p, cloud); }},
      {"PLY mesh", "mesh.ply", [cloud](const std::string& p) {
         TriangleMesh mesh;
         mesh.vertices = cloud;
         for (uint32_t i = 0; i + 2 < cloud.size(); ++i) mesh.triangles.push_back({i, i + 1, i + 2});
         writeMeshPly(p, mesh);
       }},
      {"TUM trajectory", "poses.txt", [poses](const std::string& p) { writeTumTrajectory(p, poses, "test"); }},
      {"MVSNet camera", "00000000_cam.txt", [camera](const std::string& p) { writeMvsnetCam(p, camera, 1.0, 5.0); }},
      {"text", "summary.json", [](const std::string& p) { writeFileAtomically(p, std::string(3000, 'x'), "summary"); }},
  };
}

// Runs `write` in a child whose files may not grow past `limit` bytes; the
// child's exit code: 0 when it threw an InputError naming `path` and the
// reason, 1 when it wrote without error, 2 on another outcome.
int writeUnderSizeLimit(const std::function<void(const std::string&)>& write, const std::string& path,
                        rlim_t limit) {
  const pid_t child = ::fork();
  if (child == 0) {
    ::signal(SIGXFSZ, SIG_IGN);  // the write fails with EFBIG instead of the signal killing the child
    const rlimit size_limit{limit, limit};
    ::setrlimit(RLIMIT_FSIZE, &size_limit);
    int code = 2;
    try {
      write(path);
      code = 1;
    } catch (const InputError& e) {
      const std::string message = e.what();
      if (message.find(path) != std::string::npos && message.find("File too large") != std::string::npos) code = 0;
    } catch (...) {
    }
    ::_exit(code);
  }
  int status = 0;
  ::waitpid(child, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

TEST(AtomicFile, WritesReplacesAndLeavesNothingBeside) {
  test::TempDir tmp;
  const mode_t previous_mask = ::umask(022);
  writeFileAtomically(tmp.file("a.txt"), "first", "note");
  writeFileAtomically(tmp.file("a.txt"), "second, longer", "note");
  ::umask(previous_mask);
  EXPECT_EQ(test::readText(tmp.file("a.txt")), "second, longer");
  EXPECT_EQ(folderEntries(tmp.path()), std::vector<std::string>{"a.txt"});
  struct stat info {};
  ASSERT_EQ(::stat(tmp.file("a.txt").c_str(), &info), 0);
  EXPECT_EQ(info.st_mode & 0777, 0644u) << "the umask applies, as for any new file";
}

TEST(AtomicFile, BadPathsNameThePathAndTheReason) {
  test::TempDir tmp;
  try {
    writeFileAtomically(tmp.file("no_such_folder/a.txt"), "x", "depth map");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no_such_folder/a.txt: cannot open the depth map for writing (No such file or directory)"),
              std::string::npos)
        << e.what();
  }
  EXPECT_THROW(writeFileAtomically("", "x"), InputError);
  EXPECT_THROW(writeFileAtomically(tmp.path() + "/", "x"), InputError);
  // A folder under the name: the rename fails and the folder stays.
  std::filesystem::create_directory(tmp.file("taken"));
  std::filesystem::create_directory(tmp.file("taken/inside"));
  EXPECT_THROW(writeFileAtomically(tmp.file("taken"), "x"), InputError);
  EXPECT_TRUE(std::filesystem::is_directory(tmp.file("taken/inside")));
  EXPECT_EQ(folderEntries(tmp.path()), std::vector<std::string>{"taken"});
}

TEST(AtomicFile, FailedWritesAtEveryCutPointKeepThePreviousFile) {
  for (const Writer& writer : writers()) {
    test::TempDir tmp;
    const std::string path = tmp.file(writer.file_name);
    const std::string previous = "the previous file, which must survive\n";
    test::TempDir::writeTo(path, previous);
    // The size of the new file, from a write without limit elsewhere.
    test::TempDir sizing;
    writer.write(sizing.file(writer.file_name));
    const rlim_t size = std::filesystem::file_size(sizing.file(writer.file_name));
    ASSERT_GT(size, 50u) << writer.name;
    for (const rlim_t cut : {rlim_t{0}, rlim_t{1}, rlim_t{17}, size / 3, size / 2, size - 1}) {
      EXPECT_EQ(writeUnderSizeLimit(writer.write, path, cut), 0) << writer.name << " cut at byte " << cut;
      EXPECT_EQ(test::readText(path), previous) << writer.name << " cut at byte " << cut;
      EXPECT_EQ(folderEntries(tmp.path()), std::vector<std::string>{writer.file_name})
          << writer.name << " left its temporary file, cut at byte " << cut;
    }
    // With room for the whole file, the new one replaces the old.
    EXPECT_EQ(writeUnderSizeLimit(writer.write, path, size), 1) << writer.name;
    EXPECT_EQ(std::filesystem::file_size(path), size) << writer.name;
  }
}

TEST(AtomicFile, KilledWritersNeverLeaveHalfAFile) {
  // A child rewrites one path with two large contents in turn and is killed
  // at random moments; the name holds one of them whole, or nothing before
  // the first rename. 100 trials.
  test::TempDir tmp;
  const std::string path = tmp.file("map.ply");
  const std::string first(3 << 20, 'a'), second(2 << 20, 'b');
  std::mt19937 random(42);
  std::uniform_int_distribution<int> delay_us(0, 20000);
  int killed_with_a_file = 0;
  for (int trial = 0; trial < 100; ++trial) {
    const pid_t child = ::fork();
    if (child == 0) {
      for (int i = 0;; ++i) writeFileAtomically(path, i % 2 ? second : first, "map");
    }
    ::usleep(delay_us(random));
    ::kill(child, SIGKILL);
    int status = 0;
    ::waitpid(child, &status, 0);
    ASSERT_TRUE(WIFSIGNALED(status)) << "trial " << trial;
    for (const std::string& name : folderEntries(tmp.path())) {  // a killed writer's temporary file stays
      if (name != "map.ply") std::filesystem::remove(tmp.file(name));
    }
    if (!std::filesystem::exists(path)) continue;
    ++killed_with_a_file;
    const std::string content = test::readText(path);
    ASSERT_TRUE(content == first || content == second)
        << "trial " << trial << ": " << content.size() << " bytes under the final name";
  }
  EXPECT_GT(killed_with_a_file, 50) << "most kills came after the first write";
}

}  // namespace
}  // namespace amhmvs
