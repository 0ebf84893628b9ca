#include "gonio/brdf/samples_io.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <utility>

#include "gonio/base/huge_pages.h"
#include "gonio/base/limits.h"
#include "gonio/base/strings.h"
#include "gonio/base/thread_pool.h"
#include "gonio/brdf/merl.h"
#include "gonio/brdf/rgl_bsdf.h"
#include "gonio/brdf/values_below_zero.h"
#include "sample_columns.h"

namespace gonio::brdf {

using namespace detail;  // the dataset columns of sample_columns.h
namespace {

// ---------------------------------------------------------------------------------------------
// Dataset CSV reader: the whole file is read at once, split at line boundaries into one chunk per
// thread of the project's pool, and each chunk is parsed in place (no per-line string, no per-field
// copy). Numbers go through std::from_chars (correctly rounded, locale-free); a field it does not
// take whole (for example "+1" or "0x1p3") is retried with strtod on a nul-terminated copy so that
// every number strtod accepts is read.

/// Accepted range of each column and its wording in messages.
struct Range {
    double lo, hi;
    bool hi_open;  ///< [lo, hi) instead of [lo, hi]
    const char* text;
};

Range column_range(int c) {
    switch (path_base_column(c)) {
        case kTi:
        case kTo:
            return {0.0, kPi / 2, true, "[0, pi/2)"};
        case kPhiI:
        case kPo:
            return {-2 * kPi, 2 * kPi, false, "[-2 pi, 2 pi]"};
        case kW:
            return {0.0, kMaxSampleWeight, false, "[0, 1e9]"};
        case kF:
            return {0.0, 4294967295.0, false, "[0, 4294967295] (unsigned 32-bit integer)"};
        case kR:
        case kG:
        case kB:
            // Values below zero within their noise are measurements (values_below_zero.h); how
            // far below is judged once the whole file is read.
            return {-kMaxSampleValue, kMaxSampleValue, false, "[-1e9, 1e9] 1/sr"};
        default:
            return {0.0, kMaxSampleValue, false, "[0, 1e9] 1/sr"};
    }
}

bool is_space(char c) {
    return c == ' ' || c == '\t' || c == '\r';
}

/// Parses [b, e) (already trimmed) as a whole number. False when it is not one.
/// A field as quoted in an error message: at most 24 characters, longer ones cut with their length
/// said, so a hostile file cannot fill the message (or the terminal) with one field.
std::string shown(const char* b, const char* e) {
    constexpr std::ptrdiff_t kMax = 24;
    if (e - b <= kMax) {
        return std::string(b, e);
    }
    return std::string(b, b + kMax) + "... (" + std::to_string(e - b) + " characters)";
}

bool parse_number(const char* b, const char* e, double* out) {
    if (b == e) {
        return false;
    }
    const std::from_chars_result r = std::from_chars(b, e, *out);
    if (r.ec == std::errc() && r.ptr == e) {
        return true;
    }
    // Out of range for a double, or a form from_chars does not take (a leading '+', hex): strtod
    // on a copy decides (its ERANGE overflow is a number outside every column's range anyway).
    char buf[128];
    const std::size_t n = static_cast<std::size_t>(e - b);
    if (n >= sizeof buf) {
        return false;
    }
    std::memcpy(buf, b, n);
    buf[n] = 0;
    char* end = nullptr;
    const double v = std::strtod(buf, &end);
    if (end != buf + n) {
        return false;
    }
    *out = v;
    return true;
}

std::string fmt_value(double v) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.17g", v);
    return buf;
}

/// The layout of the columns, from the header.
struct Layout {
    int index[kNumCols];      ///< field position of each column, -1 when absent
    int column_of[kNumCols];  ///< column of each field position
    std::size_t num_fields = 0;
};

/// The first error of a chunk (the lowest line), or with keep_going the rows it refused (at most
/// max_rejected + 1: one more than allowed is enough to know that the file has too many).
struct ChunkResult {
    Sample* samples = nullptr;   ///< where the chunk's rows go: room for one per line of the chunk
    std::size_t count = 0;       ///< rows stored
    std::size_t error_line = 0;  ///< 0 = none
    std::string error;
    std::vector<RejectedRow> rejected;
};

/// Why a value x of column c is outside the column's range r, with a hint when the value looks
/// like degrees.
std::string out_of_range_reason(int c, double x, const Range& r) {
    std::string reason = std::string(kColNames[c]) + " = " + fmt_value(x) + " outside " + r.text;
    const int base = path_base_column(c);
    if ((base == kTi || base == kTo) && x >= r.hi) {
        // A polar angle in (pi/2, 90] is most likely written in degrees.
        reason += x > r.hi && x <= 90 ? " (at or below the horizon; it looks like degrees: "
                                        "angles are radians, 90 deg = 1.5708)"
                                      : " (at or below the horizon)";
    }
    if ((base == kPhiI || base == kPo) && std::abs(x) <= 360) {
        // An azimuth in (2 pi, 360] is most likely written in degrees.
        reason += " (it looks like degrees: angles are radians, 180 deg = 3.1416)";
    }
    return reason;
}

/// Reads the field [b, e) (already trimmed) as column c into *x; returns why it cannot be one
/// (empty when it can).
std::string read_field(const char* b, const char* e, int c, double* x) {
    const Range r = column_range(c);
    if (!parse_number(b, e, x)) {
        return std::string(kColNames[c]) + " = \"" + shown(b, e) + "\" is not a number";
    }
    if (!std::isfinite(*x)) {
        return std::string(kColNames[c]) + " = " + shown(b, e) + " is not finite (allowed " +
               r.text + ")";
    }
    if (*x < r.lo || *x > r.hi || (r.hi_open && *x >= r.hi) || (c == kF && *x != std::floor(*x))) {
        return out_of_range_reason(c, *x, r);
    }
    return {};
}

/// A row's first problem: where (FILE:LINE[:COLUMN]: ) and why.
struct RowProblem {
    std::string where;
    std::string reason;
};

/// Reads the data line [p, le) into v (columns absent from the header keep their defaults).
/// False with *problem set at the row's first problem: its other fields are not read.
bool read_row(const char* p,
              const char* le,
              std::size_t line_no,
              const Layout& layout,
              const std::string& path,
              double* v,
              RowProblem* problem) {
    v[kSr] = v[kSg] = v[kSb] = 0;
    v[kW] = 1;
    v[kF] = 0;
    std::size_t field = 0;
    const char* fb = p;
    for (;;) {
        const char* fe = static_cast<const char*>(std::memchr(fb, ',', le - fb));
        const bool last = fe == nullptr;
        if (last) {
            fe = le;
        }
        if (field < layout.num_fields) {
            const char* b = fb;
            const char* e = fe;
            while (b < e && is_space(*b)) {
                ++b;
            }
            while (e > b && is_space(e[-1])) {
                --e;
            }
            const int c = layout.column_of[field];
            double x;
            std::string reason = read_field(b, e, c, &x);
            if (!reason.empty()) {
                // FILE:LINE:COLUMN, built only for an error (not for each of millions of fields).
                problem->where =
                    path + ":" + std::to_string(line_no) + ":" + std::to_string(field + 1) + ": ";
                problem->reason = std::move(reason);
                return false;
            }
            v[c] = x;
        }
        ++field;
        if (last) {
            break;
        }
        fb = fe + 1;
    }
    if (field != layout.num_fields) {
        problem->where = path + ":" + std::to_string(line_no) + ": ";
        problem->reason =
            std::to_string(field) + " fields, the header has " + std::to_string(layout.num_fields);
        return false;
    }
    return true;
}

/// The sample of a row read by read_row.
void store_sample(const double* v, const Layout& layout, std::size_t line_no, Sample& s) {
    s.theta_i = v[kTi];
    s.phi_i = v[kPhiI];
    s.theta_o = v[kTo];
    s.phi_o = v[kPo];
    s.value = Rgbd(v[kR], v[kG], v[kB]);
    s.sigma = Rgbd(v[kSr], v[kSg], v[kSb]);
    s.weight = v[kW];
    s.flags = static_cast<std::uint32_t>(v[kF]);
    s.line = line_no;
    if (layout.index[kTi0] >= 0) {
        for (int k = 0; k < 4; ++k) {
            s.path_start[k] = v[kTi0 + k];
            s.path_end[k] = v[kTi1 + k];
        }
        // A path that starts and ends where it is measured is a standing exposure.
        s.has_path = s.path_start != s.path_end;
    }
}

/// Blank lines (spaces, CR) and comment lines carry no data.
bool is_blank_or_comment(const char* p, const char* le) {
    while (p < le && is_space(*p)) {
        ++p;
    }
    return p == le || *p == '#';
}

void parse_chunk(const char* p,
                 const char* end,
                 std::size_t first_line,
                 const Layout& layout,
                 const std::string& path,
                 const DatasetReadOptions& options,
                 ChunkResult& out) {
    double v[kNumCols];
    RowProblem problem;
    for (std::size_t line_no = first_line; p < end; ++line_no) {
        const char* nl = static_cast<const char*>(std::memchr(p, '\n', end - p));
        const char* le = nl == nullptr ? end : nl;
        const char* line = p;
        p = nl == nullptr ? end : nl + 1;
        if (is_blank_or_comment(line, le)) {
            continue;
        }
        if (read_row(line, le, line_no, layout, path, v, &problem)) {
            store_sample(v, layout, line_no, out.samples[out.count++]);
            continue;
        }
        // A refused row: the first error of the chunk, or (keep_going) a row recorded with its
        // reason and skipped.
        if (!options.keep_going || out.rejected.size() > options.max_rejected) {
            out.error_line = line_no;
            out.error = problem.where + problem.reason;
            return;
        }
        out.rejected.push_back(RejectedRow{line_no, problem.reason});
    }
}

/// Reads the header line's fields into `layout`.
Expected<void> parse_header(
    const char* b, const char* e, const std::string& where, Layout& layout, Dataset& data) {
    for (int& i : layout.index) {
        i = -1;
    }
    std::size_t f = 0;
    const char* fb = b;
    for (;;) {
        const char* fe = static_cast<const char*>(std::memchr(fb, ',', e - fb));
        const bool last = fe == nullptr;
        if (last) {
            fe = e;
        }
        const char* nb = fb;
        const char* ne = fe;
        while (nb < ne && is_space(*nb)) {
            ++nb;
        }
        while (ne > nb && is_space(ne[-1])) {
            --ne;
        }
        const std::string name(nb, ne);
        int found = -1;
        for (int c = 0; c < kNumCols; ++c) {
            if (name == kColNames[c]) {
                found = c;
            }
        }
        if (found < 0) {
            return make_error(where + ": unknown column \"" + excerpt(name) +
                              "\" (expected theta_i,phi_i,theta_o,phi_o,r,g,b and optionally "
                              "sigma_r,sigma_g,sigma_b,weight,flag and the exposure path "
                              "theta_i_start,phi_i_start,theta_o_start,phi_o_start,theta_i_end,"
                              "phi_i_end,theta_o_end,phi_o_end)");
        }
        if (layout.index[found] >= 0) {
            return make_error(where + ": column \"" + name + "\" appears twice");
        }
        layout.index[found] = static_cast<int>(f);
        layout.column_of[f] = found;
        ++f;
        if (last) {
            break;
        }
        fb = fe + 1;
    }
    for (int c = kTi; c <= kB; ++c) {
        if (layout.index[c] < 0) {
            return make_error(where + ": header lacks the required column \"" + kColNames[c] +
                              "\"");
        }
    }
    const int sig = (layout.index[kSr] >= 0) + (layout.index[kSg] >= 0) + (layout.index[kSb] >= 0);
    if (sig != 0 && sig != 3) {
        return make_error(where + ": sigma_r, sigma_g and sigma_b must come together");
    }
    data.has_sigma = sig == 3;
    int path = 0;
    for (int c = kTi0; c <= kPo1; ++c) {
        path += layout.index[c] >= 0;
    }
    if (path != 0 && path != kPo1 - kTi0 + 1) {
        return make_error(where +
                          ": the exposure path columns theta_i_start .. phi_o_end must come "
                          "together (all eight)");
    }
    data.has_path = path != 0;
    data.has_weight = layout.index[kW] >= 0;
    data.has_flags = layout.index[kF] >= 0;
    layout.num_fields = f;
    return {};
}

/// A file's bytes: mapped read-only when it is a regular file (no copy, pages read ahead), read
/// into memory otherwise (a pipe, a FIFO).
class FileBytes {
  public:
    static Expected<FileBytes> read(const std::string& path) {
        FileBytes f;
        const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
        if (fd < 0) {
            return make_error(path + ": cannot open for reading (" + std::strerror(errno) + ")");
        }
        struct stat st {};
        if (::fstat(fd, &st) == 0 && S_ISREG(st.st_mode) && st.st_size > 0) {
            void* m = ::mmap(nullptr,
                             static_cast<std::size_t>(st.st_size),
                             PROT_READ,
                             MAP_PRIVATE | MAP_POPULATE,
                             fd,
                             0);
            if (m != MAP_FAILED) {
                ::close(fd);
                f.map_ = static_cast<const char*>(m);
                f.size_ = static_cast<std::size_t>(st.st_size);
                return f;
            }
        }
        char buf[1 << 16];
        for (;;) {
            const ssize_t n = ::read(fd, buf, sizeof buf);
            if (n < 0 && errno == EINTR) {
                continue;
            }
            if (n < 0) {
                const std::string why = std::strerror(errno);
                ::close(fd);
                return make_error(path + ": read error (" + why + ")");
            }
            if (n == 0) {
                break;
            }
            f.copy_.append(buf, static_cast<std::size_t>(n));
        }
        ::close(fd);
        return f;
    }
    FileBytes() = default;
    FileBytes(FileBytes&& o) noexcept
        : map_(std::exchange(o.map_, nullptr)),
          size_(std::exchange(o.size_, 0)),
          copy_(std::move(o.copy_)) {}
    FileBytes& operator=(FileBytes&&) = delete;
    FileBytes(const FileBytes&) = delete;
    FileBytes& operator=(const FileBytes&) = delete;
    ~FileBytes() {
        if (map_ != nullptr) {
            ::munmap(const_cast<char*>(map_), size_);
        }
    }
    const char* data() const { return map_ != nullptr ? map_ : copy_.data(); }
    std::size_t size() const { return map_ != nullptr ? size_ : copy_.size(); }

