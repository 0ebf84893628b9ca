#include "gonio/brdf/dataset.h"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "gonio/brdf/atomic_file.h"

namespace gonio::brdf {
namespace {

std::vector<std::string> split_csv(const std::string& line) {
    std::vector<std::string> out;
    std::string cur;
    for (char c : line) {
        if (c == ',') {
            out.push_back(cur);
            cur.clear();
        } else if (c != '\r') {
            cur.push_back(c);
        }
    }
    out.push_back(cur);
    for (std::string& s : out) {
        const auto b = s.find_first_not_of(" \t");
        const auto e = s.find_last_not_of(" \t");
        s = (b == std::string::npos) ? std::string() : s.substr(b, e - b + 1);
    }
    return out;
}

bool parse_double(const std::string& s, double* out) {
    if (s.empty()) {
        return false;
    }
    errno = 0;
    char* end = nullptr;
    const double v = std::strtod(s.c_str(), &end);
    if (end != s.c_str() + s.size() || errno == ERANGE) {
        return false;
    }
    *out = v;
    return true;
}

std::string fmt_g(double v) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.17g", v);
    return buf;
}

enum Col { kTi, kPhiI, kTo, kPo, kR, kG, kB, kSr, kSg, kSb, kW, kF, kNumCols };
const char* const kColNames[kNumCols] = {"theta_i",
                                         "phi_i",
                                         "theta_o",
                                         "phi_o",
                                         "r",
                                         "g",
                                         "b",
                                         "sigma_r",
                                         "sigma_g",
                                         "sigma_b",
                                         "weight",
                                         "flag"};

}  // namespace

std::string validate_sample(const Sample& s) {
    const double angles[4] = {s.theta_i, s.phi_i, s.theta_o, s.phi_o};
    for (int k = 0; k < 4; ++k) {
        if (!std::isfinite(angles[k])) {
            return std::string(kColNames[k]) + " is not finite";
        }
    }
    for (int c = 0; c < 3; ++c) {
        if (!std::isfinite(s.value[c])) {
            return std::string(kColNames[kR + c]) + " is not finite";
        }
        if (s.value[c] < 0) {
            return std::string(kColNames[kR + c]) + " = " + fmt_g(s.value[c]) + " is negative";
        }
        if (!std::isfinite(s.sigma[c]) || s.sigma[c] < 0) {
            return std::string(kColNames[kSr + c]) + " = " + fmt_g(s.sigma[c]) +
                   " is not a finite value >= 0";
        }
    }
    if (!std::isfinite(s.weight) || s.weight < 0) {
        return "weight = " + fmt_g(s.weight) + " is not a finite value >= 0";
    }
    const double half_pi = kPi / 2;
    if (s.theta_i < 0 || s.theta_i >= half_pi) {
        return "theta_i = " + fmt_g(s.theta_i) +
               (s.theta_i >= half_pi ? " at or below the horizon (>= pi/2)" : " outside [0, pi/2)");
    }
    if (s.theta_o < 0 || s.theta_o >= half_pi) {
        return "theta_o = " + fmt_g(s.theta_o) +
               (s.theta_o >= half_pi ? " at or below the horizon (>= pi/2)" : " outside [0, pi/2)");
    }
    if (std::abs(s.phi_i) > 2 * kPi) {
        return "phi_i = " + fmt_g(s.phi_i) + " outside [-2 pi, 2 pi]";
    }
    if (std::abs(s.phi_o) > 2 * kPi) {
        return "phi_o = " + fmt_g(s.phi_o) + " outside [-2 pi, 2 pi]";
    }
    return {};
}

