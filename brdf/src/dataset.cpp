#include "gonio/brdf/dataset.h"

#include <cmath>
#include <cstdio>
#include <fstream>

#include "gonio/base/atomic_file.h"
#include "sample_columns.h"

namespace gonio::brdf {

using namespace detail;  // the dataset columns of sample_columns.h
namespace {

std::string fmt_g(double v) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.17g", v);
    return buf;
}

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
    // An angle above its range in radians but within it in degrees is most likely in degrees.
    const auto polar = [half_pi](const char* name, double v) -> std::string {
        if (v < 0) {
            return std::string(name) + " = " + fmt_g(v) + " outside [0, pi/2)";
        }
        return std::string(name) + " = " + fmt_g(v) + " at or below the horizon (>= pi/2)" +
               (v <= 90 ? "; it looks like degrees: angles are radians, 90 deg = 1.5708" : "");
    };
    const auto azimuth = [](const char* name, double v) -> std::string {
        return std::string(name) + " = " + fmt_g(v) + " outside [-2 pi, 2 pi]" +
               (std::abs(v) <= 360 ? "; it looks like degrees: angles are radians, 180 deg = 3.1416"
                                   : "");
    };
    if (s.theta_i < 0 || s.theta_i >= half_pi) {
        return polar("theta_i", s.theta_i);
    }
    if (s.theta_o < 0 || s.theta_o >= half_pi) {
        return polar("theta_o", s.theta_o);
    }
    if (std::abs(s.phi_i) > 2 * kPi) {
        return azimuth("phi_i", s.phi_i);
    }
    if (std::abs(s.phi_o) > 2 * kPi) {
        return azimuth("phi_o", s.phi_o);
    }
    if (s.has_path) {
        for (int k = 0; k < 8; ++k) {
            const double v = k < 4 ? s.path_start[k] : s.path_end[k - 4];
            const char* name = kColNames[kTi0 + k];
            if (!std::isfinite(v)) {
                return std::string(name) + " is not finite";
            }
            if (k % 2 == 0 && (v < 0 || v >= half_pi)) {
                return polar(name, v);
            }
            if (k % 2 == 1 && std::abs(v) > 2 * kPi) {
                return azimuth(name, v);
            }
        }
    }
    return {};
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
    if (layout.has_path) {
        for (int c = kTi0; c <= kPo1; ++c) {
            h += ',';
            h += kColNames[c];
        }
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
    if (layout.has_path) {
        // A standing exposure's path starts and ends at its own directions.
        const std::array<double, 4> own{s.theta_i, s.phi_i, s.theta_o, s.phi_o};
        for (const std::array<double, 4>* a : {&s.path_start, &s.path_end}) {
            for (int k = 0; k < 4; ++k) {
                row += "," + fmt_g(s.has_path ? (*a)[k] : own[k]);
            }
        }
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
