// gonio eval MODEL_OR_TABLE < dirs.csv > values.csv

#include <CLI/CLI.hpp>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <memory>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "command.h"
#include "exit_rule.h"
#include "gonio/base/atomic_file.h"
#include "gonio/brdf/analytic_brdf.h"
#include "gonio/brdf/brdf.h"
#include "gonio/brdf/model_eval_packets.h"
#include "option_checks.h"

namespace {

struct EvalOptions {
    std::string brdf_path;
    std::string input = "-";
    std::string output = "-";
};

std::string trim(const std::string& s) {
    const auto b = s.find_first_not_of(" \t\r");
    if (b == std::string::npos) {
        return {};
    }
    const auto e = s.find_last_not_of(" \t\r");
    return s.substr(b, e - b + 1);
}

std::vector<std::string> split_commas(const std::string& line) {
    std::vector<std::string> out;
    std::stringstream ss(line);
    std::string field;
    while (std::getline(ss, field, ',')) {
        out.push_back(trim(field));
    }
    if (!line.empty() && line.back() == ',') {
        out.emplace_back();
    }
    return out;
}

/// Index of each required column in the header, or an error message.
bool find_columns(const std::vector<std::string>& header, int index[4], std::string& error) {
    static const char* kNames[4] = {"theta_i", "phi_i", "theta_o", "phi_o"};
    for (int k = 0; k < 4; ++k) {
        index[k] = -1;
        for (std::size_t c = 0; c < header.size(); ++c) {
            if (header[c] == kNames[k]) {
                index[k] = static_cast<int>(c);
            }
        }
        if (index[k] < 0) {
            error = std::string("header lacks column \"") + kNames[k] +
                    "\" (required: theta_i,phi_i,theta_o,phi_o)";
            return false;
        }
    }
    return true;
}

/// Parses one data row into the four angles (radians); returns an empty string or the reason.
std::string parse_row(const std::vector<std::string>& fields,
                      std::size_t n_columns,
                      const int index[4],
                      double angles[4]) {
    static const char* kNames[4] = {"theta_i", "phi_i", "theta_o", "phi_o"};
    if (fields.size() != n_columns) {
        return std::to_string(fields.size()) + " fields, header has " + std::to_string(n_columns);
    }
    for (int k = 0; k < 4; ++k) {
        const std::string& f = fields[index[k]];
        char* end = nullptr;
        errno = 0;
        const double v = std::strtod(f.c_str(), &end);
        if (f.empty() || end != f.c_str() + f.size() || errno == ERANGE) {
            return std::string(kNames[k]) + " = \"" + f + "\": not a number";
        }
        if (!std::isfinite(v)) {
            return std::string(kNames[k]) + " = " + f + ": must be finite";
        }
        if ((k == 0 || k == 2) && (v < 0 || v > gonio::brdf::kPi)) {
            return std::string(kNames[k]) + " = " + f + ": outside [0, pi]";
        }
        angles[k] = v;
    }
    return {};
}

/// Rows evaluated together: directions as structure of arrays, an analytic model through
/// eval_model_packets, any other BRDF one row at a time; values printed in row order.
class Block {
  public:
    static constexpr std::size_t kRows = 4096;

    void add(const double angles[4], std::size_t line_no) {
        const gonio::brdf::Vec3d wi = gonio::brdf::spherical_to_cartesian(angles[0], angles[1]);
        const gonio::brdf::Vec3d wo = gonio::brdf::spherical_to_cartesian(angles[2], angles[3]);
        for (int k = 0; k < 3; ++k) {
            dir_[k].push_back(wi[k]);
            dir_[3 + k].push_back(wo[k]);
        }
        line_.push_back(line_no);
    }

    bool full() const { return line_.size() >= kRows; }

    /// Evaluates the rows held and hands their text to `emit` in one piece.
    template <typename Emit>
    void flush(const gonio::brdf::Brdf& brdf,
               Emit&& emit,
               const std::string& in_name,
               std::size_t& good,
               std::size_t& bad) {
        const std::size_t n = line_.size();
        for (std::vector<double>& v : value_) {
            v.resize(n);
        }
        const auto* analytic = dynamic_cast<const gonio::brdf::AnalyticBrdf*>(&brdf);
        if (analytic != nullptr) {
            double* const values[3] = {value_[0].data(), value_[1].data(), value_[2].data()};
            gonio::brdf::eval_model_packets(analytic->model(),
                                            n,
                                            {dir_[0].data(),
                                             dir_[1].data(),
                                             dir_[2].data(),
                                             dir_[3].data(),
                                             dir_[4].data(),
                                             dir_[5].data()},
                                            values);
        } else {
            for (std::size_t k = 0; k < n; ++k) {
                const gonio::brdf::Rgbd f =
                    brdf.eval(gonio::brdf::Vec3d(dir_[0][k], dir_[1][k], dir_[2][k]),
                              gonio::brdf::Vec3d(dir_[3][k], dir_[4][k], dir_[5][k]));
                for (int c = 0; c < 3; ++c) {
                    value_[c][k] = f[c];
                }
            }
        }
        text_.clear();
        for (std::size_t k = 0; k < n; ++k) {
            const double f[3] = {value_[0][k], value_[1][k], value_[2][k]};
            if (!std::isfinite(f[0]) || !std::isfinite(f[1]) || !std::isfinite(f[2])) {
                std::fprintf(stderr,
                             "gonio eval: %s:%zu: non-finite BRDF value (row skipped)\n",
                             in_name.c_str(),
                             line_[k]);
                ++bad;
                continue;
            }
            // %.17g, formatted by to_chars (the same digits as printf's, without its locale).
            char buf[3 * 32];
            char* p = buf;
            for (int c = 0; c < 3; ++c) {
                p = std::to_chars(p, buf + sizeof buf, f[c], std::chars_format::general, 17).ptr;
                *p++ = c < 2 ? ',' : '\n';
            }
            text_.append(buf, static_cast<std::size_t>(p - buf));
            ++good;
        }
        if (!text_.empty()) {
            emit(text_);
        }
        for (std::vector<double>& v : dir_) {
            v.clear();
        }
        line_.clear();
    }