Expected<Dataset> read_dataset_csv(const std::string& path) {
    std::ifstream in(path);
    if (!in) {
        return make_error(path + ": cannot open for reading");
    }
    Dataset data;
    data.source = path;
    std::string line;
    std::size_t line_no = 0;
    int index[kNumCols];
    for (int& i : index) {
        i = -1;
    }
    std::size_t num_fields = 0;
    bool have_header = false;
    while (std::getline(in, line)) {
        ++line_no;
        if (line.empty() || line == "\r" || line[0] == '#') {
            continue;
        }
        const std::vector<std::string> fields = split_csv(line);
        if (!have_header) {
            for (std::size_t f = 0; f < fields.size(); ++f) {
                int found = -1;
                for (int c = 0; c < kNumCols; ++c) {
                    if (fields[f] == kColNames[c]) {
                        found = c;
                    }
                }
                if (found < 0) {
                    return make_error(
                        path + ":" + std::to_string(line_no) + ": unknown column \"" + fields[f] +
                        "\" (expected theta_i,phi_i,theta_o,phi_o,r,g,b and optionally "
                        "sigma_r,sigma_g,sigma_b,weight,flag)");
                }
                if (index[found] >= 0) {
                    return make_error(path + ":" + std::to_string(line_no) + ": column \"" +
                                      fields[f] + "\" appears twice");
                }
                index[found] = static_cast<int>(f);
            }
            for (int c = kTi; c <= kB; ++c) {
                if (index[c] < 0) {
                    return make_error(path + ":" + std::to_string(line_no) +
                                      ": header lacks the required column \"" + kColNames[c] +
                                      "\"");
                }
            }
            const int sig = (index[kSr] >= 0) + (index[kSg] >= 0) + (index[kSb] >= 0);
            if (sig != 0 && sig != 3) {
                return make_error(path + ":" + std::to_string(line_no) +
                                  ": sigma_r, sigma_g and sigma_b must come together");
            }
            data.has_sigma = sig == 3;
            data.has_weight = index[kW] >= 0;
            data.has_flags = index[kF] >= 0;
            num_fields = fields.size();
            have_header = true;
            continue;
        }
        if (fields.size() != num_fields) {
            data.rejected.push_back({line_no,
                                     "has " + std::to_string(fields.size()) +
                                         " fields, header has " + std::to_string(num_fields)});
            continue;
        }
        double v[kNumCols] = {0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0};
        std::string bad;
        for (int c = 0; c < kNumCols && bad.empty(); ++c) {
            if (index[c] >= 0 && !parse_double(fields[index[c]], &v[c])) {
                bad = std::string(kColNames[c]) + " = \"" + fields[index[c]] + "\" is not a number";
            }
        }
        Sample s;
        s.theta_i = v[kTi];
        s.phi_i = v[kPhiI];
        s.theta_o = v[kTo];
        s.phi_o = v[kPo];
        s.value = Rgbd(v[kR], v[kG], v[kB]);
        s.sigma = Rgbd(v[kSr], v[kSg], v[kSb]);
        s.weight = v[kW];
        if (bad.empty() && (v[kF] < 0 || v[kF] > 4294967295.0 || v[kF] != std::floor(v[kF]))) {
            bad = "flag = " + fields[index[kF]] + " is not an unsigned 32-bit integer";
        }
        s.flags = static_cast<std::uint32_t>(v[kF]);
        s.line = line_no;
        if (bad.empty()) {
            bad = validate_sample(s);
        }
        if (!bad.empty()) {
            data.rejected.push_back({line_no, bad});
            continue;
        }
        data.samples.push_back(s);
    }
    if (!have_header) {
        return make_error(path +
                          ": empty file, expected a header theta_i,phi_i,theta_o,phi_o,r,g,b");
    }
    return data;
}

std::string dataset_csv_header(const Dataset& layout) {
    std::string h = "theta_i,phi_i,theta_o,phi_o,r,g,b";
    if (layout.has_sigma) {
        h += ",sigma_r,sigma_g,sigma_b";
    }
    if (layout.has_weight) {
        h += ",weight";
    }
    if (layout.has_flags) {
        h += ",flag";
    }
    return h;
}

std::string format_sample_row(const Sample& s, const Dataset& layout) {
    std::string row = fmt_g(s.theta_i) + "," + fmt_g(s.phi_i) + "," + fmt_g(s.theta_o) + "," +
                      fmt_g(s.phi_o) + "," + fmt_g(s.value[0]) + "," + fmt_g(s.value[1]) + "," +
                      fmt_g(s.value[2]);
    if (layout.has_sigma) {
        row += "," + fmt_g(s.sigma[0]) + "," + fmt_g(s.sigma[1]) + "," + fmt_g(s.sigma[2]);
    }
    if (layout.has_weight) {
        row += "," + fmt_g(s.weight);
    }
    if (layout.has_flags) {
        row += "," + std::to_string(s.flags);
    }
    return row;
}

Expected<void> write_dataset_csv(const std::string& path, const Dataset& data) {
    Expected<AtomicFile> out = AtomicFile::create(path);
    if (!out) {
        return tl::unexpected(out.error());
    }
    std::string chunk = dataset_csv_header(data) + '\n';
    for (const Sample& s : data.samples) {
        chunk += format_sample_row(s, data);
        chunk += '\n';
        if (chunk.size() >= (1u << 20)) {
            if (auto w = out->write(chunk); !w) {
                return w;
            }
            chunk.clear();
        }
    }
    if (auto w = out->write(chunk); !w) {
        return w;
    }
    return out->commit();
}

}  // namespace gonio::brdf
