#pragma once

// Helpers shared by the fuzz targets: the input written to a private temporary file (for readers
// that take a path), and the properties every reader's error message must have.

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <string>

namespace gonio::fuzz {

/// Aborts (a finding for libFuzzer, a failed ctest for the replay) when a property is violated.
inline void require(bool ok, const char* target, const char* what, const std::string& detail = "") {
    if (!ok) {
        std::fprintf(stderr, "%s fuzz: property violated: %s %s\n", target, what, detail.c_str());
        std::abort();
    }
}

/// Properties of every error message: names the input, leaks no library internals (nlohmann's
/// "[json.exception...]" codes), prints no number with dozens of digits, stays short.
inline void check_message(const char* target, const std::string& message, const std::string& name) {
    require(message.find(name) != std::string::npos, target, "error names the input:", message);
    require(message.find("json.exception") == std::string::npos,
            target,
            "no nlohmann exception text:",
            message);
    int run = 0;
    for (const char c : message) {
        run = (c >= '0' && c <= '9') ? run + 1 : 0;
        require(run < 40, target, "no number printed with 40+ digits:", message.substr(0, 200));
    }
    require(message.size() < 4096, target, "message shorter than 4 KiB");
}

/// A folder of its own under the temporary directory, removed with everything in it.
class TempDir {
  public:
    TempDir() {
        std::string tmpl = (std::filesystem::temp_directory_path() / "gonio_fuzz_XXXXXX").string();
        if (::mkdtemp(tmpl.data()) == nullptr) {
            std::perror("mkdtemp");
            std::abort();
        }
        path_ = tmpl;
    }
    ~TempDir() {
        std::error_code ec;
        std::filesystem::remove_all(path_, ec);
    }
    TempDir(const TempDir&) = delete;
    TempDir& operator=(const TempDir&) = delete;

    /// Writes bytes to NAME inside the folder and returns its path.
    std::string write(const std::string& name, const std::uint8_t* data, std::size_t size) const {
        const std::string p = path_ + "/" + name;
        std::FILE* f = std::fopen(p.c_str(), "wb");
        if (f == nullptr || (size > 0 && std::fwrite(data, 1, size, f) != size)) {
            std::perror(p.c_str());
            std::abort();
        }
        std::fclose(f);
        return p;
    }
    const std::string& path() const { return path_; }

  private:
    std::string path_;
};

}  // namespace gonio::fuzz
