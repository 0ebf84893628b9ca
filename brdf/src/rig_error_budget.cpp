#include "gonio/brdf/rig_error_budget.h"

#include <cmath>
#include <nlohmann/json.hpp>

#include "gonio/base/limits.h"
#include "gonio/base/strict_json.h"
#include "gonio/brdf/coords.h"

namespace gonio::brdf {

RigErrorBudget reference_error_budget() {
    // Standard uncertainties (k = 1); docs/error-budget.md adds them up for a matte sample.
    RigErrorBudget b;
    b.profile = "reference";
    b.lamp_fluctuation = 0.0015;
    b.lamp_drift_per_hour = 0.001;
    b.light_arm = {0.005, 0.01, 0.01};
    b.detector_arm = {0.005, 0.01, 0.01};
    b.stray_light = 2e-4;
    b.nonlinearity = 0.001;
    return b;
}

RigErrorBudget quiet_error_budget() {
    RigErrorBudget b;
    b.profile = "quiet";
    return b;
}

namespace {

RigErrorBudget named_profile(const std::string& name, const std::string& key) {
    if (name == "reference") {
        return reference_error_budget();
    }
    if (name == "quiet") {
        return quiet_error_budget();
    }
    json_fail(key + " = \"" + name + "\": unknown profile (known: reference, quiet)");
}

void read_arm(JsonObject& top, const char* name, ArmErrors* arm) {
    const nlohmann::json* j = top.find(name);
    if (j == nullptr) {
        return;
    }
    JsonObject o(*j, top.key_path(name));
    o.allow({"repeatability_deg", "zero_offset_deg", "axis_tilt_deg"});
    o.finish();
    arm->repeatability_deg = o.number("repeatability_deg", arm->repeatability_deg, 0, 10, "deg");
    arm->zero_offset_deg = o.number("zero_offset_deg", arm->zero_offset_deg, 0, 10, "deg");
    arm->axis_tilt_deg = o.number("axis_tilt_deg", arm->axis_tilt_deg, 0, 10, "deg");
}

RigErrorBudget read_budget_object(const nlohmann::json& j) {
    JsonObject o(j, "error_budget");
    o.allow({"profile", "lamp", "light_arm", "detector_arm", "stray_light", "nonlinearity"});
    o.finish();
    const std::string name = o.string("profile", "reference", kMaxJsonString);
    RigErrorBudget b = named_profile(name, "error_budget.profile");
    b.profile = "custom";
    if (const nlohmann::json* lamp = o.find("lamp")) {
        JsonObject l(*lamp, "error_budget.lamp");
        l.allow({"fluctuation", "drift_per_hour"});
        l.finish();
        b.lamp_fluctuation = l.number("fluctuation", b.lamp_fluctuation, 0, 0.5);
        b.lamp_drift_per_hour = l.number("drift_per_hour", b.lamp_drift_per_hour, 0, 0.5);
    }
    read_arm(o, "light_arm", &b.light_arm);
    read_arm(o, "detector_arm", &b.detector_arm);
    b.stray_light = o.number("stray_light", b.stray_light, 0, 0.1);
    b.nonlinearity = o.number("nonlinearity", b.nonlinearity, 0, 0.2);
    return b;
}

}  // namespace

Expected<RigErrorBudget> read_error_budget(const std::string& rig_json, const std::string& source) {
    return read_strict_json(source, [&] {
        const nlohmann::json rig = parse_json_checked(rig_json, source);
        require_json_object(rig, "");
        const auto found = rig.find("error_budget");
        if (found == rig.end()) {
            return reference_error_budget();
        }
        if (found->is_string()) {
            return named_profile(found->get<std::string>(), "error_budget");
        }
        if (!found->is_object()) {
            json_fail("error_budget: a profile name (\"reference\", \"quiet\") or an object, not " +
                      json_type(*found));
        }
        return read_budget_object(*found);
    });
}

double arm_direction_sigma_rad(const ArmErrors& arm) {
    const double deg = std::sqrt(arm.repeatability_deg * arm.repeatability_deg +
                                 arm.zero_offset_deg * arm.zero_offset_deg +
                                 arm.axis_tilt_deg * arm.axis_tilt_deg);
    return deg * kPi / 180.0;
}

double relative_sigma(const RigErrorBudget& b, double hours_since_white) {
    const double drift = b.lamp_drift_per_hour * std::max(0.0, hours_since_white);
    // Fluctuation twice: in the value's exposure and in the white reference's it is divided by.
    return std::sqrt(2 * b.lamp_fluctuation * b.lamp_fluctuation + drift * drift +
                     b.nonlinearity * b.nonlinearity);
}

double common_relative_sigma(const RigErrorBudget& b) {
    return std::hypot(b.lamp_fluctuation, b.nonlinearity);
}

double stray_light_brdf(const RigErrorBudget& b, double cos_theta_i) {
    // A radiance offset s E / pi read as a BRDF: f = L / (E cos theta_i).
    return cos_theta_i > 0 ? b.stray_light * kInvPi / cos_theta_i : 0.0;
}

}  // namespace gonio::brdf
