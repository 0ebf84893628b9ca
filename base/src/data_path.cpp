#include "gonio/base/data_path.h"

#include <dlfcn.h>
#include <link.h>
#include <sys/stat.h>
#include <unistd.h>

#include <climits>
#include <cstdlib>
#include <fstream>

#include "install_layout.h"

namespace gonio {
namespace {

bool is_file(const std::string& path) {
    struct stat st {};
    return ::stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode);
}

std::string parent_dir(const std::string& path) {
    const std::size_t slash = path.find_last_of('/');
    if (slash == std::string::npos) {
        return ".";
    }
    return slash == 0 ? "/" : path.substr(0, slash);
}

std::string executable_path() {
    char buf[4096];
    const ssize_t len = ::readlink("/proc/self/exe", buf, sizeof buf - 1);
    if (len <= 0) {
        return {};
    }
    buf[len] = '\0';
    return buf;
}

/// The path of the shared object holding this code, or empty when it is linked into the
/// executable (the main program's link map has an empty name).
std::string shared_object_path() {
    Dl_info info{};
    link_map* map = nullptr;
    if (::dladdr1(reinterpret_cast<void*>(&shared_object_path),
                  &info,
                  reinterpret_cast<void**>(&map),
                  RTLD_DL_LINKMAP) == 0 ||
        map == nullptr || map->l_name == nullptr || map->l_name[0] == '\0') {
        return {};
    }
    char resolved[PATH_MAX];
    return ::realpath(map->l_name, resolved) != nullptr ? std::string(resolved) : std::string();
}

/// The value of gonio_SOURCE_DIR in a CMakeCache.txt, or empty.
std::string cached_source_dir(const std::string& cache) {
    std::ifstream in(cache);
    const std::string key = "gonio_SOURCE_DIR:STATIC=";
    std::string line;
    while (std::getline(in, line)) {
        if (line.compare(0, key.size(), key) == 0) {
            return line.substr(key.size());
        }
    }
    return {};
}

}  // namespace

std::string binary_dir() {
    std::string path = shared_object_path();
    if (path.empty()) {
        path = executable_path();
    }
    return path.empty() ? std::string() : parent_dir(path);
}

std::string build_tree_data_dir(const std::string& dir) {
    std::string d = dir;
    for (int up = 0; up <= 3 && !d.empty(); ++up) {
        const std::string cache = d + "/CMakeCache.txt";
        if (is_file(cache)) {
            const std::string source = cached_source_dir(cache);
            return source.empty() ? std::string() : source + "/data";
        }
        if (d == "/") {
            break;
        }
        d = parent_dir(d);
    }
    return {};
}

std::vector<DataDirCandidate> data_dir_candidates() {
    std::vector<DataDirCandidate> dirs;
    const std::string bin = binary_dir();
    if (!bin.empty()) {
        for (const char* relative : kInstalledDataDirs) {
            dirs.push_back({bin + "/" + relative, "install"});
        }
    }
    if (const char* env = std::getenv("GONIO_DATA_DIR"); env != nullptr && *env != '\0') {
        dirs.push_back({env, "$GONIO_DATA_DIR"});
    }
    if (!bin.empty()) {
        if (std::string source = build_tree_data_dir(bin); !source.empty()) {
            dirs.push_back({source, "build tree"});
        }
    }
    return dirs;
}

Expected<std::string> find_data_file(const std::string& relative) {
    std::string tried;
    for (const DataDirCandidate& c : data_dir_candidates()) {
        const std::string p = c.dir + "/" + relative;
        if (is_file(p)) {
            return p;
        }
        tried += (tried.empty() ? "" : ", ") + p + " (" + c.origin + ")";
    }
    if (tried.empty()) {
        tried = "nothing: the program's own path is unreadable and $GONIO_DATA_DIR is unset";
    }
    return make_error("data file \"" + relative + "\" not found (tried " + tried + ")");
}

}  // namespace gonio
