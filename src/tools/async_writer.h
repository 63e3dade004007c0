// A writer thread with a bounded queue of jobs (file writes, ground-truth
// comparisons), so that they stay off the pipeline's critical path. Jobs run
// in posting order; post() blocks while the queue is full (offline input can
// wait; the pipeline's own queue absorbs bursts in realtime replay).
#pragma once

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>

namespace amhmvs {

class AsyncWriter {
 public:
  explicit AsyncWriter(size_t max_queued);
  // Runs the jobs still queued, then stops (errors are dropped: call finish()).
  ~AsyncWriter();
  AsyncWriter(const AsyncWriter&) = delete;
  AsyncWriter& operator=(const AsyncWriter&) = delete;

  void post(std::function<void()> job);
  // Waits for every posted job; rethrows the first exception a job threw
  // (later jobs are skipped once one failed).
  void finish();

  size_t maxQueued() const { return max_queued_; }
  // Most jobs that waited at once, and milliseconds post() spent blocked.
  size_t peakQueued() const;
  double blockedMilliseconds() const;

 private:
  void loop();

  const size_t max_queued_;
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<std::function<void()>> jobs_;
  bool running_job_ = false;
  bool stopping_ = false;
  std::exception_ptr error_;
  size_t peak_queued_ = 0;
  double blocked_ms_ = 0;
  std::thread thread_;
};

}  // namespace amhmvs