  private:
    const char* map_ = nullptr;
    std::size_t size_ = 0;
    std::string copy_;
};

/// Values below zero beyond their noise (values_below_zero.h), judged with the noise the whole
/// file implies: the first is an error naming its row and column, or with keep_going each such
/// row is moved to data.rejected (in file order with the others).
Expected<void> refuse_values_below_noise(Dataset& data,
                                         const Layout& layout,
                                         const std::string& path,
                                         const DatasetReadOptions& options) {
    const bool any = std::any_of(data.samples.begin(), data.samples.end(), [](const Sample& s) {
        return s.value.minCoeff() < 0;
    });
    if (!any) {
        return {};
    }
    const double noise = implied_noise(data.samples);
    const std::size_t rejected_before = data.rejected.size();
    std::size_t kept = 0;
    for (std::size_t i = 0; i < data.samples.size(); ++i) {
        const Sample& s = data.samples[i];
        std::string reason;
        int column = -1;
        if (s.value.minCoeff() < 0) {
            const Rgbd allowance = below_zero_allowance(s, noise);
            for (int c = 0; c < 3 && reason.empty(); ++c) {
                reason = below_zero_reason(c, s.value[c], allowance[c], s.sigma[c] > 0);
                column = layout.index[kR + c];
            }
        }
        if (reason.empty()) {
            data.samples[kept++] = s;
            continue;
        }
        const std::string where =
            path + ":" + std::to_string(s.line) + ":" + std::to_string(column + 1) + ": ";
        if (!options.keep_going || data.rejected.size() >= options.max_rejected) {
            return make_error(where + reason);
        }
        data.rejected.push_back(RejectedRow{s.line, reason});
    }
    data.samples.resize(kept);
    if (data.rejected.size() != rejected_before) {
        std::stable_sort(
            data.rejected.begin(),
            data.rejected.end(),
            [](const RejectedRow& a, const RejectedRow& b) { return a.line < b.line; });
    }
    return {};
}

/// Reads the header: the first line from *p that is neither blank nor a comment; *p and *line_no
/// move past it.
Expected<void> read_header(const char** p,
                           const char* end,
                           std::size_t* line_no,
                           const std::string& path,
                           Layout& layout,
                           Dataset& data) {
    while (*p < end) {
        const char* nl = static_cast<const char*>(std::memchr(*p, '\n', end - *p));
        const char* le = nl == nullptr ? end : nl;
        const char* line = *p;
        *p = nl == nullptr ? end : nl + 1;
        const std::size_t at = (*line_no)++;
        if (!is_blank_or_comment(line, le)) {
            Expected<void> h =
                parse_header(line, le, path + ":" + std::to_string(at), layout, data);
            if (!h) {
                return make_error(h.error().message);
            }
            return {};
        }
    }
    return make_error(path + ": empty file, expected a header theta_i,phi_i,theta_o,phi_o,r,g,b");
}

/// [p, end) cut at line boundaries, one chunk per thread of the pool for a large file (the cut
/// depends on the pool's size only): chunk k is [cut[k], cut[k + 1]).
std::vector<const char*> cut_chunks(const char* p, const char* end) {
    const std::size_t bytes = static_cast<std::size_t>(end - p);
    const unsigned chunks =
        bytes < (1u << 20) ? 1u : static_cast<unsigned>(std::min(thread_pool_size(), 16));
    std::vector<const char*> cut{p};
    for (unsigned k = 1; k < chunks; ++k) {
        const char* c = p + bytes * k / chunks;
        c = std::max(c, cut.back());
        const char* nl = static_cast<const char*>(std::memchr(c, '\n', end - c));
        cut.push_back(nl == nullptr ? end : nl + 1);
    }
    cut.push_back(end);
    return cut;
}

/// Where each chunk starts: its first line number and its first row in the samples buffer.
struct ChunkPlaces {
    std::vector<std::size_t> first_line;
    std::vector<std::size_t> first_row;  ///< one more than chunks: the last is the rows' bound
};

/// Lines per chunk (in parallel), hence each chunk's first line number and an upper bound of its
/// rows (its newlines, plus a last line without one): the rows are parsed straight into their
/// place in data.samples, one buffer for the whole file, no copy of the rows afterwards.
ChunkPlaces place_chunks(const std::vector<const char*>& cut, std::size_t line_no) {
    const std::size_t chunks = cut.size() - 1;
    std::vector<std::size_t> lines(chunks);
    parallel_for(chunks, 1, 0, [&](std::size_t, std::size_t b, std::size_t e) {
        for (std::size_t k = b; k < e; ++k) {
            lines[k] = static_cast<std::size_t>(std::count(cut[k], cut[k + 1], '\n'));
        }
    });
    ChunkPlaces places;
    places.first_line.resize(chunks);
    places.first_row.resize(chunks + 1);
    places.first_line[0] = line_no;
    places.first_row[0] = 0;
    for (std::size_t k = 0; k < chunks; ++k) {
        if (k > 0) {
            places.first_line[k] = places.first_line[k - 1] + lines[k - 1];
        }
        places.first_row[k + 1] = places.first_row[k] + lines[k] + 1;
    }
    return places;
}

/// The chunks' refused rows and rows joined in file order into `data` (rows move only where an
/// earlier chunk had blank, comment or refused lines); the first chunk's error, if any.
Expected<void> join_chunks(std::vector<ChunkResult>& results,
                           const std::string& path,
                           const DatasetReadOptions& options,
                           Dataset& data) {
    std::size_t total = 0;
    for (ChunkResult& r : results) {
        // Rows refused before a chunk's error come first in the file: they count toward the limit.
        for (RejectedRow& row : r.rejected) {
            if (data.rejected.size() == options.max_rejected) {
                return make_error(path + ":" + std::to_string(row.line) + ": " + row.reason +
                                  " (more than " + std::to_string(options.max_rejected) +
                                  " rows refused; the first at line " +
                                  std::to_string(data.rejected.front().line) + ")");
            }
            data.rejected.push_back(std::move(row));
        }
        if (r.error_line != 0) {
            return make_error(r.error);
        }
        if (r.samples != data.samples.data() + total) {
            std::move(r.samples, r.samples + r.count, data.samples.data() + total);
        }
        total += r.count;
    }
    data.samples.resize(total);
    return {};
}

}  // namespace

