// gonio eval MODEL_OR_TABLE < dirs.csv > values.csv

#include <CLI/CLI.hpp>
#include <array>
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
#include "gonio/base/strings.h"
#include "gonio/brdf/brdf.h"
#include "gonio/brdf/direction_rows.h"
#include "option_checks.h"

namespace {

using gonio::trim;

struct EvalOptions {
    std::string brdf_path;
    std::string input = "-";
    std::string output = "-";
};

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
            // A polar angle above pi in radians but within [0, 180] is most likely in degrees.
            return std::string(kNames[k]) + " = " + f + ": outside [0, pi]" +
                   (v > 0 && v <= 180 ? " (it looks like degrees: angles are radians, 180 deg = "
                                        "3.1416)"
                                      : "");
        }
        angles[k] = v;
    }
    return {};
}

/// The output line of a row that gives no value (refused, or a non-finite BRDF value): it keeps
/// its place, so that output row k answers input row k.
constexpr const char* kNanRow = "nan,nan,nan\n";

/// Rows evaluated together (brdf::DirectionRows: Brdf::eval_many, an analytic model on packets);
/// values (or the NaN row of a refused row) printed in input order.
class Block {
  public:
    static constexpr std::size_t kRows = 4096;

    void add(const double angles[4], std::size_t line_no) {
        rows_.add(gonio::brdf::spherical_to_cartesian(angles[0], angles[1]),
                  gonio::brdf::spherical_to_cartesian(angles[2], angles[3]));
        line_.push_back(line_no);
    }

    /// A refused row: its place, printed as NaN.
    void add_refused(std::size_t line_no) {
        rows_.add_refused();
        line_.push_back(line_no);
    }

    bool full() const { return line_.size() >= kRows; }

    /// Evaluates the rows held and hands their text to `emit` in one piece; returns the number
    /// of evaluated rows whose value was not finite (reported by line, printed as NaN).
    template <typename Emit>
    std::size_t flush(const gonio::brdf::Brdf& brdf, Emit&& emit, const std::string& in_name) {
        const std::size_t n = line_.size();
        for (std::vector<double>& v : value_) {
            v.resize(n);
        }
        double* const values[3] = {value_[0].data(), value_[1].data(), value_[2].data()};
        const std::vector<std::size_t> non_finite = rows_.evaluate(brdf, values);
        for (const std::size_t k : non_finite) {
            std::fprintf(stderr,
                         "gonio eval: %s:%zu: non-finite BRDF value (NaN row written)\n",
                         in_name.c_str(),
                         line_[k]);
        }
        text_.clear();
        for (std::size_t k = 0; k < n; ++k) {
            if (std::isnan(value_[0][k])) {
                text_ += kNanRow;  // refused, or not finite
            } else {
                append_values({value_[0][k], value_[1][k], value_[2][k]});
            }
        }
        if (!text_.empty()) {
            emit(text_);
        }
        rows_.clear();
        line_.clear();
        return non_finite.size();
    }

  private:
    /// %.17g, formatted by to_chars (the same digits as printf's, without its locale).
    void append_values(const std::array<double, 3>& f) {
        char buf[3 * 32];
        char* p = buf;
        for (int c = 0; c < 3; ++c) {
            p = std::to_chars(p, buf + sizeof buf, f[c], std::chars_format::general, 17).ptr;
            *p++ = c < 2 ? ',' : '\n';
        }
        text_.append(buf, static_cast<std::size_t>(p - buf));
    }

    gonio::brdf::DirectionRows rows_;
    std::vector<double> value_[3];
    std::vector<std::size_t> line_;
    std::string text_;
};

/// Where the values go: standard output, or a file through AtomicFile (never through a planted
/// link, nothing left behind when the command fails before the end).
class Output {
  public:
    static std::optional<Output> open(const std::string& path) {
        Output out;
        if (path != "-") {
            auto f = gonio::AtomicFile::create(path);
            if (!f) {
                std::fprintf(stderr, "gonio eval: %s\n", f.error().message.c_str());
                return std::nullopt;
            }
            out.file_.emplace(std::move(*f));
        }
        return out;
    }

    void operator()(const std::string& text) {
        if (file_) {
            (void)file_->write(text);  // the first failure is returned by commit()
        } else {
            std::fwrite(text.data(), 1, text.size(), stdout);
        }
    }

    bool commit() {
        if (file_) {
            if (auto c = file_->commit(); !c) {
                std::fprintf(stderr, "gonio eval: %s\n", c.error().message.c_str());
                return false;
            }
        }
        return true;
    }

  private:
    std::optional<gonio::AtomicFile> file_;
};

