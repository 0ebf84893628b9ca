#include "gonio/brdf/merl.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <system_error>

#include "gonio/base/atomic_file.h"
#include "gonio/base/huge_pages.h"
#include "gonio/base/limits.h"
#include "gonio/base/strings.h"

namespace gonio::brdf {
namespace {

constexpr std::size_t kHeaderBytes = 12;

#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__
constexpr bool kHostLittleEndian = false;
#else
constexpr bool kHostLittleEndian = true;
#endif

// Reverses the byte order of n 8-byte words in place (big-endian hosts only).
void swap_doubles(double* p, std::size_t n) {
    for (std::size_t k = 0; k < n; ++k) {
        unsigned char b[8];
        std::memcpy(b, p + k, 8);
        for (int j = 0; j < 4; ++j) {
            const unsigned char t = b[j];
            b[j] = b[7 - j];
            b[7 - j] = t;
        }
        std::memcpy(p + k, b, 8);
    }
}

std::int32_t read_le_i32(const std::uint8_t* p) {
    const std::uint32_t u =
        static_cast<std::uint32_t>(p[0]) | (static_cast<std::uint32_t>(p[1]) << 8) |
        (static_cast<std::uint32_t>(p[2]) << 16) | (static_cast<std::uint32_t>(p[3]) << 24);
    std::int32_t v;
    std::memcpy(&v, &u, 4);
    return v;
}

void write_le_i32(std::uint8_t* p, std::int32_t v) {
    std::uint32_t u;
    std::memcpy(&u, &v, 4);
    for (int j = 0; j < 4; ++j) {
        p[j] = static_cast<std::uint8_t>((u >> (8 * j)) & 0xffu);
    }
}

// Checks the three dims from the header; returns an empty string or the rule broken.
std::string check_dims(const std::int32_t d[3], MerlDims dims) {
    const std::string got =
        std::to_string(d[0]) + ", " + std::to_string(d[1]) + ", " + std::to_string(d[2]);
    if (dims == MerlDims::kMerlOnly) {
        if (d[0] != 90 || d[1] != 90 || d[2] != 180) {
            return "header dims are " + got + ", the MERL format requires 90, 90, 180";
        }
        return {};
    }
    for (int a = 0; a < 3; ++a) {
        if (d[a] < 1 || d[a] > kMaxTableDim) {
            return "header dims are " + got + ", each must be in [1, " +
                   std::to_string(kMaxTableDim) + "]";
        }
    }
    return {};
}

// Validates a decoded body: every entry finite. Returns an empty string or the first bad entry.
std::string check_finite(const double* v, const TableGrid& grid) {
    const std::size_t n = grid.size();
    for (std::size_t k = 0; k < 3 * n; ++k) {
        if (!std::isfinite(v[k])) {
            const std::size_t flat = k % n;
            const std::array<int, 3> b = grid.unflatten(flat);
            return std::string("entry ") + std::to_string(k) + " (channel " + "rgb"[k / n] +
                   ", theta_h bin " + std::to_string(b[0]) + ", theta_d bin " +
                   std::to_string(b[1]) + ", phi_d bin " + std::to_string(b[2]) + ") is " +
                   (std::isnan(v[k]) ? "NaN" : "infinite") + "; stored values must be finite";
        }
    }
    return {};
}

// "<name>: 204 bytes, dims 90 x 90 x 180 require 34992012 (truncated)".
std::string size_message(const std::string& name, std::size_t size, const TableGrid& g) {
    const std::size_t expected = merl_file_size(g);
    return name + ": " + std::to_string(size) + " bytes, dims " + std::to_string(g.n_theta_h) +
           " x " + std::to_string(g.n_theta_d) + " x " + std::to_string(g.n_phi_d) + " require " +
           std::to_string(expected) + (size < expected ? " (truncated)" : " (trailing bytes)");
}

struct FileCloser {
    void operator()(std::FILE* f) const { std::fclose(f); }
};
using FilePtr = std::unique_ptr<std::FILE, FileCloser>;

}  // namespace

std::size_t merl_file_size(const TableGrid& grid) {
    return kHeaderBytes + 24 * grid.size();
}

Expected<TabulatedBrdf> parse_merl(const std::uint8_t* data,
                                   std::size_t size,
                                   const std::string& name,
                                   MerlDims dims) {
    if (size < kHeaderBytes) {
        return make_error(name + ": " + std::to_string(size) +
                          " bytes, shorter than the 12-byte header of three int32 dims");
    }
    const std::int32_t d[3] = {read_le_i32(data), read_le_i32(data + 4), read_le_i32(data + 8)};
    const std::string bad_dims = check_dims(d, dims);
    if (!bad_dims.empty()) {
        return make_error(name + ": " + bad_dims);
    }
    const TableGrid grid{d[0], d[1], d[2]};
    if (size != merl_file_size(grid)) {
        return make_error(size_message(name, size, grid));
    }
    TableValues raw;
    resize_huge_unwritten(raw, 3 * grid.size());
    std::memcpy(raw.data(), data + kHeaderBytes, raw.size() * sizeof(double));
    if (!kHostLittleEndian) {
        swap_doubles(raw.data(), raw.size());
    }
    const std::string bad = check_finite(raw.data(), grid);
    if (!bad.empty()) {
        return make_error(name + ": " + bad);
    }
    return TabulatedBrdf(grid, kMerlScale, std::move(raw), name);
}

Expected<TabulatedBrdf> read_merl(const std::string& path, MerlDims dims) {
    namespace fs = std::filesystem;
    std::error_code ec;
    const fs::file_status st = fs::status(path, ec);
    if (ec || !fs::exists(st)) {
        return make_error(path + ": cannot open: no such file");
    }
    if (fs::is_directory(st)) {
        return make_error(path + ": is a directory, expected a MERL binary file");
    }
    if (!fs::is_regular_file(st)) {
        return make_error(path + ": not a regular file, expected a MERL binary file");
    }
    const std::uintmax_t file_size = fs::file_size(path, ec);
    if (ec) {
        return make_error(path + ": cannot read its size: " + ec.message());
    }
    FilePtr f(std::fopen(path.c_str(), "rb"));
    if (!f) {
        return make_error(path + ": cannot open: " + std::strerror(errno));
    }
    // Header first, then the body straight into the table's storage: one pass over the bytes.
    std::uint8_t header[kHeaderBytes];
    const std::size_t got_header = std::fread(header, 1, kHeaderBytes, f.get());
    if (got_header < kHeaderBytes) {
        return parse_merl(header, got_header, path, dims);
    }
    const std::int32_t d[3] = {
        read_le_i32(header), read_le_i32(header + 4), read_le_i32(header + 8)};
    const std::string bad_dims = check_dims(d, dims);
    if (!bad_dims.empty()) {
        return make_error(path + ": " + bad_dims);
    }
    const TableGrid grid{d[0], d[1], d[2]};
    if (file_size != merl_file_size(grid)) {
        // Checked before allocating: the header alone must not decide how much memory is taken.
        return make_error(size_message(path, static_cast<std::size_t>(file_size), grid));
    }
    // Values and validity flags of the table.
    if (auto ok = check_memory(static_cast<double>(grid.size()) * (3 * 8 + 1), path); !ok) {
        return tl::unexpected(ok.error());
    }
    // Written once, by the read.
    TableValues raw;
    resize_huge_unwritten(raw, 3 * grid.size());
    const std::size_t want = raw.size() * sizeof(double);
    const std::size_t got = std::fread(raw.data(), 1, want, f.get());
    if (std::ferror(f.get())) {
        return make_error(path + ": read error: " + std::strerror(errno));
    }
    std::size_t trailing = 0;
    if (got == want) {
        unsigned char extra[256];
        std::size_t more = 0;
        while ((more = std::fread(extra, 1, sizeof extra, f.get())) > 0) {
            trailing += more;
        }
    }
    const std::size_t size = kHeaderBytes + got + trailing;
    if (got != want || trailing != 0) {
        // The file changed size while being read.
        return make_error(size_message(path, size, grid));
    }
    if (!kHostLittleEndian) {
        swap_doubles(raw.data(), raw.size());
    }
    const std::string bad = check_finite(raw.data(), grid);
    if (!bad.empty()) {
        return make_error(path + ": " + bad);
    }
    return TabulatedBrdf(grid, kMerlScale, std::move(raw), path);
}

std::vector<std::uint8_t> encode_merl(const TabulatedBrdf& table) {
    const TableGrid& grid = table.grid();
    std::vector<std::uint8_t> out(merl_file_size(grid));
    write_le_i32(out.data(), grid.n_theta_h);
    write_le_i32(out.data() + 4, grid.n_theta_d);
    write_le_i32(out.data() + 8, grid.n_phi_d);
    const TableValues& raw = table.raw();
    std::memcpy(out.data() + kHeaderBytes, raw.data(), raw.size() * sizeof(double));
    if (!kHostLittleEndian) {
        std::vector<double> tmp(raw.begin(), raw.end());
        swap_doubles(tmp.data(), tmp.size());
        std::memcpy(out.data() + kHeaderBytes, tmp.data(), tmp.size() * sizeof(double));
    }
    return out;
}

Expected<void> write_merl(const std::string& path, const TabulatedBrdf& table) {
    if (table.scale() != kMerlScale) {
        return make_error(path +
                          ": the table's scale is not MERL's (1/1500, 1.15/1500, 1.66/1500)");
    }
    const TableGrid& g = table.grid();
    if (!ends_with(path, ".gtab") && (g.n_theta_h != 90 || g.n_theta_d != 90 || g.n_phi_d != 180)) {
        return make_error(path + ": grid " + std::to_string(g.n_theta_h) + " x " +
                          std::to_string(g.n_theta_d) + " x " + std::to_string(g.n_phi_d) +
                          " cannot be written as MERL (90 x 90 x 180); use a .gtab path");
    }
    const std::vector<std::uint8_t> bytes = encode_merl(table);
    return write_file_atomic(
        path, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
}

bool is_table_path(const std::string& path) {
    return ends_with(path, ".binary") || ends_with(path, ".merl") || ends_with(path, ".gtab");
}

Expected<TabulatedBrdf> read_table_file(const std::string& path) {
    if (ends_with(path, ".gtab")) {
        return read_merl(path, MerlDims::kAny);
    }
    if (ends_with(path, ".binary") || ends_with(path, ".merl")) {
        return read_merl(path, MerlDims::kMerlOnly);
    }
    return make_error(path + ": not a table file (expected .binary, .merl or .gtab)");
}

}  // namespace gonio::brdf