Expected<Dataset> read_dataset_csv(const std::string& path, const DatasetReadOptions& options) {
    auto text = FileBytes::read(path);
    if (!text) {
        return tl::unexpected(text.error());
    }
    Dataset data;
    data.source = path;
    const char* p = text->data();
    const char* end = p + text->size();
    std::size_t line_no = 1;
    Layout layout;
    if (auto h = read_header(&p, end, &line_no, path, layout, data); !h) {
        return tl::unexpected(h.error());
    }
    const std::vector<const char*> cut = cut_chunks(p, end);
    const std::size_t chunks = cut.size() - 1;
    const ChunkPlaces places = place_chunks(cut, line_no);
    const std::size_t rows = places.first_row[chunks];
    // (At most one row per line: a file of blank lines would ask for far more than it holds, so
    // the buffer is checked against the memory budget before it is made.)
    if (auto room = check_memory(static_cast<double>(rows) * sizeof(Sample),
                                 path + ": " + std::to_string(rows) + " lines");
        !room) {
        return make_error(room.error().message);
    }
    resize_huge(data.samples, rows);
    std::vector<ChunkResult> results(chunks);
    for (std::size_t k = 0; k < chunks; ++k) {
        results[k].samples = data.samples.data() + places.first_row[k];
    }
    // One chunk of the pool per cut (grain 1).
    parallel_for(chunks, 1, 0, [&](std::size_t, std::size_t b, std::size_t e) {
        for (std::size_t k = b; k < e; ++k) {
            parse_chunk(
                cut[k], cut[k + 1], places.first_line[k], layout, path, options, results[k]);
        }
    });
    if (auto joined = join_chunks(results, path, options, data); !joined) {
        return tl::unexpected(joined.error());
    }
    if (auto below = refuse_values_below_noise(data, layout, path, options); !below) {
        return make_error(below.error().message);
    }
    return data;
}

