#include "stop_request.h"

#include <unistd.h>

namespace amhmvs {

volatile std::sig_atomic_t StopRequest::signal_ = 0;

StopRequest::StopRequest() {
  signal_ = 0;
  struct sigaction action {};
  action.sa_handler = &StopRequest::handle;
  sigemptyset(&action.sa_mask);
  sigaction(SIGINT, &action, &previous_int_);
  sigaction(SIGTERM, &action, &previous_term_);
}

StopRequest::~StopRequest() {
  sigaction(SIGINT, &previous_int_, nullptr);
  sigaction(SIGTERM, &previous_term_, nullptr);
}

std::string StopRequest::signalName() const {
  if (signal_ == SIGINT) return "SIGINT";
  if (signal_ == SIGTERM) return "SIGTERM";
  return "";
}

void StopRequest::handle(int signal) {
  if (signal_ != 0) {  // the second request: the default action, now
    std::signal(signal, SIG_DFL);
    std::raise(signal);
    return;
  }
  signal_ = signal;
  static const char kNote[] = "\namhmvs_map: stopping: finishing the keyframes in the pipeline, then writing the "
                              "map and summary (again to quit at once)\n";
  const ssize_t ignored = ::write(STDERR_FILENO, kNote, sizeof(kNote) - 1);
  (void)ignored;
}

}  // namespace amhmvs
