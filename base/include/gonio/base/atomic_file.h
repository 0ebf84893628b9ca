#pragma once

// Output files that never follow a link and never leave debris.
//
// Every file gonio writes goes through AtomicFile: the bytes go to a temporary file created
// exclusively (O_CREAT | O_EXCL | O_NOFOLLOW, mode 0644 less the umask) under a random name
// ".NAME.XXXXXXXXXXXXXXXX.tmp" in the target's folder, which is fsynced, closed and renamed over
// the target, and the folder is fsynced. A symbolic link planted at the temporary name makes the
// creation fail instead of being followed; a link at the final name is replaced by the rename, its
// target is never opened. On any failure, on destruction without commit(), and on SIGINT, SIGTERM
// or SIGHUP while the file is open, the temporary file is removed and the previous target kept.
// std-only (POSIX), so every module can link it.

#include <cstddef>
#include <string>
#include <string_view>

#include "gonio/base/error.h"

namespace gonio {

/// Refuses, before any work starts, an output path that cannot be replaced by a regular file: an
/// existing folder, a device, FIFO or socket (also when reached through a symbolic link), an empty
/// path, or a path whose folder does not exist. A missing file, a regular file or a symbolic link
/// to one (the link itself is replaced) are accepted.
Expected<void> check_output_path(const std::string& path);

/// A file being written; see the file comment.
class AtomicFile {
  public:
    /// Checks the path (check_output_path) and creates the temporary file next to it.
    static Expected<AtomicFile> create(const std::string& path);

    AtomicFile(AtomicFile&& other) noexcept;
    AtomicFile& operator=(AtomicFile&& other) noexcept;
    AtomicFile(const AtomicFile&) = delete;
    AtomicFile& operator=(const AtomicFile&) = delete;
    /// Removes the temporary file unless commit() succeeded.
    ~AtomicFile();

    /// Appends bytes; the first failure (e.g. ENOSPC) is kept and returned by later calls too.
    Expected<void> write(std::string_view bytes);
    /// fsync, close, rename onto the target, fsync of the folder. The temporary file is removed
    /// when any step fails.
    Expected<void> commit();

    const std::string& path() const { return path_; }
    const std::string& temp_path() const { return temp_; }

  private:
    AtomicFile() = default;
    void discard();

    std::string path_;
    std::string temp_;
    int fd_ = -1;
    int slot_ = -1;
    std::string error_;
};

/// AtomicFile::create + write + commit of a whole buffer.
Expected<void> write_file_atomic(const std::string& path, std::string_view bytes);

}  // namespace gonio