  private:
    std::vector<double> dir_[6];
    std::vector<double> value_[3];
    std::vector<std::size_t> line_;
    std::string text_;
};

int run_eval(const EvalOptions& opts) {
    auto brdf = gonio::brdf::load_brdf(opts.brdf_path);
    if (!brdf) {
        std::fprintf(stderr, "gonio eval: %s\n", brdf.error().message.c_str());
        return 1;
    }
    std::ifstream file_in;
    std::istream* in = &std::cin;
    const std::string in_name = opts.input == "-" ? "<stdin>" : opts.input;
    if (opts.input != "-") {
        file_in.open(opts.input);
        if (!file_in) {
            std::fprintf(stderr, "gonio eval: %s: cannot open\n", opts.input.c_str());
            return 1;
        }
        in = &file_in;
    }
    // A file output goes through AtomicFile: never through a planted link, nothing left behind
    // when the command fails before the end.
    std::optional<gonio::AtomicFile> file_out;
    if (opts.output != "-") {
        auto f = gonio::AtomicFile::create(opts.output);
        if (!f) {
            std::fprintf(stderr, "gonio eval: %s\n", f.error().message.c_str());
            return 1;
        }
        file_out.emplace(std::move(*f));
    }
    auto emit = [&](const std::string& text) {
        if (file_out) {
            (void)file_out->write(text);  // the first failure is returned by commit()
        } else {
            std::fwrite(text.data(), 1, text.size(), stdout);
        }
    };
    std::string line;
    std::size_t line_no = 0;
    std::vector<std::string> header;
    int index[4] = {-1, -1, -1, -1};
    std::size_t bad = 0;
    std::size_t good = 0;
    Block block;
    while (std::getline(*in, line)) {
        ++line_no;
        const std::string t = trim(line);
        if (t.empty() || t[0] == '#') {
            // Blank lines and comments carry no row.
            continue;
        }
        if (header.empty()) {
            header = split_commas(t);
            std::string error;
            if (!find_columns(header, index, error)) {
                std::fprintf(
                    stderr, "gonio eval: %s:%zu: %s\n", in_name.c_str(), line_no, error.c_str());
                return 1;
            }
            emit("r,g,b\n");
            continue;
        }
        double a[4];
        const std::string reason = parse_row(split_commas(t), header.size(), index, a);
        if (!reason.empty()) {
            std::fprintf(stderr,
                         "gonio eval: %s:%zu: %s (row skipped)\n",
                         in_name.c_str(),
                         line_no,
                         reason.c_str());
            ++bad;
            continue;
        }
        block.add(a, line_no);
        if (block.full()) {
            block.flush(**brdf, emit, in_name, good, bad);
        }
    }
    block.flush(**brdf, emit, in_name, good, bad);
    if (header.empty()) {
        std::fprintf(stderr,
                     "gonio eval: %s: no header line (required: theta_i,phi_i,theta_o,phi_o)\n",
                     in_name.c_str());
        bad = 1;
    }
    if (header.empty()) {
        return 1;
    }
    if (file_out) {
        if (auto c = file_out->commit(); !c) {
            std::fprintf(stderr, "gonio eval: %s\n", c.error().message.c_str());
            return 1;
        }
    }
    if (bad > 0) {
        std::fprintf(stderr, "gonio eval: %zu row(s) failed, %zu evaluated\n", bad, good);
        return 1;
    }
    return 0;
}

}  // namespace

GONIO_COMMAND(eval) {
    auto* cmd = app.add_subcommand(
        "eval", "evaluate a BRDF (model JSON or table) at directions read as CSV");
    auto opts = std::make_shared<EvalOptions>();
    cmd->add_option(
           "brdf", opts->brdf_path, "Model JSON (docs/model-schema.md) or tabulated BRDF file")
        ->required()
        ->check(gonio::tools::readable_input());
    cmd->add_option("-i,--input", opts->input, "Directions CSV (default '-': standard input)")
        ->check(gonio::tools::readable_input());
    cmd->add_option("-o,--output", opts->output, "Output CSV (default '-': standard output)");
    cmd->footer(
        "Input: a header naming the columns theta_i,phi_i,theta_o,phi_o (radians; any order,\n"
        "other columns ignored), then one row per direction pair; blank lines and lines starting\n"
        "with '#' are skipped. Output: the header r,g,b, then one line per valid row with the\n"
        "BRDF in 1/sr printed with %.17g. A row that does not parse (or has theta outside\n"
        "[0, pi]) produces no output line; it is reported on standard error with its line number.\n"
        "Exit status 1 here also means that some rows were skipped.\n" +
        std::string(gonio::tools::kExitRule));
    return [opts]() -> int { return run_eval(*opts); };
}
