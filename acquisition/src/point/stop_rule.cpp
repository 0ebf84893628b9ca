#include "gonio/acquisition/point/stop_rule.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>

namespace gonio::acquisition {

namespace {

/// Shortest round-tripping text of a number ("0.01", "2").
std::string format_number(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.17g", v);
    for (int p = 1; p <= 17; ++p) {
        char shorter[32];
        std::snprintf(shorter, sizeof shorter, "%.*g", p, v);
        if (std::strtod(shorter, nullptr) == v) {
            return shorter;
        }
    }
    return buf;
}

Expected<double> positive_number(const std::string& key, const std::string& value, double hi) {
    char* end = nullptr;
    const double v = std::strtod(value.c_str(), &end);
    if (value.empty() || end == nullptr || *end != '\0' || !std::isfinite(v) || !(v > 0) ||
        v > hi) {
        return make_error("until: " + key + "=" + value + ": must be a number in (0, " +
                          format_number(hi) + "]");
    }
    return v;
}

}  // namespace

Expected<StopRule> parse_stop_rule(const std::string& text) {
    StopRule rule;
    std::stringstream ss(text);
    std::string item;
    bool have_sigma = false;
    while (std::getline(ss, item, ',')) {
        const auto eq = item.find('=');
        if (eq == std::string::npos) {
            return make_error("until: \"" + item +
                              "\": expected key=value (sigma=0.01, holdout=2, every=N)");
        }
        const std::string key = item.substr(0, eq);
        const std::string value = item.substr(eq + 1);
        if (key == "sigma") {
            auto v = positive_number(key, value, 1);
            if (!v) {
                return tl::unexpected(v.error());
            }
            rule.sigma = *v;
            have_sigma = true;
        } else if (key == "holdout") {
            auto v = positive_number(key, value, 1e6);
            if (!v) {
                return tl::unexpected(v.error());
            }
            rule.holdout = *v;
        } else if (key == "every") {
            auto v = positive_number(key, value, 1e6);
            if (!v || *v != std::floor(*v)) {
                return make_error("until: every=" + value + ": must be a whole number >= 1");
            }
            rule.every = static_cast<int>(*v);
        } else {
            return make_error("until: unknown target \"" + key +
                              "\" (known: sigma, holdout, every)");
        }
    }
    if (!have_sigma) {
        return make_error("until: \"" + text + "\": sigma=TARGET is required (e.g. sigma=0.01)");
    }
    return rule;
}

std::string format_stop_rule(const StopRule& rule) {
    if (!rule.active()) {
        return "";
    }
    std::string s =
        "sigma=" + format_number(rule.sigma) + ",holdout=" + format_number(rule.holdout);
    if (rule.every > 0) {
        s += ",every=" + std::to_string(rule.every);
    }
    return s;
}

bool rule_holds(const StopRule& rule, const FitCheck& check, std::string* why) {
    char buf[320];
    if (!check.usable) {
        if (why != nullptr) {
            *why = "the fit did not converge";
        }
        return false;
    }
    const bool sigma_ok = check.max_rel_sigma <= rule.sigma;
    const bool holdout_ok = check.held_out > 0 && check.holdout_rms_z <= rule.holdout;
    std::snprintf(
        buf,
        sizeof buf,
        "largest relative sigma %.3g (%s) %s %.3g; held-out RMS error %.3g sigma over %zu "
        "values %s %.3g",
        check.max_rel_sigma,
        check.worst.c_str(),
        sigma_ok ? "<=" : ">",
        rule.sigma,
        check.holdout_rms_z,
        check.held_out,
        holdout_ok ? "<=" : ">",
        rule.holdout);
    if (why != nullptr) {
        *why = buf;
    }
    return sigma_ok && holdout_ok;
}

void split_holdout(const std::vector<brdf::Sample>& samples,
                   std::vector<brdf::Sample>* fit,
                   std::vector<brdf::Sample>* holdout) {
    for (std::size_t k = 0; k < samples.size(); ++k) {
        ((k + 1) % kHoldoutEvery == 0 ? holdout : fit)->push_back(samples[k]);
    }
}

}  // namespace gonio::acquisition
