#include "amhmvs_mapping/io/atomic_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>

#include "amhmvs_mapping/core/error.h"

namespace amhmvs {
namespace {

// A name no other writer (thread or process) uses at the same time, hidden
// beside the final name: ".NAME.PID.N.tmp".
std::string temporaryNameFor(const std::string& path) {
  static std::atomic<unsigned long> counter{0};
  const size_t slash = path.find_last_of('/');
  const std::string folder = slash == std::string::npos ? "" : path.substr(0, slash + 1);
  const std::string name = slash == std::string::npos ? path : path.substr(slash + 1);
  return folder + "." + name + "." + std::to_string(::getpid()) + "." + std::to_string(counter++) + ".tmp";
}

bool writeAll(int fd, const std::string& bytes) {
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      if (n == 0) errno = EIO;
      return false;
    }
    done += static_cast<size_t>(n);
  }
  return true;
}

}  // namespace

void writeFileAtomically(const std::string& path, const std::string& bytes, const std::string& what) {
  if (path.empty() || path.back() == '/') throw InputError("'" + path + "': not a file name to write the " + what + " to");
  const std::string temporary = temporaryNameFor(path);
  // 0666 less the umask, as for a file opened with fopen.
  const int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
  if (fd < 0) throw InputError(path + ": cannot open the " + what + " for writing (" + std::strerror(errno) + ")");
  const bool written = writeAll(fd, bytes);
  int error = written ? 0 : errno;
  if (::close(fd) != 0 && error == 0) error = errno;
  if (error == 0 && std::rename(temporary.c_str(), path.c_str()) != 0) error = errno;
  if (error != 0) {
    ::unlink(temporary.c_str());
    throw InputError(path + ": writing the " + what + " failed (" + std::strerror(error) + "); the previous file, if any, is unchanged");
  }
}

}  // namespace amhmvs
