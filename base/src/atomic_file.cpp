#include "gonio/base/atomic_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <mutex>
#include <random>

namespace gonio {
namespace {

// Temporary files open in this process, removed by the signal handler. Fixed storage: the handler
// may only call async-signal-safe functions (unlink) and read what is already there.
constexpr int kSlots = 16;
constexpr std::size_t kSlotPath = 4096;
std::array<std::atomic<bool>, kSlots> g_slot_used{};
std::array<std::array<char, kSlotPath>, kSlots> g_slot_path{};
std::mutex g_slot_mutex;
std::once_flag g_handlers_once;

void remove_temps_and_reraise(int sig) {
    for (int i = 0; i < kSlots; ++i) {
        if (g_slot_used[i].load()) {
            ::unlink(g_slot_path[i].data());
        }
    }
    std::signal(sig, SIG_DFL);
    std::raise(sig);
}

void install_handlers() {
    for (int sig : {SIGINT, SIGTERM, SIGHUP}) {
        struct sigaction old {};
        if (::sigaction(sig, nullptr, &old) == 0 && old.sa_handler == SIG_DFL) {
            // Only where nobody else handles the signal (a campaign's own handler stays).
            struct sigaction sa {};
            sa.sa_handler = remove_temps_and_reraise;
            sigemptyset(&sa.sa_mask);
            ::sigaction(sig, &sa, nullptr);
        }
    }
}

int register_temp(const std::string& path) {
    std::call_once(g_handlers_once, install_handlers);
    if (path.size() >= kSlotPath) {
        return -1;
    }
    std::lock_guard<std::mutex> lock(g_slot_mutex);
    for (int i = 0; i < kSlots; ++i) {
        if (!g_slot_used[i].load()) {
            std::memcpy(g_slot_path[i].data(), path.c_str(), path.size() + 1);
            g_slot_used[i].store(true);
            return i;
        }
    }
    return -1;
}

void unregister_temp(int slot) {
    if (slot >= 0) {
        std::lock_guard<std::mutex> lock(g_slot_mutex);
        g_slot_used[slot].store(false);
    }
}

std::string errno_text(int err) {
    return std::strerror(err);
}

// Folder and file name of a path ("a/b.csv" -> "a", "b.csv"; "b.csv" -> ".", "b.csv").
std::pair<std::string, std::string> split_path(const std::string& path) {
    const std::size_t slash = path.find_last_of('/');
    if (slash == std::string::npos) {
        return {".", path};
    }
    return {slash == 0 ? "/" : path.substr(0, slash), path.substr(slash + 1)};
}

std::string random_suffix() {
    static std::mutex m;
    static std::mt19937_64 gen{(static_cast<std::uint64_t>(std::random_device{}()) << 32) ^
                               std::random_device{}() ^ static_cast<std::uint64_t>(::getpid())};
    std::lock_guard<std::mutex> lock(m);
    char buf[17];
    std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(gen()));
    return buf;
}

const char* kind_of(mode_t mode) {
    if (S_ISDIR(mode)) {
        return "a folder";
    }
    if (S_ISCHR(mode) || S_ISBLK(mode)) {
        return "a device";
    }
    if (S_ISFIFO(mode)) {
        return "a FIFO";
    }
    if (S_ISSOCK(mode)) {
        return "a socket";
    }
    return "not a regular file";
}

}  // namespace

Expected<void> check_output_path(const std::string& path) {
    if (path.empty()) {
        return make_error("output path is empty");
    }
    if (path.back() == '/') {
        return make_error(path + ": output path names a folder; give a file name");
    }
    struct stat st {};
    if (::lstat(path.c_str(), &st) == 0) {
        if (S_ISLNK(st.st_mode)) {
            struct stat target {};
            if (::stat(path.c_str(), &target) == 0 && !S_ISREG(target.st_mode)) {
                return make_error(path + ": output path is a link to " + kind_of(target.st_mode) +
                                  "; refusing to replace it with a regular file");
            }
        } else if (!S_ISREG(st.st_mode)) {
            return make_error(path + ": output path is " + kind_of(st.st_mode) +
                              "; give a regular file name");
        }
    } else if (errno != ENOENT && errno != ENOTDIR) {
        return make_error(path + ": cannot inspect output path: " + errno_text(errno));
    }
    const std::string dir = split_path(path).first;
    struct stat dst {};
    if (::stat(dir.c_str(), &dst) != 0) {
        return make_error(path + ": output folder " + dir + " does not exist");
    }
    if (!S_ISDIR(dst.st_mode)) {
        return make_error(path + ": " + dir + " is not a folder");
    }
    return {};
}

