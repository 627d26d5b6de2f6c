#include "volcast/core/private_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <string>

#include "volcast/core/error.hpp"

namespace volcast {

int open_private_file(const std::filesystem::path& path, bool exclusive) {
  const int flags = O_WRONLY | O_CREAT | O_CLOEXEC | (exclusive ? O_EXCL : O_TRUNC);
  const int fd = ::open(path.c_str(), flags, 0600);
  if (fd < 0) throw Error("cannot create '" + path.string() + "': " + std::strerror(errno));
  if (::fchmod(fd, 0600) != 0) {
    const std::string why = std::strerror(errno);
    ::close(fd);
    throw Error("cannot make '" + path.string() + "' private (mode 0600): " + why);
  }
  return fd;
}

void write_private_file(const std::filesystem::path& path, std::string_view bytes, bool exclusive) {
  const int fd = open_private_file(path, exclusive);
  size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const std::string why = n < 0 ? std::strerror(errno) : "nothing written";
      ::close(fd);
      throw Error("cannot write '" + path.string() + "': " + why);
    }
    done += static_cast<size_t>(n);
  }
  if (::close(fd) != 0)
    throw Error("cannot write '" + path.string() + "': " + std::strerror(errno));
}

void restrict_to_owner(const std::filesystem::path& path) {
  if (::chmod(path.c_str(), 0600) != 0)
    throw Error("cannot make '" + path.string() + "' private (mode 0600): " + std::strerror(errno));
}

}  // namespace volcast
