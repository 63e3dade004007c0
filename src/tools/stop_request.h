// SIGINT/SIGTERM as a request to stop: the first one sets a flag the tool's
// loop reads (it stops reading frames, finishes what the pipeline holds and
// writes its outputs); a second one ends the process at once, as a user who
// presses Ctrl-C twice expects.
#pragma once

#include <csignal>
#include <string>

namespace amhmvs {

class StopRequest {
 public:
  // Installs the handlers for the life of the object (one at a time).
  StopRequest();
  ~StopRequest();
  StopRequest(const StopRequest&) = delete;
  StopRequest& operator=(const StopRequest&) = delete;

  bool requested() const { return signal_ != 0; }
  // "SIGINT" or "SIGTERM"; empty while none came.
  std::string signalName() const;
  // The shell's code for that signal, 128 + its number (130, 143).
  int exitCode() const { return 128 + signal_; }

 private:
  static void handle(int signal);
  static volatile std::sig_atomic_t signal_;
  struct sigaction previous_int_ {}, previous_term_ {};
};

}  // namespace amhmvs
