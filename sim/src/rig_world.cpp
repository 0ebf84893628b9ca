#include "gonio/sim/rig_world.h"

#include <algorithm>
#include <cmath>

#include "gonio/brdf/rig_geometry.h"

namespace gonio::sim {

MountedBrdf::MountedBrdf(std::shared_ptr<const brdf::Brdf> sample, double white_reflectance)
    : sample_(std::move(sample)), white_reflectance_(white_reflectance) {}

brdf::Rgbd MountedBrdf::eval(const brdf::Vec3d& wi, const brdf::Vec3d& wo) const {
    if (white_.load()) {
        // The white standard: Lambertian, f = rho / pi above the horizon, 0 below.
        if (wi.z() <= 0 || wo.z() <= 0) {
            return brdf::Rgbd::Zero();
        }
        return brdf::Rgbd::Constant(white_reflectance_ * brdf::kInvPi);
    }
    return sample_ ? sample_->eval(wi, wo) : brdf::Rgbd::Zero();
}

bool MountedBrdf::isotropic() const {
    return sample_ ? sample_->isotropic() : true;
}

std::string MountedBrdf::describe() const {
    return (white_.load() ? std::string("white standard in the beam; sample: ")
                          : std::string("sample: ")) +
           (sample_ ? sample_->describe() : std::string("none"));
}

RigWorld::RigWorld(const MotorControllerServer* server,
                   RigUnits units,
                   std::shared_ptr<MountedBrdf> mounted,
                   double irradiance_w_m2)
    : server_(server), units_(units), mounted_(std::move(mounted)), irradiance_(irradiance_w_m2) {}

SceneState RigWorld::scene() const {
    constexpr double kDeg = brdf::kPi / 180.0;
    brdf::RigPosed p;
    p.light = server_->position_deg(units_.light) * kDeg;
    p.detector = server_->position_deg(units_.detector) * kDeg;
    p.tilt = server_->position_deg(units_.tilt) * kDeg;
    p.spin = server_->position_deg(units_.spin) * kDeg;
    return scene_of(p);
}

SceneState RigWorld::scene_at(std::chrono::steady_clock::time_point at) const {
    constexpr double kDeg = brdf::kPi / 180.0;
    auto deg = [&](int unit) { return server_->path_deg_at(unit, at, {0.0})[0] * kDeg; };
    brdf::RigPosed p;
    p.light = deg(units_.light);
    p.detector = deg(units_.detector);
    p.tilt = deg(units_.tilt);
    p.spin = deg(units_.spin);
    return scene_of(p);
}

SceneState RigWorld::scene_of(const brdf::RigPosed& p) const {
    const std::uint64_t n = ++exposures_;
    if (hook_) {
        hook_(n);
    }
    SceneState s;
    const auto [wi, wo] = brdf::rig_forward(p);
    s.wi = wi;
    s.wo = wo;
    s.light_arm_rad = p.light;
    s.detector_arm_rad = p.detector;
    s.tilt_rad = p.tilt;
    s.spin_rad = p.spin;
    s.shutter_open = units_.shutter > 0 ? server_->shutter_open(units_.shutter) : true;
    s.irradiance_w_m2 = irradiance_ * lamp_factor_.load();
    if (instrument_) {
        apply_instrument(p, n, &s);
    }
    for (int c = 0; c < 3; ++c) {
        if (units_.filters[c] > 0 && server_->shutter_open(units_.filters[c])) {
            s.filter = brdf::Rgbd::Zero();
            s.filter[c] = 1.0;
            break;
        }
    }
    for (std::size_t k = 0; k < units_.placements.size(); ++k) {
        if (server_->shutter_open(units_.placements[k])) {
            s.placement = static_cast<int>(k) + 1;
            break;
        }
    }
    if (units_.reference_changer > 0) {
        mounted_->set_white(server_->shutter_open(units_.reference_changer));
    }
    if (!s.wi.allFinite() || !s.wo.allFinite()) {
        // An unknown unit reads NaN: the camera then sees darkness, never NaN.
        s.wi = s.wo = brdf::Vec3d(0, 0, -1);
    }
    if (!std::isfinite(s.light_arm_rad) || !std::isfinite(s.detector_arm_rad) ||
        !std::isfinite(s.tilt_rad) || !std::isfinite(s.spin_rad)) {
        // Same for the stage angles: an image-mode renderer then sees the shutter closed.
        s.light_arm_rad = s.detector_arm_rad = s.tilt_rad = s.spin_rad = 0;
        s.shutter_open = false;
    }
    return s;
}

void RigWorld::set_instrument(std::shared_ptr<const InstrumentErrors> instrument,
                              std::function<double()> clock_s) {
    instrument_ = std::move(instrument);
    clock_s_ = std::move(clock_s);
}

std::array<std::uint64_t, 2> RigWorld::arm_moves(double light_rad, double detector_rad) const {
    std::lock_guard<std::mutex> lock(moves_mutex_);
    const double now[2] = {light_rad, detector_rad};
    for (int k = 0; k < 2; ++k) {
        // Any change of the encoder reading since the last exposure is a move (the first
        // exposure counts as one: the arm arrived there somehow).
        if (!(now[k] == last_arm_rad_[k])) {
            ++moves_[k];
            last_arm_rad_[k] = now[k];
        }
    }
    return moves_;
}

void RigWorld::apply_instrument(const brdf::RigPosed& p,
                                std::uint64_t exposure,
                                SceneState* s) const {
    const InstrumentErrors& e = *instrument_;
    const auto moves = arm_moves(p.light, p.detector);
    const brdf::Vec3d l = e.arm_direction(Arm::kLight, p.light, moves[0]);
    const brdf::Vec3d v = e.arm_direction(Arm::kDetector, p.detector, moves[1]);
    s->wi = brdf::world_to_sample(l, p.tilt, p.spin);
    s->wo = brdf::world_to_sample(v, p.tilt, p.spin);
    s->light_arm_rad = e.arm_angle(Arm::kLight, p.light, moves[0]);
    s->detector_arm_rad = e.arm_angle(Arm::kDetector, p.detector, moves[1]);
    const double hours = clock_s_ ? clock_s_() / 3600.0 : 0.0;
    s->irradiance_w_m2 *= e.lamp_factor(exposure, hours);
    s->stray_radiance_w_m2_sr = e.stray_radiance(s->irradiance_w_m2);
}

SceneFn RigWorld::scene_fn() const {
    return [this]() { return scene(); };
}

std::pair<brdf::Vec3d, brdf::Vec3d> RigWorld::pose_directions(const brdf::RigPosed& p) const {
    if (!instrument_) {
        return brdf::rig_forward(p);
    }
    std::array<std::uint64_t, 2> moves;
    {
        std::lock_guard<std::mutex> lock(moves_mutex_);
        moves = moves_;
    }
    const InstrumentErrors& e = *instrument_;
    return {brdf::world_to_sample(e.arm_direction(Arm::kLight, p.light, moves[0]), p.tilt, p.spin),
            brdf::world_to_sample(
                e.arm_direction(Arm::kDetector, p.detector, moves[1]), p.tilt, p.spin)};
}

void RigWorld::fill_path(double exposure_s, SceneState* scene) const {
    scene->path.clear();
    if (!(exposure_s > 0)) {
        return;
    }
    // The drives' touch probes latch the exposure's edges (every exposure, as the camera's
    // exposure-active line pulses for each).
    for (int u : {units_.light, units_.detector, units_.tilt, units_.spin}) {
        server_->latch_exposure(u, exposure_s);
    }
    fill_path_along(
        exposure_s,
        [this](int unit, const std::vector<double>& t) { return server_->path_deg(unit, t); },
        scene);
}

void RigWorld::fill_path_at(std::chrono::steady_clock::time_point at,
                            double exposure_s,
                            SceneState* scene) const {
    scene->path.clear();
    if (!(exposure_s > 0)) {
        return;
    }
    for (int u : {units_.light, units_.detector, units_.tilt, units_.spin}) {
        server_->latch_pulse(u, 0, at, exposure_s);
    }
    fill_path_along(
        exposure_s,
        [this, at](int unit, const std::vector<double>& t) {
            return server_->path_deg_at(unit, at, t);
        },
        scene);
}

void RigWorld::fill_path_along(double exposure_s, const UnitPathFn& path, SceneState* scene) const {
    constexpr double kDeg = brdf::kPi / 180.0;
    if (scene->shape != SampleShape::kFlatPatch) {
        return;
    }
    const int units[4] = {units_.light, units_.detector, units_.tilt, units_.spin};
    double travel = 0;
    for (int u : units) {
        const std::vector<double> ends = path(u, {0.0, exposure_s});
        if (std::isfinite(ends[0]) && std::isfinite(ends[1])) {
            travel = std::max(travel, std::abs(ends[1] - ends[0]) * kDeg);
        }
    }
    if (travel < 1e-9) {
        return;  // every stage stands: the scene's own directions hold for the whole exposure
    }
    // Time nodes: composite Gauss-Legendre over the exposure (a monotonic stage travels at most
    // kPathPieceRad per piece).
    const int pieces = std::clamp(static_cast<int>(std::ceil(travel / kPathPieceRad)), 1, 20000);
    double x[kPathNodesPerPiece];
    double w[kPathNodesPerPiece];
    brdf::gauss_legendre_unit(kPathNodesPerPiece, x, w);
    std::vector<double> t;
    std::vector<double> weight;
    for (int p = 0; p < pieces; ++p) {
        for (int k = 0; k < kPathNodesPerPiece; ++k) {
            t.push_back(exposure_s * (p + x[k]) / pieces);
            weight.push_back(w[k] / pieces);
        }
    }
    std::vector<double> deg[4];
    for (int a = 0; a < 4; ++a) {
        deg[a] = path(units[a], t);
    }
    scene->path.reserve(t.size());
    for (std::size_t k = 0; k < t.size(); ++k) {
        const brdf::RigPosed p{
            deg[0][k] * kDeg, deg[1][k] * kDeg, deg[2][k] * kDeg, deg[3][k] * kDeg};
        const auto [wi, wo] = pose_directions(p);
        if (!wi.allFinite() || !wo.allFinite()) {
            scene->path.clear();  // an unknown unit: the scene's own (dark) directions hold
            return;
        }
        scene->path.push_back(brdf::PathNode{wi, wo, weight[k]});
    }
}

ScenePathFn RigWorld::scene_path_fn() const {
    return [this](double exposure_s, SceneState* s) { fill_path(exposure_s, s); };
}

}  // namespace gonio::sim
