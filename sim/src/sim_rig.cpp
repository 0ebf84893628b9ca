#include "gonio/sim/sim_rig.h"

#include <chrono>
#include <cmath>
#include <cstdint>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "gonio/base/limits.h"
#include "gonio/base/strict_json.h"
#include "gonio/base/strings.h"
#include "gonio/brdf/analytic_brdf.h"
#include "gonio/brdf/brdf.h"
#include "gonio/brdf/material_library.h"
#include "gonio/brdf/rig_error_budget.h"
#include "gonio/devices/axis_profile.h"

namespace gonio::sim {

using nlohmann::json;

namespace {

/// The rig file's "sim" section, read only by the virtual rig; each value its default when absent.
struct SimSection {
    double time_scale = 20.0;
    std::uint64_t seed = 1;
    std::string brdf;
    std::string material = "red-plastic";
    bool start_homed = true;
    std::map<std::string, double> initial_deg;  ///< By axis role; detector 45, others 0 if absent.
    double irradiance_w_m2 = 1.0;
    int sensor_width = 640;
    int sensor_height = 512;
};

/// Reads "sim" with the strict reader (base/strict_json.h): unknown keys refused with the keys
/// allowed there, types and ranges checked, messages naming the key path ("sim.sensor.width").
Expected<SimSection> read_sim_section(const json& rig) {
    return read_strict_json("sim rig", [&] {
        SimSection s;
        require_json_object(rig, "");
        const auto found = rig.find("sim");
        if (found == rig.end()) {
            return s;
        }
        JsonObject sim(*found, "sim");
        sim.allow({"material",
                   "brdf",
                   "time_scale",
                   "seed",
                   "start_homed",
                   "initial_deg",
                   "irradiance_w_m2",
                   "sensor"});
        sim.finish();
        s.material = sim.string("material", s.material, kMaxJsonString);
        s.brdf = sim.string("brdf", s.brdf, kMaxJsonString);
        s.time_scale = sim.number("time_scale", s.time_scale, 0.0, 1e6);
        if (!(s.time_scale > 0)) {
            json_fail("sim.time_scale = 0: must be > 0 (simulated seconds per second)");
        }
        // Whole and at least 1 (0 would be "unset" beside the command line's seed).
        s.seed = static_cast<std::uint64_t>(sim.integer("seed", 1, 1, 2147483647));
        s.start_homed = sim.boolean("start_homed", s.start_homed);
        if (const json* initial = sim.find("initial_deg")) {
            JsonObject roles(*initial, "sim.initial_deg");
            roles.allow({"light", "detector", "tilt", "spin"});
            roles.finish();
            for (const char* role : {"light", "detector", "tilt", "spin"}) {
                if (roles.has(role)) {
                    s.initial_deg[role] = roles.number(role, 0.0, -360.0, 360.0, "deg");
                }
            }
        }
        s.irradiance_w_m2 = sim.number("irradiance_w_m2", s.irradiance_w_m2, 0.0, 1e9, "W/m^2");
        if (const json* sensor = sim.find("sensor")) {
            JsonObject sz(*sensor, "sim.sensor");
            sz.allow({"width", "height"});
            sz.finish();
            s.sensor_width = sz.integer("width", s.sensor_width, 1, 16384);
            s.sensor_height = sz.integer("height", s.sensor_height, 1, 16384);
        }
        return s;
    });
}

/// The rig's simulated seconds since now: wall time times the time scale (the lamp drifts on it).
std::function<double()> simulated_clock(double time_scale) {
    const auto t0 = std::chrono::steady_clock::now();
    return [t0, time_scale] {
        return time_scale *
               std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    };
}

/// The ground truth: a BRDF file or a material, from the options or else from the rig's sim
/// section.
struct GroundTruth {
    std::shared_ptr<const brdf::Brdf> sample;
    std::string name;
};

Expected<GroundTruth> load_ground_truth(const SimRigOptions& opt, const SimSection& sim) {
    GroundTruth t;
    std::string brdf_path = opt.brdf_path;
    std::string material = opt.material;
    if (brdf_path.empty() && material.empty()) {
        brdf_path = sim.brdf;
        material = sim.material;
    }
    if (!brdf_path.empty()) {
        auto b = brdf::load_brdf(brdf_path);
        if (!b) {
            return make_error("sim rig: " + b.error().message);
        }
        t.sample = std::shared_ptr<const brdf::Brdf>(std::move(*b));
        t.name = brdf_path;
    } else {
        auto m = brdf::load_material(material);
        if (!m) {
            return make_error("sim rig: " + m.error().message);
        }
        t.sample = std::shared_ptr<const brdf::Brdf>(brdf::make_analytic_brdf(*m));
        t.name = material;
    }
    return t;
}

/// The motor controllers: one unit per axis, the shutter, the reference changer and the filter
/// wheel's coils.
Expected<void> add_motor_units(MotorControllerServer& motors,
                               RigUnits& units,
                               const json& j,
                               const SimSection& sim,
                               double time_scale,
                               std::uint64_t seed) {
    try {
        for (const json& a : j.at("axes")) {
            const std::string role = a.at("role").get<std::string>();
            const int unit = a.at("unit").get<int>();
            auto prof = devices::load_axis_profile(a.value("profile", std::string("generic")));
            if (!prof) {
                return make_error("sim rig: axis " + role + ": " + prof.error().message);
            }
            MotorSimConfig mc;
            mc.time_scale = time_scale;
            mc.seed = seed + static_cast<std::uint64_t>(unit);
            mc.start_homed = sim.start_homed;
            const auto initial = sim.initial_deg.find(role);
            mc.initial_deg = initial != sim.initial_deg.end() ? initial->second
                             : role == "detector"             ? 45.0
                                                              : 0.0;
            const json lim = a.at("limits_deg");
            // Limit switches a little beyond the soft limits.
            mc.limit_min_deg = lim.at(0).get<double>() - 5;
            mc.limit_max_deg = lim.at(1).get<double>() + 5;
            if (auto r = motors.add_unit(unit, *prof, mc); !r) {
                return make_error("sim rig: axis " + role + ": " + r.error().message);
            }
            if (role == "light") {
                units.light = unit;
            } else if (role == "detector") {
                units.detector = unit;
            } else if (role == "tilt") {
                units.tilt = unit;
            } else if (role == "spin") {
                units.spin = unit;
            }
        }
        const json& sh = j.at("shutter");
        units.shutter = sh.at("unit").get<int>();
        if (auto r = motors.add_shutter(units.shutter, sh.at("coil").get<int>()); !r) {
            return make_error("sim rig: shutter: " + r.error().message);
        }
        if (j.contains("reference_changer")) {
            const json& rc = j.at("reference_changer");
            units.reference_changer = rc.at("unit").get<int>();
            if (auto r = motors.add_shutter(units.reference_changer, rc.at("coil").get<int>());
                !r) {
                return make_error("sim rig: reference changer: " + r.error().message);
            }
        }
        if (j.contains("filter_wheel")) {
            const json& filters = j.at("filter_wheel").at("filters");
            if (!filters.is_array() || filters.size() != 3) {
                return make_error("sim rig: filter_wheel.filters: three coils needed");
            }
            for (std::size_t c = 0; c < 3; ++c) {
                const int unit = filters.at(c).at("unit").get<int>();
                units.filters[c] = unit;
                if (auto r = motors.add_shutter(unit, filters.at(c).at("coil").get<int>()); !r) {
                    return make_error("sim rig: filter " + std::to_string(c) + ": " +
                                      r.error().message);
                }
            }
        }
    } catch (const std::exception& e) {
        return make_error(std::string("sim rig: ") + gonio::json_error_text(e.what()));
    }
    return {};
}

/// Zoomed camera placements: a coil each, and what the camera sees through them.
Expected<std::vector<ZoomPlacement>> add_placements(MotorControllerServer& motors,
                                                    RigUnits& units,
                                                    const json& j) {
    std::vector<ZoomPlacement> zooms;
    try {
        if (j.contains("placements")) {
            const json& ps = j.at("placements");
            if (!ps.is_array()) {
                return make_error("sim rig: placements: an array of placements");
            }
            for (std::size_t k = 0; k < ps.size(); ++k) {
                const json& p = ps.at(k);
                ZoomPlacement z;
                z.magnification = p.at("magnification").get<double>();
                z.offset_m = {p.at("offset_m").at(0).get<double>(),
                              p.at("offset_m").at(1).get<double>()};
                if (!(z.magnification >= 1 && z.magnification <= 100) ||
                    !std::isfinite(z.offset_m[0]) || !std::isfinite(z.offset_m[1])) {
                    return make_error("sim rig: placements[" + std::to_string(k) +
                                      "]: magnification in [1, 100] and a finite offset needed");
                }
                const int unit = p.at("unit").get<int>();
                if (auto r = motors.add_shutter(unit, p.at("coil").get<int>()); !r) {
                    return make_error("sim rig: placements[" + std::to_string(k) +
                                      "]: " + r.error().message);
                }
                units.placements.push_back(unit);
                zooms.push_back(z);
            }
        }
    } catch (const std::exception& e) {
        return make_error(std::string("sim rig: ") + gonio::json_error_text(e.what()));
    }
    return zooms;
}

/// The camera's sensor and feature naming.
GigeCameraConfig camera_config(const SimSection& sim,
                               const SimRigOptions& opt,
                               const brdf::RigErrorBudget& budget,
                               std::uint64_t seed) {
    GigeCameraConfig gc;
    gc.sensor.nonlinearity = budget.nonlinearity;
    gc.sensor.width = sim.sensor_width;
    gc.sensor.height = sim.sensor_height;
    gc.sensor.seed = seed;
    if (opt.sphere) {
        gc.sensor.width = opt.sphere->camera.width;
        gc.sensor.height = opt.sphere->camera.height;
    }
    gc.exposure_naming = opt.exposure_abs ? ExposureNaming::kAbs : ExposureNaming::kSfnc;
    return gc;
}

}  // namespace

SimRig::~SimRig() {
    stop();
}

void SimRig::stop() {
    wire_stop_ = true;
    if (wire_.joinable()) {
        wire_.join();
    }
    if (camera_server_) {
        camera_server_->stop();
    }
    if (motors_) {
        motors_->stop();
    }
}

void SimRig::wire_loop() {
    // The pulse of a compare output, as drives send it: 100 us (simulated) long.
    constexpr double kPulseWidthS = 100e-6;
    while (!wire_stop_) {
        bool armed = false;
        const std::vector<ComparePulse> pulses = motors_->take_pulses(&armed);
        for (const ComparePulse& p : pulses) {
            const auto width = std::chrono::duration_cast<GigeCamera::Clock::duration>(
                std::chrono::duration<double>(kPulseWidthS / time_scale_));
            const bool exposed = camera_->line_pulse(
                p.at, width, [&](GigeCamera::Clock::time_point start, double exposure_s) {
                    motors_->latch_pulse(p.unit, p.index, start, exposure_s);
                });
            if (exposed) {
                camera_server_->wake();
            }
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(armed ? 1 : 20));
    }
}

std::string SimRig::motor_address() const {
    return motors_->address();
}
std::string SimRig::camera_address() const {
    return camera_server_->address();
}

std::string SimRig::describe() const {
    return "sample " + sample_name_ + " (" + (sample_ ? sample_->describe() : "") + ")";
}

Expected<std::unique_ptr<SimRig>> SimRig::start(const std::string& rig_json,
                                                const SimRigOptions& opt) {
    std::unique_ptr<SimRig> rig(new SimRig());
    json j;
    try {
        j = json::parse(rig_json);
    } catch (const std::exception& e) {
        return make_error(std::string("sim rig: ") + gonio::json_error_text(e.what()));
    }
    Expected<SimSection> section = read_sim_section(j);
    if (!section) {
        return make_error(section.error().message);
    }
    const SimSection& sim = *section;
    const double time_scale = opt.time_scale > 0 ? opt.time_scale : sim.time_scale;
    const std::uint64_t seed = opt.seed > 0 ? opt.seed : sim.seed;
    auto truth = load_ground_truth(opt, sim);
    if (!truth) {
        return tl::unexpected(truth.error());
    }
    rig->sample_ = truth->sample;
    rig->sample_name_ = truth->name;
    const double white = j.value("white_reference", json::object()).value("reflectance", 0.99);
    rig->mounted_ = std::make_shared<MountedBrdf>(rig->sample_, white);
    rig->motors_ = std::make_unique<MotorControllerServer>();
    if (auto r = add_motor_units(*rig->motors_, rig->units_, j, sim, time_scale, seed); !r) {
        return tl::unexpected(r.error());
    }
    auto zooms = add_placements(*rig->motors_, rig->units_, j);
    if (!zooms) {
        return tl::unexpected(zooms.error());
    }
    if (auto r = rig->motors_->start(); !r) {
        return make_error("sim rig: motor controllers: " + r.error().message);
    }
    // World and camera.
    rig->world_ = std::make_unique<RigWorld>(
        rig->motors_.get(), rig->units_, rig->mounted_, sim.irradiance_w_m2);
    auto budget = brdf::read_error_budget(rig_json, "sim rig");
    if (!budget) {
        return make_error(budget.error().message);
    }
    rig->budget_ = *budget;
    rig->world_->set_instrument(std::make_shared<InstrumentErrors>(*budget, seed),
                                simulated_clock(time_scale));
    const GigeCameraConfig gc = camera_config(sim, opt, *budget, seed);
    rig->camera_ = std::make_shared<GigeCamera>(gc, rig->mounted_, rig->world_->scene_fn());
    rig->camera_->set_scene_path(rig->world_->scene_path_fn());
    if (opt.sphere) {
        SphereImaging imaging = *opt.sphere;
        imaging.placements = *zooms;
        rig->camera_->set_renderer(sphere_renderer(imaging));
    }
    rig->camera_server_ = std::make_unique<GigeServer>(rig->camera_);
    auto served = opt.camera_ip.empty() ? rig->camera_server_->start_on_free_loopback()
                                        : rig->camera_server_->start(opt.camera_ip);
    if (!served) {
        return make_error("sim rig: camera server: " + served.error().message);
    }
    rig->camera_->set_line_scene(
        [w = rig->world_.get()](GigeCamera::Clock::time_point at) { return w->scene_at(at); },
        [w = rig->world_.get()](GigeCamera::Clock::time_point at, double e, SceneState* s) {
            w->fill_path_at(at, e, s);
        });
    rig->time_scale_ = time_scale;
    rig->wire_ = std::thread([r = rig.get()] { r->wire_loop(); });
    return rig;
}

}  // namespace gonio::sim
