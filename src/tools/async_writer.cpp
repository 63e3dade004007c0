#include "async_writer.h"

#include <algorithm>
#include <chrono>

namespace amhmvs {

AsyncWriter::AsyncWriter(size_t max_queued)
    : max_queued_(std::max<size_t>(1, max_queued)), thread_([this] { loop(); }) {}

AsyncWriter::~AsyncWriter() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  changed_.notify_all();
  thread_.join();
}

void AsyncWriter::post(std::function<void()> job) {
  std::unique_lock<std::mutex> lock(mutex_);
  if (jobs_.size() >= max_queued_) {
    const auto start = std::chrono::steady_clock::now();
    changed_.wait(lock, [this] { return jobs_.size() < max_queued_; });
    blocked_ms_ += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  }
  jobs_.push_back(std::move(job));
  peak_queued_ = std::max(peak_queued_, jobs_.size());
  lock.unlock();
  changed_.notify_all();
}

void AsyncWriter::finish() {
  std::unique_lock<std::mutex> lock(mutex_);
  changed_.wait(lock, [this] { return jobs_.empty() && !running_job_; });
  if (error_) {
    std::exception_ptr error = error_;
    error_ = nullptr;
    std::rethrow_exception(error);
  }
}

size_t AsyncWriter::peakQueued() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return peak_queued_;
}

double AsyncWriter::blockedMilliseconds() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return blocked_ms_;
}

void AsyncWriter::loop() {
  std::unique_lock<std::mutex> lock(mutex_);
  while (true) {
    changed_.wait(lock, [this] { return !jobs_.empty() || stopping_; });
    if (jobs_.empty()) return;  // stopping, nothing left
    std::function<void()> job = std::move(jobs_.front());
    jobs_.pop_front();
    running_job_ = true;
    const bool skip = error_ != nullptr;
    lock.unlock();
    changed_.notify_all();  // room in the queue
    std::exception_ptr error;
    if (!skip) {
      try {
        job();
      } catch (...) {
        error = std::current_exception();
      }
    }
    lock.lock();
    if (error && !error_) error_ = error;
    running_job_ = false;
    changed_.notify_all();
  }
}

}  // namespace amhmvs
