// Output files written off the critical path: jobs (encode and write one
// result's files) run in order on one thread behind a bounded queue, so that
// the next estimate overlaps them and memory stays bounded.
//
//   BackgroundWriter writer(2);
//   writer.submit([map = std::move(map)] { writePfm(path, map.depth); });
//   ...
//   writer.finish();  // waits; throws the first job's error
//
// A failing job's exception (which names its file: writePfm, writePng, ...)
// is kept; later jobs are skipped, and submit() or finish() rethrow it.
#pragma once

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>

namespace amhmvs {

class BackgroundWriter {
 public:
  // At most `max_queued` jobs wait (>= 1); submit() blocks while it is full.
  explicit BackgroundWriter(size_t max_queued);
  // Waits for the queued jobs; an error not yet reported by finish() is lost
  // here (destructors must not throw): call finish().
  ~BackgroundWriter();
  BackgroundWriter(const BackgroundWriter&) = delete;
  BackgroundWriter& operator=(const BackgroundWriter&) = delete;

  void submit(std::function<void()> job);
  // Waits until every job ran; rethrows the first failure.
  void finish();

 private:
  void run();
  void rethrowFailure();

  const size_t max_queued_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<std::function<void()>> jobs_;
  bool busy_ = false;     // a job is running
  bool stopping_ = false;
  std::exception_ptr failure_;
  std::thread worker_;
};

}  // namespace amhmvs
