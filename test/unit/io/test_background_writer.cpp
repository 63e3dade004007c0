// BackgroundWriter: jobs run in order off the caller's thread, the queue is
// bounded, and the first failure (naming its file) reaches the caller.
#include "amhmvs_mapping/io/background_writer.h"

#include <gtest/gtest.h>

#include <atomic>
#include <string>
#include <vector>

#include "amhmvs_mapping/core/error.h"
#include "amhmvs_mapping/io/pfm.h"

namespace amhmvs {
namespace {

TEST(BackgroundWriter, RunsEveryJobInOrder) {
  std::vector<int> done;
  BackgroundWriter writer(2);
  for (int i = 0; i < 50; ++i) writer.submit([&done, i] { done.push_back(i); });
  writer.finish();
  ASSERT_EQ(done.size(), 50u);
  for (int i = 0; i < 50; ++i) EXPECT_EQ(done[i], i);
}

TEST(BackgroundWriter, QueueIsBounded) {
  // Each job records how many jobs were submitted when it started: with at
  // most 2 waiting and 1 running, job i starts before submission i + 4.
  std::atomic<int> submitted{0};
  std::vector<int> submitted_at_start;
  {
    BackgroundWriter writer(2);
    for (int i = 0; i < 20; ++i) {
      writer.submit([&] { submitted_at_start.push_back(submitted.load()); });
      ++submitted;
    }
    writer.finish();
  }
  ASSERT_EQ(submitted_at_start.size(), 20u);
  for (int i = 0; i < 20; ++i) EXPECT_LE(submitted_at_start[i], i + 3) << "job " << i;
}

TEST(BackgroundWriter, FirstErrorNamesTheFileAndSkipsTheRest) {
  int ran_after_failure = 0;
  BackgroundWriter writer(4);
  const std::string path = "/nonexistent_amhmvs_dir/depth.pfm";
  writer.submit([&] { writePfm(path, ImageF(2, 2)); });
  try {
    for (int i = 0; i < 10; ++i) writer.submit([&] { ++ran_after_failure; });
    writer.finish();
    FAIL() << "the write error was not reported";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
  EXPECT_EQ(ran_after_failure, 0);
  EXPECT_THROW(writer.finish(), std::exception);  // still reported
}

TEST(BackgroundWriter, SeveralThreadsRunEveryJobOnceAndReportAFailure) {
  std::vector<std::atomic<int>> runs(200);
  {
    BackgroundWriter writer(8, 4);
    for (size_t i = 0; i < runs.size(); ++i) writer.submit([&runs, i] { ++runs[i]; });
    writer.finish();
  }
  for (size_t i = 0; i < runs.size(); ++i) EXPECT_EQ(runs[i].load(), 1) << "job " << i;
  BackgroundWriter writer(8, 4);
  writer.submit([] { writePfm("/nonexistent_amhmvs_dir/cost.pfm", ImageF(2, 2)); });
  try {
    writer.finish();
    FAIL() << "the write error was not reported";
  } catch (const std::exception& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent_amhmvs_dir/cost.pfm"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace amhmvs