Expected<AtomicFile> AtomicFile::create(const std::string& path) {
    if (auto ok = check_output_path(path); !ok) {
        return tl::unexpected(ok.error());
    }
    const auto [dir, name] = split_path(path);
    AtomicFile f;
    f.path_ = path;
    for (int attempt = 0; attempt < 16; ++attempt) {
        const std::string temp =
            (dir == "/" ? "" : dir) + "/." + name + "." + random_suffix() + ".tmp";
        const int fd =
            ::open(temp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644);
        if (fd >= 0) {
            f.fd_ = fd;
            f.temp_ = temp;
            f.slot_ = register_temp(temp);
            return f;
        }
        if (errno != EEXIST) {
            return make_error(path + ": cannot create a temporary file in " + dir + ": " +
                              errno_text(errno));
        }
    }
    return make_error(path + ": cannot create a temporary file in " + dir +
                      ": 16 random names already taken");
}

AtomicFile::AtomicFile(AtomicFile&& other) noexcept
    : path_(std::move(other.path_)),
      temp_(std::move(other.temp_)),
      fd_(other.fd_),
      slot_(other.slot_),
      error_(std::move(other.error_)) {
    other.fd_ = -1;
    other.slot_ = -1;
    other.temp_.clear();
}

AtomicFile& AtomicFile::operator=(AtomicFile&& other) noexcept {
    if (this != &other) {
        discard();
        path_ = std::move(other.path_);
        temp_ = std::move(other.temp_);
        fd_ = other.fd_;
        slot_ = other.slot_;
        error_ = std::move(other.error_);
        other.fd_ = -1;
        other.slot_ = -1;
        other.temp_.clear();
    }
    return *this;
}

AtomicFile::~AtomicFile() {
    discard();
}

void AtomicFile::discard() {
    if (fd_ >= 0) {
        ::close(fd_);
        fd_ = -1;
    }
    if (!temp_.empty()) {
        ::unlink(temp_.c_str());
        temp_.clear();
    }
    unregister_temp(slot_);
    slot_ = -1;
}

Expected<void> AtomicFile::write(std::string_view bytes) {
    if (!error_.empty()) {
        return make_error(error_);
    }
    if (fd_ < 0) {
        return make_error(path_ + ": file is already closed");
    }
    std::size_t done = 0;
    while (done < bytes.size()) {
        const ssize_t n = ::write(fd_, bytes.data() + done, bytes.size() - done);
        if (n < 0) {
            if (errno == EINTR) {
                continue;
            }
            error_ = path_ + ": write failed: " + errno_text(errno) + " (nothing written; " +
                     "the previous file, if any, is kept)";
            return make_error(error_);
        }
        done += static_cast<std::size_t>(n);
    }
    return {};
}

Expected<void> AtomicFile::commit() {
    if (!error_.empty()) {
        discard();
        return make_error(error_);
    }
    if (fd_ < 0) {
        return make_error(path_ + ": file is already closed");
    }
    if (::fsync(fd_) != 0) {
        const std::string why = errno_text(errno);
        discard();
        return make_error(path_ + ": fsync failed: " + why + " (previous file kept)");
    }
    const int fd = fd_;
    fd_ = -1;
    if (::close(fd) != 0) {
        const std::string why = errno_text(errno);
        discard();
        return make_error(path_ + ": close failed: " + why + " (previous file kept)");
    }
    if (::rename(temp_.c_str(), path_.c_str()) != 0) {
        const std::string why = errno_text(errno);
        discard();
        return make_error(path_ + ": cannot rename the temporary file into place: " + why);
    }
    temp_.clear();
    unregister_temp(slot_);
    slot_ = -1;
    const int dfd = ::open(split_path(path_).first.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (dfd >= 0) {
        // Makes the rename durable; a folder that cannot be fsynced (some file systems) is no
        // error.
        ::fsync(dfd);
        ::close(dfd);
    }
    return {};
}

Expected<void> write_file_atomic(const std::string& path, std::string_view bytes) {
    Expected<AtomicFile> f = AtomicFile::create(path);
    if (!f) {
        return tl::unexpected(f.error());
    }
    if (auto w = f->write(bytes); !w) {
        return w;
    }
    return f->commit();
}

}  // namespace gonio
