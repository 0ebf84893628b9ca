#include "gonio/acquisition/shared/rig_config.h"

#include <cmath>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <vector>

#include "gonio/base/limits.h"
#include "gonio/base/strict_json.h"
#include "gonio/base/strings.h"
#include "gonio/devices/camera_factory.h"
#include "gonio/devices/modbus_axis.h"
#include "gonio/devices/modbus_light.h"

namespace gonio::acquisition {

using brdf::kPi;
using nlohmann::json;

namespace {

constexpr double kDeg = kPi / 180.0;

// Modbus unit (slave) ids 0..247 and coil addresses 0..65535, checked before the cast.
int modbus_int(const json& j, const char* key, int lo, int hi) {
    const json& v = j.at(key);
    if (!v.is_number() || !std::isfinite(v.get<double>()) ||
        v.get<double>() != std::floor(v.get<double>()) || v.get<double>() < lo ||
        v.get<double>() > hi) {
        json_fail(std::string(key) + " = " +
                  (v.is_number() ? show_number(v.get<double>()) : v.dump().substr(0, 64)) +
                  ": must be a whole number in [" + std::to_string(lo) + ", " + std::to_string(hi) +
                  "]");
    }
    return static_cast<int>(v.get<double>());
}

CoilConfig parse_coil(const json& j) {
    CoilConfig c;
    c.address = j.at("address").get<std::string>();
    c.unit = modbus_int(j, "unit", 0, 247);
    c.coil = modbus_int(j, "coil", 0, 65535);
    return c;
}

// Every number of the rig's own sections is finite and of a sane magnitude before any cast, and
// every string of a bounded length.
void check_rig_values(const json& j) {
    std::vector<std::pair<const json*, std::string>> pending;
    for (auto it = j.begin(); it != j.end(); ++it) {
        // The error budget has its own strict reader (brdf/rig_error_budget.h).
        if (it.key() != "sim" && it.key() != "camera_model" && it.key() != "error_budget") {
            pending.emplace_back(&*it, it.key());
        }
    }
    while (!pending.empty()) {
        auto [v, path] = pending.back();
        pending.pop_back();
        if (v->is_number()) {
            const double x = v->get<double>();
            if (!std::isfinite(x) || std::abs(x) > 1e9) {
                json_fail(path + " = " + show_number(x) +
                          ": out of range (numbers of a rig description lie in [-1e9, "
                          "1e9])");
            }
        } else if (v->is_object()) {
            for (auto it = v->begin(); it != v->end(); ++it) {
                pending.emplace_back(&*it, path + "." + it.key());
            }
        } else if (v->is_array()) {
            for (std::size_t i = 0; i < v->size(); ++i) {
                pending.emplace_back(&(*v)[i], path + "[" + std::to_string(i) + "]");
            }
        } else if (v->is_string() && v->get_ref<const std::string&>().size() > kMaxJsonString) {
            json_fail(path + ": string longer than " + std::to_string(kMaxJsonString) +
                      " characters");
        }
    }
}

// Keys of a rig description (docs/file-formats.md); "camera_model" is checked by its own reader.
void check_rig_keys(const json& j) {
    static const std::set<std::string> kTop = {"name",
                                               "description",
                                               "axes",
                                               "camera",
                                               "shutter",
                                               "reference_changer",
                                               "filter_wheel",
                                               "geometry",
                                               "white_reference",
                                               "noise",
                                               "capture",
                                               "move_timeout_ms",
                                               "retries",
                                               "sim",
                                               "camera_model",
                                               "image_sample",
                                               "placements",
                                               "embedded_virtual_rig",
                                               "error_budget"};
    static const std::map<std::string, std::set<std::string>> kSections = {
        {"camera", {"address", "readout_ms"}},
        {"sim",
         {"material",
          "brdf",
          "time_scale",
          "seed",
          "start_homed",
          "initial_deg",
          "irradiance_w_m2",
          "sensor"}},
        {"shutter", {"address", "unit", "coil"}},
        {"reference_changer", {"address", "unit", "coil"}},
        {"filter_wheel", {"address", "filters"}},
        {"geometry", {"blind_angle_deg", "max_theta_deg"}},
        {"white_reference", {"reflectance", "theta_i_deg", "theta_o_deg"}},
        {"noise", {"e_per_count", "read_noise_counts"}},
        {"image_sample", {"sphere_radius_m"}},
        {"capture",
         {"target_fraction",
          "linear_max_fraction",
          "min_exposure_us",
          "max_exposure_us",
          "max_brackets",
          "bracket_ratio",
          "hdr_low_fraction",
          "dark_frames",
          "roi_fraction",
          "gain",
          "timeout_ms"}}};
    static const std::set<std::string> kAxis = {"role",
                                                "name",
                                                "address",
                                                "unit",
                                                "profile",
                                                "limits_deg",
                                                "speed_deg_per_s",
                                                "accel_deg_per_s2",
                                                "settle_ms",
                                                "position_compare"};
    auto check = [](const json& obj, const std::string& path, const std::set<std::string>& keys) {
        check_json_keys(obj, path, std::vector<std::string>(keys.begin(), keys.end()));
    };
    check(j, "", kTop);
    for (const auto& [name, keys] : kSections) {
        if (j.contains(name)) {
            check(j.at(name), name, keys);
        }
    }
    if (j.contains("sim") && j.at("sim").is_object()) {
        const json& sim = j.at("sim");
        if (sim.contains("sensor")) {
            check(sim.at("sensor"), "sim.sensor", {"width", "height"});
        }
        if (sim.contains("initial_deg")) {
            check(sim.at("initial_deg"), "sim.initial_deg", {"light", "detector", "tilt", "spin"});
        }
    }
    if (j.contains("axes") && j.at("axes").is_array()) {
        if (j.at("axes").size() > 16) {
            json_fail("axes: " + std::to_string(j.at("axes").size()) + " axes, at most 16 allowed");
        }
        for (std::size_t k = 0; k < j.at("axes").size(); ++k) {
            check(j.at("axes")[k], "axes[" + std::to_string(k) + "]", kAxis);
        }
    }
    check_rig_values(j);
}

json coil_json(const CoilConfig& c) {
    return json{{"address", c.address}, {"unit", c.unit}, {"coil", c.coil}};
}

/// One axis description (axes[k]); `seen` marks the roles already given.
Expected<void> parse_axis(
    const json& a, const std::string& source, const std::string& at, bool* seen, RigConfig* rig) {
    const std::string role = a.at("role").get<std::string>();
    int r = -1;
    for (int q = 0; q < kNumAxes; ++q) {
        if (role == to_string(static_cast<AxisRole>(q))) {
            r = q;
        }
    }
    if (r < 0) {
        return make_error(source + ": " + at + ".role: \"" + excerpt(role) +
                          "\" is not one of light, detector, tilt, spin");
    }
    if (seen[r]) {
        return make_error(source + ": " + at + ".role: \"" + excerpt(role) + "\" given twice");
    }
    seen[r] = true;
    AxisConfig& ax = rig->axes[r];
    ax.name = a.value("name", role);
    ax.address = a.at("address").get<std::string>();
    ax.unit = modbus_int(a, "unit", 0, 247);
    ax.profile = a.value("profile", std::string("generic"));
    const json& lim = a.at("limits_deg");
    ax.limits.min_deg = lim.at(0).get<double>();
    ax.limits.max_deg = lim.at(1).get<double>();
    if (!(ax.limits.min_deg < ax.limits.max_deg)) {
        return make_error(source + ": " + at + ".limits_deg: min must be < max");
    }
    ax.motion.speed_deg_per_s = a.value("speed_deg_per_s", 20.0);
    ax.motion.accel_deg_per_s2 = a.value("accel_deg_per_s2", 40.0);
    ax.motion.settle_ms = a.value("settle_ms", 50.0);
    if (!(ax.motion.speed_deg_per_s > 0) || !(ax.motion.accel_deg_per_s2 > 0) ||
        !(ax.motion.settle_ms >= 0)) {
        return make_error(source + ": " + at + ": speed and acceleration must be > 0, settle >= 0");
    }
    if (a.contains("position_compare")) {
        if (!a.at("position_compare").is_boolean()) {
            return make_error(source + ": " + at + ".position_compare: expected true or false");
        }
        ax.position_compare = a.at("position_compare").get<bool>();
    }
    return {};
}

/// The four axes, each role once. The parse stages below throw JsonFailure or json::exception on
/// a missing key or a wrong type, with *at naming where they were.
Expected<void> parse_axes(const json& j,
                          const std::string& source,
                          std::string* at,
                          RigConfig* rig) {
    bool seen[kNumAxes] = {false, false, false, false};
    *at = "axes";
    const json& axes = j.at("axes");
    for (std::size_t k = 0; k < axes.size(); ++k) {
        *at = "axes[" + std::to_string(k) + "]";
        if (auto a = parse_axis(axes[k], source, *at, seen, rig); !a) {
            return a;
        }
    }
    for (int q = 0; q < kNumAxes; ++q) {
        if (!seen[q]) {
            return make_error(source + ": axes: no axis with role \"" +
                              to_string(static_cast<AxisRole>(q)) + "\"");
        }
    }
    return {};
}

/// The camera, the shutter, the reference changer and the filter wheel.
Expected<void> parse_devices(const json& j,
                             const std::string& source,
                             std::string* at,
                             RigConfig* rig) {
    *at = "camera";
    rig->camera_address = j.at("camera").at("address").get<std::string>();
    rig->camera_readout_ms = j.at("camera").value("readout_ms", rig->camera_readout_ms);
    if (!(rig->camera_readout_ms >= 0 && rig->camera_readout_ms <= 60000)) {
        return make_error(source + ": camera.readout_ms = " + show_number(rig->camera_readout_ms) +
                          ": must be in [0, 60000] ms");
    }
    *at = "shutter";
    rig->shutter = parse_coil(j.at("shutter"));
    if (j.contains("reference_changer")) {
        *at = "reference_changer";
        rig->reference_changer = parse_coil(j.at("reference_changer"));
    }
    if (!j.contains("filter_wheel")) {
        return {};
    }
    *at = "filter_wheel";
    const json& fw = j.at("filter_wheel");
    const json& filters = fw.at("filters");
    if (!filters.is_array() || filters.size() != 3) {
        return make_error(source + ": filter_wheel.filters: three coils (red, green, blue) needed");
    }
    std::array<CoilConfig, 3> coils;
    for (std::size_t c = 0; c < 3; ++c) {
        *at = "filter_wheel.filters[" + std::to_string(c) + "]";
        // The filter coils share the shutter's bus unless an address is given.
        coils[c].address = fw.value("address", rig->shutter.address);
        coils[c].unit = modbus_int(filters.at(c), "unit", 0, 247);
        coils[c].coil = modbus_int(filters.at(c), "coil", 0, 65535);
    }
    rig->filter_wheel = coils;
    return {};
}

/// The geometry limits, the white reference and the sensor noise.
Expected<void> parse_references(const json& j,
                                const std::string& source,
                                std::string* at,
                                RigConfig* rig) {
    *at = "geometry";
    if (j.contains("geometry")) {
        const json& g = j.at("geometry");
        rig->blind_angle_deg = g.value("blind_angle_deg", rig->blind_angle_deg);
        rig->max_theta_deg = g.value("max_theta_deg", rig->max_theta_deg);
    }
    if (!(rig->blind_angle_deg >= 0 && rig->blind_angle_deg < 90) ||
        !(rig->max_theta_deg > 0 && rig->max_theta_deg < 90)) {
        return make_error(source +
                          ": geometry: blind_angle_deg in [0, 90), max_theta_deg in (0, 90)");
    }
    *at = "white_reference";
    if (j.contains("white_reference")) {
        const json& w = j.at("white_reference");
        rig->white_reflectance = w.value("reflectance", rig->white_reflectance);
        rig->white_theta_i_deg = w.value("theta_i_deg", rig->white_theta_i_deg);
        rig->white_theta_o_deg = w.value("theta_o_deg", rig->white_theta_o_deg);
    }
    if (!(rig->white_reflectance > 0 && rig->white_reflectance <= 1)) {
        return make_error(source + ": white_reference.reflectance must be in (0, 1]");
    }
    *at = "noise";
    if (j.contains("noise")) {
        rig->noise.e_per_count = j.at("noise").value("e_per_count", rig->noise.e_per_count);
        rig->noise.read_noise_counts =
            j.at("noise").value("read_noise_counts", rig->noise.read_noise_counts);
    }
    return {};
}

/// The capture settings.
Expected<void> parse_capture(const json& j,
                             const std::string& source,
                             std::string* at,
                             RigConfig* rig) {
    *at = "capture";
    if (!j.contains("capture")) {
        return {};
    }
    const json& c = j.at("capture");
    CaptureConfig& cc = rig->capture;
    cc.target_fraction = c.value("target_fraction", cc.target_fraction);
    cc.linear_max_fraction = c.value("linear_max_fraction", cc.linear_max_fraction);
    cc.min_exposure_us = c.value("min_exposure_us", cc.min_exposure_us);
    cc.max_exposure_us = c.value("max_exposure_us", cc.max_exposure_us);
    cc.max_brackets = c.value("max_brackets", cc.max_brackets);
    cc.bracket_ratio = c.value("bracket_ratio", cc.bracket_ratio);
    cc.hdr_low_fraction = c.value("hdr_low_fraction", cc.hdr_low_fraction);
    cc.dark_frames = c.value("dark_frames", cc.dark_frames);
    cc.roi_fraction = c.value("roi_fraction", cc.roi_fraction);
    cc.gain = c.value("gain", cc.gain);
    cc.timeout_ms = c.value("timeout_ms", cc.timeout_ms);
    if (!(cc.target_fraction > 0 && cc.target_fraction < cc.linear_max_fraction &&
          cc.linear_max_fraction <= 1) ||
        !(cc.min_exposure_us > 0 && cc.min_exposure_us < cc.max_exposure_us) ||
        cc.max_brackets < 1 || !(cc.bracket_ratio > 1) || cc.dark_frames < 1 ||
        !(cc.roi_fraction > 0 && cc.roi_fraction <= 1) || !(cc.gain > 0)) {
        return make_error(source +
                          ": capture: target_fraction in (0, 1), 0 < "
                          "min_exposure_us < max_exposure_us, max_brackets >= 1, "
                          "bracket_ratio > 1, dark_frames >= 1, roi_fraction in "
                          "(0, 1], gain > 0");
    }
    return {};
}

/// One zoomed placement (placements[k]).
Expected<PlacementConfig> parse_placement(const json& pj,
                                          std::size_t k,
                                          const std::string& source,
                                          const std::string& at,
                                          const RigConfig& rig) {
    check_json_keys(pj, at, {"name", "magnification", "offset_m", "address", "unit", "coil"});
    PlacementConfig pc;
    pc.placement.name = pj.value("name", "zoom-" + std::to_string(k + 1));
    pc.placement.magnification = pj.at("magnification").get<double>();
    if (!(pc.placement.magnification >= 1 && pc.placement.magnification <= 100)) {
        return make_error(source + ": " + at +
                          ".magnification = " + show_number(pc.placement.magnification) +
                          ": must be in [1, 100] (relative to the wide view)");
    }
    const json& off = pj.at("offset_m");
    if (!off.is_array() || off.size() != 2) {
        return make_error(source + ": " + at + ".offset_m: expected [x, y] in metres");
    }
    for (int c = 0; c < 2; ++c) {
        const double v = off.at(static_cast<std::size_t>(c)).get<double>();
        if (!(std::abs(v) < 10)) {
            return make_error(source + ": " + at + ".offset_m[" + std::to_string(c) +
                              "] = " + show_number(v) + ": must be within 10 metres");
        }
        pc.placement.offset_m[static_cast<std::size_t>(c)] = v;
    }
    pc.coil.address = pj.value("address", rig.shutter.address);
    pc.coil.unit = modbus_int(pj, "unit", 0, 247);
    pc.coil.coil = modbus_int(pj, "coil", 0, 65535);
    return pc;
}

/// The image-mode sample sphere and the zoomed placements.
Expected<void> parse_image_views(const json& j,
                                 const std::string& source,
                                 std::string* at,
                                 RigConfig* rig) {
    *at = "image_sample";
    if (j.contains("image_sample")) {
        rig->sphere_radius_m = j.at("image_sample").value("sphere_radius_m", rig->sphere_radius_m);
        if (!(rig->sphere_radius_m > 0 && rig->sphere_radius_m < 10)) {
            return make_error(source + ": image_sample.sphere_radius_m = " +
                              show_number(rig->sphere_radius_m) + ": must be in (0, 10) metres");
        }
    }
    if (!j.contains("placements")) {
        return {};
    }
    *at = "placements";
    const json& ps = j.at("placements");
    if (!ps.is_array() || ps.size() > 16) {
        return make_error(source + ": placements: an array of at most 16 placements");
    }
    for (std::size_t k = 0; k < ps.size(); ++k) {
        *at = "placements[" + std::to_string(k) + "]";
        auto pc = parse_placement(ps.at(k), k, source, *at, *rig);
        if (!pc) {
            return tl::unexpected(pc.error());
        }
        rig->placements.push_back(*pc);
    }
    return {};
}

}  // namespace

Expected<RigConfig> parse_rig_config(const std::string& text, const std::string& source) {
    RigConfig rig;
    rig.source = source;
    rig.json = text;
    std::string at = "";
    try {
        const json j = parse_json_checked(text, source);
        check_rig_keys(j);
        rig.name = j.value("name", source);
        for (const auto stage :
             {parse_axes, parse_devices, parse_references, parse_capture, parse_image_views}) {
            if (auto s = stage(j, source, &at, &rig); !s) {
                return tl::unexpected(s.error());
            }
        }
        rig.move_timeout_ms = j.value("move_timeout_ms", rig.move_timeout_ms);
        rig.retries = j.value("retries", rig.retries);
    } catch (const JsonFailure& f) {
        const bool named = f.message.compare(0, source.size(), source) == 0;
        return make_error(named ? f.message
                                : source + ": " + (at.empty() ? "" : at + ": ") + f.message);
    } catch (const json::exception& e) {
        // A value of the wrong type: say which key, without nlohmann's internal error code.
        return make_error(source + ": " + (at.empty() ? "" : at + ": ") +
                          gonio::json_error_text(e.what()));
    }
    auto budget = brdf::read_error_budget(text, source);
    if (!budget) {
        return tl::unexpected(budget.error());
    }
    rig.error_budget = *budget;
    return rig;
}

Expected<RigConfig> read_rig_config(const std::string& path) {
    Expected<std::string> text = read_input_file(path, kMaxJsonBytes);
    if (!text) {
        return make_error(text.error().message + " (rig description)");
    }
    return parse_rig_config(*text, path);
}

RigConfig with_addresses(const RigConfig& rig,
                         const std::string& motor_address,
                         const std::string& camera_address) {
    RigConfig out = rig;
    json j = json::parse(rig.json);
    for (auto& a : out.axes) {
        a.address = motor_address;
    }
    for (auto& a : j.at("axes")) {
        a["address"] = motor_address;
    }
    out.shutter.address = motor_address;
    j["shutter"] = coil_json(out.shutter);
    if (out.reference_changer) {
        out.reference_changer->address = motor_address;
        j["reference_changer"] = coil_json(*out.reference_changer);
    }
    if (out.filter_wheel) {
        for (CoilConfig& c : *out.filter_wheel) {
            c.address = motor_address;
        }
        j["filter_wheel"]["address"] = motor_address;
    }
    for (std::size_t k = 0; k < out.placements.size(); ++k) {
        out.placements[k].coil.address = motor_address;
        j["placements"][k]["address"] = motor_address;
    }
    if (!camera_address.empty()) {
        out.camera_address = camera_address;
        j["camera"]["address"] = camera_address;
    }
    out.json = j.dump(2);
    return out;
}

RigLimits rig_limits(const RigConfig& rig) {
    RigLimits l;
    for (int k = 0; k < kNumAxes; ++k) {
        l.range[k].min = rig.axes[k].limits.min_deg * kDeg;
        l.range[k].max = rig.axes[k].limits.max_deg * kDeg;
    }
    l.blind_angle = rig.blind_angle_deg * kDeg;
    l.max_theta = rig.max_theta_deg * kDeg;
    return l;
}

std::array<AxisDynamics, kNumAxes> rig_dynamics(const RigConfig& rig) {
    std::array<AxisDynamics, kNumAxes> d;
    for (int k = 0; k < kNumAxes; ++k) {
        d[k].speed = rig.axes[k].motion.speed_deg_per_s * kDeg;
        d[k].accel = rig.axes[k].motion.accel_deg_per_s2 * kDeg;
        d[k].settle_s = rig.axes[k].motion.settle_ms / 1000.0;
    }
    return d;
}

Expected<RigDevices> open_rig(const RigConfig& rig) {
    RigDevices d;
    for (int k = 0; k < kNumAxes; ++k) {
        const AxisConfig& a = rig.axes[k];
        auto ax = devices::open_axis(a.name, a.address, a.unit, a.profile, a.limits, a.motion);
        if (!ax) {
            return make_error("axis \"" + a.name + "\" (" + a.address + " unit " +
                              std::to_string(a.unit) + "): " + ax.error().message);
        }
        d.axes[k] = std::move(*ax);
    }
    auto cam = devices::open_camera(rig.camera_address);
    if (!cam) {
        return make_error("camera " + rig.camera_address + ": " + cam.error().message);
    }
    d.camera = std::move(*cam);
    auto sh = devices::open_modbus_light(rig.shutter.address, rig.shutter.unit, rig.shutter.coil);
    if (!sh) {
        return make_error("shutter: " + sh.error().message);
    }
    d.shutter = std::move(*sh);
    if (rig.reference_changer) {
        const CoilConfig& c = *rig.reference_changer;
        auto rc = devices::open_modbus_light(c.address, c.unit, c.coil);
        if (!rc) {
            return make_error("reference changer: " + rc.error().message);
        }
        d.reference_changer = std::move(*rc);
    }
    if (rig.filter_wheel) {
        std::array<devices::FilterCoil, 3> coils;
        for (int c = 0; c < 3; ++c) {
            coils[c].unit = (*rig.filter_wheel)[c].unit;
            coils[c].coil = (*rig.filter_wheel)[c].coil;
        }
        auto fw = devices::open_modbus_filter_wheel((*rig.filter_wheel)[0].address, coils);
        if (!fw) {
            return make_error(fw.error().message);
        }
        d.filter_wheel = std::move(*fw);
    }
    for (const PlacementConfig& p : rig.placements) {
        auto coil = devices::open_modbus_light(p.coil.address, p.coil.unit, p.coil.coil);
        if (!coil) {
            return make_error("camera placement \"" + p.placement.name +
                              "\": " + coil.error().message);
        }
        d.placements.push_back(std::move(*coil));
    }
    return d;
}

}  // namespace gonio::acquisition
