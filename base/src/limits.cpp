#include "gonio/base/limits.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "gonio/base/strings.h"

namespace gonio {
namespace {

std::atomic<std::size_t> g_max_memory{kDefaultMaxMemoryBytes};

}  // namespace

std::size_t max_memory_bytes() {
    return g_max_memory.load();
}

void set_max_memory_bytes(std::size_t bytes) {
    g_max_memory.store(bytes);
}

std::string human_bytes(double bytes) {
    static const char* const kUnits[] = {"B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"};
    int u = 0;
    while (bytes >= 1024 && u < 6) {
        bytes /= 1024;
        ++u;
    }
    char buf[48];
    if (u == 0) {
        std::snprintf(buf, sizeof buf, "%.0f B", bytes);
    } else {
        std::snprintf(buf, sizeof buf, "%.3g %s", bytes, kUnits[u]);
    }
    return buf;
}

std::string show_number(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.6g", v);
    return buf;
}

Expected<std::size_t> parse_byte_size(const std::string& text) {
    const auto bad = [&] {
        return make_error("memory size \"" + text.substr(0, 64) +
                          "\": expected a number of bytes with an optional unit k, M, G or T "
                          "(powers of 1024), e.g. 512M or 4G");
    };
    if (text.empty() || text.size() > 32) {
        return bad();
    }
    char* end = nullptr;
    errno = 0;
    const double v = std::strtod(text.c_str(), &end);
    if (end == text.c_str() || errno != 0 || !std::isfinite(v) || !(v > 0)) {
        return bad();
    }
    std::string unit(end);
    for (const char* suffix : {"iB", "B"}) {
        const std::size_t n = std::strlen(suffix);
        if (unit.size() > n && ends_with(unit, suffix)) {
            unit.resize(unit.size() - n);
            break;
        }
    }
    double mult = 1;
    if (unit.empty() || unit == "B") {
        mult = 1;
    } else if (unit == "k" || unit == "K") {
        mult = 1024.0;
    } else if (unit == "M") {
        mult = 1024.0 * 1024;
    } else if (unit == "G") {
        mult = 1024.0 * 1024 * 1024;
    } else if (unit == "T") {
        mult = 1024.0 * 1024 * 1024 * 1024;
    } else {
        return bad();
    }
    const double bytes = v * mult;
    if (!(bytes >= 1024 * 1024) || bytes > 1024.0 * 1024 * 1024 * 1024 * 1024) {
        return make_error("memory size " + text + ": must be between 1 MiB and 1 PiB");
    }
    return static_cast<std::size_t>(bytes);
}

Expected<void> check_memory(double bytes, const std::string& what) {
    const std::size_t limit = max_memory_bytes();
    if (!(bytes <= static_cast<double>(limit))) {
        return make_error(what + " needs about " + human_bytes(bytes) +
                          " of memory, above the limit of " +
                          human_bytes(static_cast<double>(limit)) +
                          " (raise it with --max-memory, e.g. --max-memory 8G)");
    }
    return {};
}

Expected<void> check_json_text(const std::string& text, const std::string& source) {
    if (text.size() > kMaxJsonBytes) {
        return make_error(source + ": " + human_bytes(static_cast<double>(text.size())) +
                          ", above the limit of " + human_bytes(kMaxJsonBytes) +
                          " for a JSON file");
    }
    int depth = 0;
    std::size_t line = 1;
    bool in_string = false;
    bool escaped = false;
    for (const char c : text) {
        if (c == '\n') {
            ++line;
        }
        if (in_string) {
            if (escaped) {
                escaped = false;
            } else if (c == '\\') {
                escaped = true;
            } else if (c == '"') {
                in_string = false;
            }
            continue;
        }
        if (c == '"') {
            in_string = true;
        } else if (c == '{' || c == '[') {
            if (++depth > kMaxJsonDepth) {
                return make_error(source + ":" + std::to_string(line) +
                                  ": objects and arrays nested deeper than " +
                                  std::to_string(kMaxJsonDepth) + " levels");
            }
        } else if (c == '}' || c == ']') {
            --depth;
        }
    }
    return {};
}

Expected<std::string> read_input_file(const std::string& path, std::size_t max_bytes) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);
    if (fd < 0) {
        return make_error(path + ": cannot open: " + std::strerror(errno));
    }
    struct stat st {};
    if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
        ::close(fd);
        return make_error(path + ": not a regular file");
    }
    if (static_cast<std::size_t>(st.st_size) > max_bytes) {
        ::close(fd);
        return make_error(path + ": " + human_bytes(static_cast<double>(st.st_size)) +
                          ", above the limit of " + human_bytes(static_cast<double>(max_bytes)) +
                          " for this kind of file");
    }
    std::string text;
    text.resize(static_cast<std::size_t>(st.st_size));
    std::size_t done = 0;
    while (done < text.size()) {
        const ssize_t n = ::read(fd, &text[done], text.size() - done);
        if (n < 0 && errno == EINTR) {
            continue;
        }
        if (n <= 0) {
            break;
        }
        done += static_cast<std::size_t>(n);
    }
    ::close(fd);
    text.resize(done);
    return text;
}

}  // namespace gonio
