#include "plot_common.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "canvas.h"
#include "gonio/report/plot.h"

namespace gonio::report {

const char* axis_scale_name(AxisScale s) {
    switch (s) {
        case AxisScale::kLinear:
            return "linear";
        case AxisScale::kLog:
            return "log";
        case AxisScale::kAuto:
            break;
    }
    return "auto";
}

AxisScale resolve_scale(AxisScale requested, double vmin_pos, double vmax) {
    if (requested != AxisScale::kAuto) {
        return requested;
    }
    if (std::isfinite(vmin_pos) && vmin_pos > 0 && std::isfinite(vmax) && vmax > 10 * vmin_pos) {
        // More than a decade: a linear axis would squeeze the low values into the origin.
        return AxisScale::kLog;
    }
    return AxisScale::kLinear;
}

}  // namespace gonio::report

namespace gonio::report::plot_detail {

std::string scale_caption(bool log, double vmin_pos, double vmax) {
    char buf[160];
    if (log) {
        std::snprintf(buf,
                      sizeof buf,
                      "log10 scale (values span %.2g to %.2g, %.1f decades)",
                      vmin_pos,
                      vmax,
                      std::log10(vmax / vmin_pos));
    } else {
        std::snprintf(buf, sizeof buf, "linear scale from 0");
    }
    return buf;
}

std::vector<double> pick_evenly(const std::vector<std::pair<double, int>>& sorted, std::size_t n) {
    std::vector<double> out;
    if (sorted.empty() || n == 0) {
        return out;
    }
    if (sorted.size() <= n) {
        for (const auto& s : sorted) {
            out.push_back(s.first);
        }
        return out;
    }
    for (std::size_t k = 0; k < n; ++k) {
        const std::size_t i = n == 1 ? 0 : k * (sorted.size() - 1) / (n - 1);
        out.push_back(sorted[i].first);
    }
    return out;
}

std::string short_name(const std::string& source) {
    if (source.empty()) {
        return "data";
    }
    const auto slash = source.find_last_of('/');
    return slash == std::string::npos ? source : source.substr(slash + 1);
}

double log_floor(double vmin_pos, double vmax) {
    const double top = std::ceil(std::log10(vmax) - 1e-9);
    // A third of a decade below the smallest value, so that it stands off the origin.
    double bottom = std::isfinite(vmin_pos) && vmin_pos > 0
                        ? std::floor(std::log10(vmin_pos) - 1.0 / 3.0)
                        : top - 3;
    bottom = std::max(bottom, top - 5);
    if (bottom >= top) {
        // A single decade of data: show one decade below.
        bottom = top - 1;
    }
    return std::pow(10.0, bottom);
}

RadialScale RadialScale::make(double vmin_pos, double vmax, bool log, double radius_px) {
    RadialScale s;
    s.log = log;
    s.radius_px = radius_px;
    if (log) {
        s.min_value = log_floor(vmin_pos, vmax);
        s.max_value = std::pow(10.0, std::ceil(std::log10(vmax) - 1e-9));
        for (double v = s.min_value * 10; v <= s.max_value * 1.0000001; v *= 10) {
            s.ticks.push_back(v);
        }
    } else {
        s.min_value = 0;
        std::vector<double> t = draw::nice_ticks(0, vmax, 5);
        double step = t.size() >= 2 ? t[1] - t[0] : vmax;
        s.max_value = t.empty() ? vmax : t.back();
        if (s.max_value < vmax * (1 - 1e-9)) {
            s.max_value += step;
        }
        for (double v = step; v <= s.max_value * 1.0000001; v += step) {
            s.ticks.push_back(v);
        }
    }
    return s;
}

double RadialScale::radius(double v) const {
    if (!(v > min_value)) {
        // At or below the lowest value shown (and NaN): the origin.
        return 0;
    }
    double t = 0;
    if (log) {
        t = (std::log10(v) - std::log10(min_value)) /
            (std::log10(max_value) - std::log10(min_value));
    } else {
        t = v / max_value;
    }
    return std::clamp(t, 0.0, 1.0) * radius_px;
}

}  // namespace gonio::report::plot_detail
