#pragma once
// Files only their owner may read: what shows the OR or opens the door to it (recordings and
// their exports, private keys, join links) must not be readable by the other users of a shared
// machine, whatever their umask says (POSIX open(2) modes; 0600 = owner read + write).
#include <filesystem>
#include <string_view>

namespace volcast {

/// Opens `path` for writing with mode 0600: created so, or, when `exclusive` is false and it
/// exists, truncated and its mode set to 0600 (an older 0644 file does not stay readable).
/// `exclusive`: an existing file is an Error (O_EXCL). Returns the descriptor (O_CLOEXEC; the
/// caller closes it). Throws Error naming the file and the system's reason.
int open_private_file(const std::filesystem::path& path, bool exclusive);

/// Writes `bytes` to `path` through open_private_file (mode 0600). Throws Error naming the file.
void write_private_file(const std::filesystem::path& path, std::string_view bytes,
                        bool exclusive = false);

/// Sets an existing file's mode to 0600 (for files a library wrote: Open3D's PLY, libpng's PNG).
/// Throws Error naming the file and the reason.
void restrict_to_owner(const std::filesystem::path& path);

}  // namespace volcast
