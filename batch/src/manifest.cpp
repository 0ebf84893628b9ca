// Manifests, shards and the run of one entry.

#include "gonio/batch/manifest.h"

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include "gonio/base/atomic_file.h"
#include "gonio/base/strings.h"
#include "gonio/batch/fit_policy.h"
#include "gonio/brdf/samples_io.h"
#include "gonio/fitting/fit.h"
#include "gonio/fitting/report.h"

namespace gonio::batch {

namespace fs = std::filesystem;

namespace {

std::vector<std::string> split_commas(const std::string& line) {
    std::vector<std::string> out;
    std::string field;
    for (char c : line) {
        if (c == ',') {
            out.push_back(trim(field));
            field.clear();
        } else {
            field += c;
        }
    }
    out.push_back(trim(field));
    return out;
}

bool valid_id(const std::string& id) {
    if (id.empty() || id == "." || id == "..") {
        return false;
    }
    for (char c : id) {
        const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') ||
                        (c >= '0' && c <= '9') || c == '.' || c == '_' || c == '-';
        if (!ok) {
            return false;
        }
    }
    return true;
}

std::string resolve(const fs::path& base, const std::string& p) {
    const fs::path path(p);
    if (path.is_absolute()) {
        return p;
    }
    return (base / path).lexically_normal().string();
}

Expected<void> write_text(const std::string& path, const std::string& text) {
    return write_file_atomic(path, text);
}

void fill_metrics(EntryOutcome& o, const fitting::FitResult& r) {
    o.log_rmse = r.metrics.log_rmse.mean();
    o.rel_rmse = r.metrics.rel_rmse.mean();
    o.iterations = r.solver.iterations;
    o.wall_time_s = r.solver.wall_time_s;
    o.samples_used = r.samples.used;
}

}  // namespace

Expected<std::vector<ManifestEntry>> read_manifest(const std::string& path) {
    std::ifstream in(path);
    if (!in) {
        return make_error(path + ": cannot open the manifest");
    }
    const fs::path base = fs::path(path).parent_path();
    std::vector<ManifestEntry> entries;
    std::map<std::string, std::size_t> id_lines;
    std::vector<std::string> header;
    int col_input = -1, col_model = -1, col_options = -1, col_id = -1;
    std::string line;
    std::size_t line_no = 0;
    while (std::getline(in, line)) {
        ++line_no;
        const std::string t = trim(line);
        if (t.empty() || t[0] == '#') {
            continue;
        }
        const std::vector<std::string> fields = split_commas(t);
        const std::string at = path + ":" + std::to_string(line_no);
        if (header.empty()) {
            header = fields;
            for (std::size_t c = 0; c < header.size(); ++c) {
                int* slot = nullptr;
                if (header[c] == "input") {
                    slot = &col_input;
                } else if (header[c] == "model") {
                    slot = &col_model;
                } else if (header[c] == "options") {
                    slot = &col_options;
                } else if (header[c] == "id") {
                    slot = &col_id;
                } else {
                    return make_error(at + ": unknown column \"" + header[c] +
                                      "\" (columns: input,model,options[,id])");
                }
                if (*slot >= 0) {
                    return make_error(at + ": column \"" + header[c] + "\" appears twice");
                }
                *slot = static_cast<int>(c);
            }
            if (col_input < 0) {
                return make_error(at +
                                  ": header lacks the column \"input\" "
                                  "(columns: input,model,options[,id])");
            }
            continue;
        }
        if (fields.size() != header.size()) {
            return make_error(at + ": " + std::to_string(fields.size()) + " fields, header has " +
                              std::to_string(header.size()) + " (fields hold no commas)");
        }
        ManifestEntry e;
        e.index = entries.size();
        e.line = line_no;
        if (fields[col_input].empty()) {
            return make_error(at + ": input is empty");
        }
        e.input = resolve(base, fields[col_input]);
        if (col_options >= 0) {
            auto s = set_options(e.request, fields[col_options]);
            if (!s) {
                return make_error(at + ": " + s.error().message);
            }
        }
        if (col_model >= 0 && !fields[col_model].empty()) {
            const std::string& m = fields[col_model];
            e.request.model = ends_with(m, ".json") ? resolve(base, m) : m;
        }
        if (!ends_with(e.request.model, ".json") && e.request.model != kAutoModel) {
            auto d = fitting::parse_distribution(e.request.model);
            if (!d) {
                return make_error(at + ": model: " + d.error().message +
                                  ", auto or a *.json fit "
                                  "template");
            }
        }
        if (auto c = find_conflict(e.request)) {
            return make_error(at + ": option " + c->option + " cannot be combined with model " +
                              e.request.model + ": " + c->rule);
        }
        e.id = col_id >= 0 && !fields[col_id].empty() ? fields[col_id]
                                                      : fs::path(e.input).stem().string();
        if (!valid_id(e.id)) {
            return make_error(at + ": id \"" + e.id +
                              "\": use only letters, digits, '.', '_', '-'");
        }
        const auto [it, inserted] = id_lines.emplace(e.id, line_no);
        if (!inserted) {
            return make_error(at + ": id \"" + e.id + "\" already used on line " +
                              std::to_string(it->second) + " (ids name the result files)");
        }
        entries.push_back(std::move(e));
    }
    if (header.empty()) {
        return make_error(path + ": no header line (columns: input,model,options[,id])");
    }
    return entries;
}

Expected<Shard> parse_shard(const std::string& text) {
    const auto slash = text.find('/');
    const std::string rule = "shard \"" + text + "\": expected K/N with integers 0 <= K < N";
    if (slash == std::string::npos) {
        return make_error(rule);
    }
    const std::string ks = text.substr(0, slash);
    const std::string ns = text.substr(slash + 1);
    auto parse = [](const std::string& s, unsigned long long& v) {
        if (s.empty() || s.find_first_not_of("0123456789") != std::string::npos) {
            return false;
        }
        errno = 0;
        v = std::strtoull(s.c_str(), nullptr, 10);
        return errno != ERANGE;
    };
    unsigned long long k = 0;
    unsigned long long n = 0;
    if (!parse(ks, k) || !parse(ns, n) || n == 0 || k >= n) {
        return make_error(rule);
    }
    return Shard{static_cast<std::size_t>(k), static_cast<std::size_t>(n)};
}

std::vector<ManifestEntry> select_shard(const std::vector<ManifestEntry>& entries,
                                        const Shard& shard) {
    std::vector<ManifestEntry> out;
    for (const ManifestEntry& e : entries) {
        if (e.index % shard.n == shard.k) {
            out.push_back(e);
        }
    }
    return out;
}

std::string model_path(const std::string& out_dir, const std::string& id) {
    return (fs::path(out_dir) / (id + ".json")).string();
}

std::string report_path(const std::string& out_dir, const std::string& id) {
    return fitting::report_path_for(model_path(out_dir, id));
}

std::string error_path(const std::string& out_dir, const std::string& id) {
    return (fs::path(out_dir) / (id + ".error.txt")).string();
}

bool entry_finished(const std::string& out_dir, const std::string& id) {
    std::error_code ec;
    return fs::is_regular_file(model_path(out_dir, id), ec) &&
           fs::is_regular_file(report_path(out_dir, id), ec);
}

const char* to_string(EntryStatus s) {
    switch (s) {
        case EntryStatus::kFitted:
            return "fitted";
        case EntryStatus::kMisfit:
            return "misfit";
        case EntryStatus::kNotConverged:
            return "not-converged";
        case EntryStatus::kFailed:
            return "failed";
        case EntryStatus::kSkipped:
            return "skipped";
    }
    return "failed";
}

EntryOutcome run_entry(const ManifestEntry& entry, const std::string& out_dir) {
    EntryOutcome o;
    o.id = entry.id;
    o.input = entry.input;
    std::error_code ec;
    if (entry_finished(out_dir, entry.id)) {
        o.status = EntryStatus::kSkipped;
        auto previous = fitting::read_fit_report(report_path(out_dir, entry.id));
        if (previous) {
            fill_metrics(o, *previous);
            o.message = "already fitted";
        } else {
            o.message = "already fitted; report unreadable: " + previous.error().message;
        }
        return o;
    }
    fs::create_directories(out_dir, ec);
    auto fail = [&](const std::string& message) {
        o.status = EntryStatus::kFailed;
        o.message = message;
        auto w = write_text(error_path(out_dir, entry.id), message + "\n");
        if (!w) {
            o.message += "; " + w.error().message;
        }
        return o;
    };
    if (auto spec = make_fit_spec(entry.request); !spec) {
        return fail(spec.error().message);
    }
    auto data = brdf::load_samples(entry.input);
    if (!data) {
        return fail(data.error().message);
    }
    auto run = run_fit(*data, entry.request);
    if (!run) {
        return fail(run.error().message);
    }
    fitting::FitResult* result = &run->result;
    fill_metrics(o, *result);
    auto w = fitting::write_fit_report(model_path(out_dir, entry.id), *result);
    if (!result->solver.converged) {
        o.status = EntryStatus::kNotConverged;
        o.message = result->solver.termination + ": " + result->solver.message;
        return o;
    }
    if (!w) {
        return fail(w.error().message);
    }
    fs::remove(error_path(out_dir, entry.id), ec);
    if (!result->usable()) {
        o.status = EntryStatus::kMisfit;
        o.message = misfit_message(*result);
        return o;
    }
    o.status = EntryStatus::kFitted;
    o.message = result->solver.termination;
    return o;
}

std::string summary_csv_header() {
    return "id,input,status,log_rmse,rel_rmse,iterations,wall_time_s,samples_used,message";
}

std::string summary_csv_row(const EntryOutcome& o) {
    std::string message = o.message;
    for (char& c : message) {
        if (c == ',') {
            c = ';';
        } else if (c == '\n' || c == '\r') {
            c = ' ';
        }
    }
    std::string input = o.input;
    for (char& c : input) {
        if (c == ',') {
            c = ';';
        }
    }
    char numbers[160];
    std::snprintf(numbers,
                  sizeof numbers,
                  "%.9g,%.9g,%d,%.6f,%zu",
                  o.log_rmse,
                  o.rel_rmse,
                  o.iterations,
                  o.wall_time_s,
                  o.samples_used);
    return o.id + "," + input + "," + to_string(o.status) + "," + numbers + "," + message;
}

Expected<void> write_summary_csv(const std::string& path, const std::vector<EntryOutcome>& rows) {
    std::string text = summary_csv_header() + "\n";
    for (const EntryOutcome& o : rows) {
        text += summary_csv_row(o) + "\n";
    }
    return write_text(path, text);
}

}  // namespace gonio::batch
