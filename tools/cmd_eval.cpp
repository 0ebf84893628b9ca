// gonio eval MODEL_OR_TABLE < dirs.csv > values.csv

#include <CLI/CLI.hpp>
#include <cerrno>
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
#include "gonio/base/atomic_file.h"
#include "gonio/brdf/brdf.h"

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
            std::fputs(text.c_str(), stdout);
        }
    };
    std::string line;
    std::size_t line_no = 0;
    std::vector<std::string> header;
    int index[4] = {-1, -1, -1, -1};
    std::size_t bad = 0;
    std::size_t good = 0;
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
        const gonio::brdf::Vec3d wi = gonio::brdf::spherical_to_cartesian(a[0], a[1]);
        const gonio::brdf::Vec3d wo = gonio::brdf::spherical_to_cartesian(a[2], a[3]);
        const gonio::brdf::Rgbd f = (*brdf)->eval(wi, wo);
        if (!std::isfinite(f[0]) || !std::isfinite(f[1]) || !std::isfinite(f[2])) {
            std::fprintf(stderr,
                         "gonio eval: %s:%zu: non-finite BRDF value (row skipped)\n",
                         in_name.c_str(),
                         line_no);
            ++bad;
            continue;
        }
        char row[96];
        std::snprintf(row, sizeof row, "%.17g,%.17g,%.17g\n", f[0], f[1], f[2]);
        emit(row);
        ++good;
    }
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
        "eval", "Evaluate a BRDF (model JSON or table) at directions read as CSV");
    auto opts = std::make_shared<EvalOptions>();
    cmd->add_option(
           "brdf", opts->brdf_path, "Model JSON (docs/model-schema.md) or tabulated BRDF file")
        ->required();
    cmd->add_option("-i,--input", opts->input, "Directions CSV (default '-': standard input)");
    cmd->add_option("-o,--output", opts->output, "Output CSV (default '-': standard output)");
    cmd->footer(
        "Input: a header naming the columns theta_i,phi_i,theta_o,phi_o (radians; any order,\n"
        "other columns ignored), then one row per direction pair; blank lines and lines starting\n"
        "with '#' are skipped. Output: the header r,g,b, then one line per valid row with the\n"
        "BRDF in 1/sr printed with %.17g. A row that does not parse (or has theta outside\n"
        "[0, pi]) produces no output line; it is reported on standard error with its line number.\n"
        "Exit status: 0 all rows evaluated, 1 some rows skipped or an unreadable BRDF or input, 2 "
        "usage error.");
    return [opts]() -> int { return run_eval(*opts); };
}
