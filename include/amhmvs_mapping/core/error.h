// Errors raised by the core library on bad input.
#pragma once

#include <stdexcept>
#include <string>

namespace amhmvs {

// Thrown for input the library refuses: malformed files, invalid cameras,
// inconsistent image sizes, bad options. The message names the offending item
// (file, view, option) and the problem, so that a caller can print it as is.
class InputError : public std::runtime_error {
 public:
  explicit InputError(const std::string& message) : std::runtime_error(message) {}
};

// Thrown when a compute backend fails at run time (GPU out of memory, lost
// device). Callers may retry on another backend.
class BackendError : public std::runtime_error {
 public:
  explicit BackendError(const std::string& message) : std::runtime_error(message) {}
};

}  // namespace amhmvs