Expected<Dataset> load_samples(const std::string& path, const DatasetReadOptions& csv) {
    if (ends_with(path, ".csv")) {
        return read_dataset_csv(path, csv);
    }
    if (is_table_path(path)) {
        Expected<TabulatedBrdf> table = read_table_file(path);
        if (!table) {
            return make_error(table.error().message);
        }
        Dataset data = table_to_dataset(*table);
        data.source = path;
        return data;
    }
    if (is_rgl_path(path)) {
        // The file's own nodes, each at its direction pair: no resampling.
        Expected<RglBsdf> rgl = read_rgl_bsdf(path);
        if (!rgl) {
            return tl::unexpected(rgl.error());
        }
        return rgl_nodes_to_dataset(*rgl);
    }
    return make_error(path +
                      ": unknown sample file type (expected .csv, .binary, .merl, .gtab or .bsdf)");
}

Expected<TabulateReport> export_merl(const std::string& path,
                                     const Brdf& brdf,
                                     const TabulateOptions& options) {
    TabulateReport report;
    const TabulatedBrdf table = tabulate(brdf, options, &report);
    Expected<void> w = write_merl(path, table);
    if (!w) {
        return make_error(w.error().message);
    }
    return report;
}

Expected<ResampleReport> export_merl(const std::string& path,
                                     const Dataset& data,
                                     const ResampleOptions& options) {
    ResampleReport report;
    Expected<TabulatedBrdf> table = resample_dataset(data, options, &report);
    if (!table) {
        return make_error(table.error().message);
    }
    Expected<void> w = write_merl(path, *table);
    if (!w) {
        return make_error(w.error().message);
    }
    return report;
}

}  // namespace gonio::brdf