/// The rows of one input, in order. Nothing is written before the first row that can be
/// evaluated: an input without one is refused whole (exit 2, no output); the refused rows
/// before it are written as NaN rows then.
class EvalRun {
  public:
    EvalRun(const gonio::brdf::Brdf& brdf, std::string in_name, Output& out)
        : brdf_(brdf), in_name_(std::move(in_name)), out_(out) {}

    /// Reads the header line; false (reported) when it lacks a required column.
    bool header(const std::string& t, std::size_t line_no) {
        header_ = split_commas(t);
        std::string error;
        if (!find_columns(header_, index_, error)) {
            std::fprintf(
                stderr, "gonio eval: %s:%zu: %s\n", in_name_.c_str(), line_no, error.c_str());
            return false;
        }
        return true;
    }

    bool has_header() const { return !header_.empty(); }

    /// One data row: evaluated, or refused (reported by line) and written as a NaN row.
    void row(const std::string& t, std::size_t line_no) {
        double a[4];
        const std::string reason = parse_row(split_commas(t), header_.size(), index_, a);
        if (!reason.empty()) {
            std::fprintf(stderr,
                         "gonio eval: %s:%zu: %s (NaN row written)\n",
                         in_name_.c_str(),
                         line_no,
                         reason.c_str());
            ++refused_;
            if (started_) {
                block_.add_refused(line_no);
            } else {
                ++leading_refused_;
            }
        } else {
            start();
            block_.add(a, line_no);
            ++evaluated_;
        }
        if (block_.full()) {
            non_finite_ += block_.flush(brdf_, out_, in_name_);
        }
    }

    /// The end of the input: the exit status (2 when no row could be evaluated).
    int finish() {
        if (header_.empty()) {
            std::fprintf(stderr,
                         "gonio eval: %s: no header line (required: theta_i,phi_i,theta_o,phi_o); "
                         "nothing written\n",
                         in_name_.c_str());
            return 2;
        }
        if (!started_ && refused_ > 0) {
            std::fprintf(stderr,
                         "gonio eval: %s: none of its %zu row(s) can be evaluated; nothing "
                         "written\n",
                         in_name_.c_str(),
                         refused_);
            return 2;
        }
        start();
        non_finite_ += block_.flush(brdf_, out_, in_name_);
        if (!out_.commit()) {
            return 1;
        }
        if (refused_ + non_finite_ > 0) {
            std::fprintf(stderr,
                         "gonio eval: warning: %zu of %zu row(s) written as NaN (reasons above), "
                         "%zu evaluated\n",
                         refused_ + non_finite_,
                         refused_ + evaluated_,
                         evaluated_ - non_finite_);
        }
        return 0;
    }

  private:
    /// Writes the header and the NaN rows of the refused rows before the first evaluated one.
    void start() {
        if (started_) {
            return;
        }
        started_ = true;
        std::string text = "r,g,b\n";
        for (std::size_t k = 0; k < leading_refused_; ++k) {
            text += kNanRow;
        }
        out_(text);
    }

    const gonio::brdf::Brdf& brdf_;
    std::string in_name_;
    Output& out_;
    std::vector<std::string> header_;
    int index_[4] = {-1, -1, -1, -1};
    bool started_ = false;
    std::size_t leading_refused_ = 0;
    std::size_t refused_ = 0;
    std::size_t evaluated_ = 0;
    std::size_t non_finite_ = 0;
    Block block_;
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
    std::optional<Output> out = Output::open(opts.output);
    if (!out) {
        return 1;
    }
    EvalRun run(**brdf, in_name, *out);
    std::string line;
    std::size_t line_no = 0;
    while (std::getline(*in, line)) {
        ++line_no;
        const std::string t = trim(line);
        if (t.empty() || t[0] == '#') {
            continue;  // blank lines and comments carry no row
        }
        if (!run.has_header()) {
            if (!run.header(t, line_no)) {
                return 2;
            }
            continue;
        }
        run.row(t, line_no);
    }
    return run.finish();
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
        "with '#' are skipped. Output: the header r,g,b, then one line per input row, in order,\n"
        "with the BRDF in 1/sr printed with %.17g. A row that does not parse (or has theta\n"
        "outside [0, pi], as in degrees) gives the line nan,nan,nan in its place, so that output\n"
        "row k answers input row k; it is named on standard error with its line number (a\n"
        "warning: exit status 0). An input without a usable row (no header naming the four\n"
        "columns, or no row that can be evaluated) is refused whole before anything is written:\n"
        "exit status 2.\n" +
        std::string(gonio::tools::kExitRule));
    return [opts]() -> int { return run_eval(*opts); };
}
