#include "amhmvs_mapping/io/background_writer.h"

#include <algorithm>
#include <utility>

namespace amhmvs {

BackgroundWriter::BackgroundWriter(size_t max_queued, int threads) : max_queued_(std::max<size_t>(1, max_queued)) {
  for (int i = 0; i < std::max(1, threads); ++i) workers_.emplace_back([this] { run(); });
}

BackgroundWriter::~BackgroundWriter() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  changed_.notify_all();
  for (std::thread& worker : workers_) worker.join();
}

void BackgroundWriter::submit(std::function<void()> job) {
  std::unique_lock<std::mutex> lock(mutex_);
  changed_.wait(lock, [this] { return jobs_.size() < max_queued_ || failure_; });
  if (failure_) rethrowFailure();
  jobs_.push_back(std::move(job));
  changed_.notify_all();
}

void BackgroundWriter::finish() {
  std::unique_lock<std::mutex> lock(mutex_);
  changed_.wait(lock, [this] { return (jobs_.empty() && running_ == 0) || failure_; });
  if (failure_) rethrowFailure();
}

void BackgroundWriter::rethrowFailure() {
  std::exception_ptr failure = failure_;
  std::rethrow_exception(failure);
}

void BackgroundWriter::run() {
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    changed_.wait(lock, [this] { return !jobs_.empty() || stopping_; });
    if (jobs_.empty()) return;  // stopping, nothing left
    std::function<void()> job = std::move(jobs_.front());
    jobs_.pop_front();
    if (failure_) continue;  // after a failure the rest is skipped
    ++running_;
    changed_.notify_all();  // room in the queue
    lock.unlock();
    std::exception_ptr error;
    try {
      job();
    } catch (...) {
      error = std::current_exception();
    }
    job = nullptr;  // the job's data (a depth map) is freed before the lock is taken
    lock.lock();
    --running_;
    if (error && !failure_) failure_ = error;
    changed_.notify_all();
  }
}

}  // namespace amhmvs
