#pragma once

// Helpers shared by the fuzz targets: the input written to a private temporary file (for readers
// that take a path), and the properties every reader's error message must have.

#include <unistd.h>

#include <algorithm>
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

/// True when `piece` occurs in the input: the message copied it (a key, a value, a column name)
/// rather than wrote it.
inline bool from_input(const std::string& piece, const std::uint8_t* input, std::size_t size) {
    if (piece.empty() || input == nullptr) {
        return false;
    }
    const char* begin = reinterpret_cast<const char*>(input);
    return std::search(begin, begin + size, piece.begin(), piece.end()) != begin + size;
}

/// Properties of every error message, judged on what gonio adds to what it quotes from the input:
/// names the input, leaks no library internals (nlohmann's "[json.exception.<kind>.<id>]" codes),
/// prints no number with 40 or more digits, stays short (quotes of the input are cut, so even a
/// long input gives a short message). A code or a digit run that the input itself contains is the
/// input's, quoted: it does not count against gonio.
inline void check_message(const char* target,
                          const std::string& message,
                          const std::string& name,
                          const std::uint8_t* input,
                          std::size_t size) {
    require(message.find(name) != std::string::npos, target, "error names the input:", message);
    // nlohmann's exception text carries a code "[json.exception.<kind>.<id>]" (kind in [a-z_],
    // id decimal). A whole code in the message is a leak unless the input holds the same code.
    const std::string code_start = "[json.exception.";
    for (std::size_t at = message.find(code_start); at != std::string::npos;
         at = message.find(code_start, at + 1)) {
        std::size_t e = at + code_start.size();
        const std::size_t kind = e;
        while (e < message.size() &&
               ((message[e] >= 'a' && message[e] <= 'z') || message[e] == '_')) {
            ++e;
        }
        if (e == kind || e >= message.size() || message[e] != '.') {
            continue;  // not a code: a quote of the input that begins like one
        }
        const std::size_t id = ++e;
        while (e < message.size() && message[e] >= '0' && message[e] <= '9') {
            ++e;
        }
        if (e == id || e >= message.size() || message[e] != ']') {
            continue;
        }
        require(from_input(message.substr(at, e + 1 - at), input, size),
                target,
                "no nlohmann exception text:",
                message.substr(0, 200));
    }
    std::size_t run_start = 0;
    for (std::size_t i = 0; i <= message.size(); ++i) {
        const bool digit = i < message.size() && message[i] >= '0' && message[i] <= '9';
        if (digit) {
            continue;
        }
        if (i - run_start >= 40) {
            require(from_input(message.substr(run_start, i - run_start), input, size),
                    target,
                    "no number printed with 40+ digits:",
                    message.substr(0, 200));
        }
        run_start = i + 1;
    }
    require(message.size() < 1024, target, "message shorter than 1 KiB:", message.substr(0, 200));
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
