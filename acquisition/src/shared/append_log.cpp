#include "gonio/acquisition/shared/append_log.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <utility>

namespace gonio::acquisition {

namespace {

std::string errno_text() {
    return std::strerror(errno);
}

}  // namespace

Expected<AppendLog> AppendLog::replay(const std::string& path,
                                      const NextRecord& next,
                                      bool* torn_tail) {
    std::string content;
    const int in = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW);
    if (in >= 0) {
        char buf[1 << 16];
        ssize_t n;
        while ((n = ::read(in, buf, sizeof buf)) > 0) {
            content.append(buf, static_cast<std::size_t>(n));
        }
        const bool failed = n < 0;
        ::close(in);
        if (failed) {
            return make_error(path + ": read failed: " + errno_text());
        }
    } else if (errno != ENOENT) {
        return make_error(path + ": cannot open: " + errno_text());
    }
    std::size_t good_end = 0;
    *torn_tail = false;
    while (good_end < content.size()) {
        auto end = next(content, good_end);
        if (!end) {
            return tl::unexpected(end.error());
        }
        if (!end->has_value()) {
            *torn_tail = true;
            break;
        }
        good_end = **end;
    }
    AppendLog log;
    log.path_ = path;
    log.fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_CLOEXEC | O_NOFOLLOW, 0644);
    if (log.fd_ < 0) {
        return make_error(path + ": cannot open for appending: " + errno_text());
    }
    if (good_end != content.size()) {
        if (::ftruncate(log.fd_, static_cast<off_t>(good_end)) != 0 || ::fsync(log.fd_) != 0) {
            return make_error(path + ": cannot cut the damaged last record: " + errno_text());
        }
    }
    if (::lseek(log.fd_, static_cast<off_t>(good_end), SEEK_SET) < 0) {
        return make_error(path + ": seek failed: " + errno_text());
    }
    return log;
}

AppendLog::AppendLog(AppendLog&& o) noexcept : path_(std::move(o.path_)), fd_(o.fd_) {
    o.fd_ = -1;
}

AppendLog& AppendLog::operator=(AppendLog&& o) noexcept {
    if (this != &o) {
        if (fd_ >= 0) {
            ::close(fd_);
        }
        path_ = std::move(o.path_);
        fd_ = o.fd_;
        o.fd_ = -1;
    }
    return *this;
}

AppendLog::~AppendLog() {
    if (fd_ >= 0) {
        ::close(fd_);
    }
}

Expected<void> AppendLog::append(const std::string& bytes) {
    std::size_t done = 0;
    while (done < bytes.size()) {
        const ssize_t n = ::write(fd_, bytes.data() + done, bytes.size() - done);
        if (n < 0) {
            if (errno == EINTR) {
                continue;
            }
            return make_error(path_ + ": write failed: " + errno_text());
        }
        done += static_cast<std::size_t>(n);
    }
    if (::fsync(fd_) != 0) {
        return make_error(path_ + ": fsync failed: " + errno_text());
    }
    return {};
}

}  // namespace gonio::acquisition
