#include "gonio/sim/sim_rig.h"

#include <nlohmann/json.hpp>

#include "gonio/base/strings.h"
#include "gonio/brdf/analytic_brdf.h"
#include "gonio/brdf/brdf.h"
#include "gonio/brdf/material_library.h"
#include "gonio/devices/axis_profile.h"

namespace gonio::sim {

using nlohmann::json;

SimRig::~SimRig() {
    stop();
}

void SimRig::stop() {
    if (camera_server_) {
        camera_server_->stop();
    }
    if (motors_) {
        motors_->stop();
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
    const json sim = j.value("sim", json::object());
    double time_scale = opt.time_scale > 0 ? opt.time_scale : sim.value("time_scale", 20.0);
    const std::uint64_t seed = opt.seed > 0 ? opt.seed : sim.value("seed", std::uint64_t{1});
    if (!(time_scale > 0)) {
        return make_error("sim rig: sim.time_scale must be > 0");
    }
    // Ground truth.
    std::string brdf_path = opt.brdf_path;
    std::string material = opt.material;
    if (brdf_path.empty() && material.empty()) {
        brdf_path = sim.value("brdf", std::string());
        material = sim.value("material", std::string("red-plastic"));
    }
    if (!brdf_path.empty()) {
        auto b = brdf::load_brdf(brdf_path);
        if (!b) {
            return make_error("sim rig: " + b.error().message);
        }
        rig->sample_ = std::shared_ptr<const brdf::Brdf>(std::move(*b));
        rig->sample_name_ = brdf_path;
    } else {
        auto m = brdf::load_material(material);
        if (!m) {
            return make_error("sim rig: " + m.error().message);
        }
        rig->sample_ = std::shared_ptr<const brdf::Brdf>(brdf::make_analytic_brdf(*m));
        rig->sample_name_ = material;
    }
    const double white = j.value("white_reference", json::object()).value("reflectance", 0.99);
    rig->mounted_ = std::make_shared<MountedBrdf>(rig->sample_, white);
    // Motor controllers.
    rig->motors_ = std::make_unique<MotorControllerServer>();
    const json initial = sim.value("initial_deg", json::object());
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
            mc.start_homed = sim.value("start_homed", true);
            mc.initial_deg = initial.value(role, role == "detector" ? 45.0 : 0.0);
            const json lim = a.at("limits_deg");
            // Limit switches a little beyond the soft limits.
            mc.limit_min_deg = lim.at(0).get<double>() - 5;
            mc.limit_max_deg = lim.at(1).get<double>() + 5;
            if (auto r = rig->motors_->add_unit(unit, *prof, mc); !r) {
                return make_error("sim rig: axis " + role + ": " + r.error().message);
            }
            if (role == "light") {
                rig->units_.light = unit;
            } else if (role == "detector") {
                rig->units_.detector = unit;
            } else if (role == "tilt") {
                rig->units_.tilt = unit;
            } else if (role == "spin") {
                rig->units_.spin = unit;
            }
        }
        const json& sh = j.at("shutter");
        rig->units_.shutter = sh.at("unit").get<int>();
        if (auto r = rig->motors_->add_shutter(rig->units_.shutter, sh.at("coil").get<int>()); !r) {
            return make_error("sim rig: shutter: " + r.error().message);
        }
        if (j.contains("reference_changer")) {
            const json& rc = j.at("reference_changer");
            rig->units_.reference_changer = rc.at("unit").get<int>();
            if (auto r = rig->motors_->add_shutter(rig->units_.reference_changer,
                                                   rc.at("coil").get<int>());
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
                rig->units_.filters[c] = unit;
                if (auto r = rig->motors_->add_shutter(unit, filters.at(c).at("coil").get<int>());
                    !r) {
                    return make_error("sim rig: filter " + std::to_string(c) + ": " +
                                      r.error().message);
                }
            }
        }
    } catch (const std::exception& e) {
        return make_error(std::string("sim rig: ") + gonio::json_error_text(e.what()));
    }
    if (auto r = rig->motors_->start(); !r) {
        return make_error("sim rig: motor controllers: " + r.error().message);
    }
    // World and camera.
    rig->world_ = std::make_unique<RigWorld>(
        rig->motors_.get(), rig->units_, rig->mounted_, sim.value("irradiance_w_m2", 1.0));
    GigeCameraConfig gc;
    const json sensor = sim.value("sensor", json::object());
    gc.sensor.width = sensor.value("width", 640);
    gc.sensor.height = sensor.value("height", 512);
    gc.sensor.seed = seed;
    if (opt.sphere) {
        gc.sensor.width = opt.sphere->camera.width;
        gc.sensor.height = opt.sphere->camera.height;
    }
    gc.exposure_naming = opt.exposure_abs ? ExposureNaming::kAbs : ExposureNaming::kSfnc;
    rig->camera_ = std::make_shared<GigeCamera>(gc, rig->mounted_, rig->world_->scene_fn());
    if (opt.sphere) {
        rig->camera_->set_renderer(sphere_renderer(*opt.sphere));
    }
    rig->camera_server_ = std::make_unique<GigeServer>(rig->camera_);
    auto served = opt.camera_ip.empty() ? rig->camera_server_->start_on_free_loopback()
                                        : rig->camera_server_->start(opt.camera_ip);
    if (!served) {
        return make_error("sim rig: camera server: " + served.error().message);
    }
    return rig;
}

}  // namespace gonio::sim
