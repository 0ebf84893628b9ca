#pragma once

// The file underneath both campaign journals (journal.h: one hashed JSON line per event;
// image_journal.h: one hashed binary record per frame): read back record by record on opening, a
// last record that was never acknowledged (cut short by kill -9 or a power cut) cut off, then
// appended to, each record written and fsynced before append() returns. The record formats stay
// with the journals; this knows only bytes.

#include <cstddef>
#include <functional>
#include <optional>
#include <string>

#include "gonio/base/error.h"

namespace gonio::acquisition {

class AppendLog {
  public:
    /// Reads a journal's content from `pos`: the end of the record that starts there, std::nullopt
    /// when the rest of the content is a last record never acknowledged (cut short, or damaged at
    /// the very end), or an error (a damaged record with good data after it: corruption). The
    /// function keeps what it decodes.
    using NextRecord = std::function<Expected<std::optional<std::size_t>>(
        const std::string& content, std::size_t pos)>;

    /// Reads the file at `path` (missing: empty) through `next`, then opens it for appending
    /// (created if missing; never through a symbolic link) at the end of the last good record,
    /// cutting anything after it off (fsynced). `torn_tail` tells whether something was cut.
    static Expected<AppendLog> replay(const std::string& path,
                                      const NextRecord& next,
                                      bool* torn_tail);

    AppendLog() = default;
    AppendLog(AppendLog&& o) noexcept;
    AppendLog& operator=(AppendLog&& o) noexcept;
    AppendLog(const AppendLog&) = delete;
    AppendLog& operator=(const AppendLog&) = delete;
    ~AppendLog();

    /// Writes the bytes (one whole record), then fsync: durable when this returns.
    Expected<void> append(const std::string& bytes);
    const std::string& path() const { return path_; }

  private:
    std::string path_;
    int fd_ = -1;
};

}  // namespace gonio::acquisition
