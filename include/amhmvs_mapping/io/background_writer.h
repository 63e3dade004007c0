// Output files written off the critical path: jobs (encode and write one
// file) run on worker threads behind a bounded queue, so that the next
// estimate overlaps them and memory stays bounded. With one thread the jobs
// run in submission order; with more, in any order.
//
//   BackgroundWriter writer(8, 4);
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
#include <vector>

namespace amhmvs {

class BackgroundWriter {
 public:
  // At most `max_queued` jobs wait (>= 1); submit() blocks while it is full.
  explicit BackgroundWriter(size_t max_queued, int threads = 1);
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
  int running_ = 0;       // jobs being run
  bool stopping_ = false;
  std::exception_ptr failure_;
  std::vector<std::thread> workers_;
};

}  // namespace amhmvs
