// The simulator behind acquisition::EmbeddedRig.

#include "embedded_rig.h"

#include <memory>
#include <utility>

#include "gonio/sim/sim_rig.h"

namespace gonio::tools {

sim::SphereCamera to_sphere_camera(const acquisition::CameraModel& c) {
    sim::SphereCamera sc;
    sc.projection = c.projection == acquisition::Projection::kPerspective
                        ? sim::SphereProjection::kPerspective
                        : sim::SphereProjection::kOrthographic;
    sc.width = c.intrinsics.width;
    sc.height = c.intrinsics.height;
    sc.fx = c.intrinsics.fx;
    sc.fy = c.intrinsics.fy;
    sc.cx = c.intrinsics.cx;
    sc.cy = c.intrinsics.cy;
    sc.distortion = c.intrinsics.distortion;
    sc.rotation = c.rotation;
    sc.translation = c.translation;
    return sc;
}

namespace {

class SimEmbeddedRig final : public acquisition::EmbeddedRig {
  public:
    explicit SimEmbeddedRig(std::unique_ptr<sim::SimRig> rig) : rig_(std::move(rig)) {}
    std::string motor_address() const override { return rig_->motor_address(); }
    std::string camera_address() const override { return rig_->camera_address(); }
    std::string describe() const override { return rig_->describe(); }
    std::string ground_truth() const override { return rig_->sample()->describe(); }
    bool isotropic_sample() const override { return rig_->sample()->isotropic(); }
    sim::SimRig& sim() const { return *rig_; }

  private:
    std::unique_ptr<sim::SimRig> rig_;
};

}  // namespace

sim::SimRig* simulator(const acquisition::ImageRig& rig) {
    auto* s = dynamic_cast<SimEmbeddedRig*>(rig.embedded.get());
    return s == nullptr ? nullptr : &s->sim();
}

acquisition::EmbeddedRigStarter embedded_rig_starter() {
    return [](const std::string& rig_json, const acquisition::EmbeddedRigOptions& o)
               -> Expected<std::unique_ptr<acquisition::EmbeddedRig>> {
        sim::SimRigOptions so;
        so.material = o.material;
        so.brdf_path = o.brdf_path;
        so.time_scale = o.time_scale;
        so.seed = o.seed;
        if (o.sphere_camera) {
            sim::SphereImaging sphere;
            sphere.camera = to_sphere_camera(*o.sphere_camera);
            sphere.radius_m = o.sphere_radius_m;
            sphere.supersample = o.supersample;
            so.sphere = sphere;
        }
        auto s = sim::SimRig::start(rig_json, so);
        if (!s) {
            return tl::unexpected(s.error());
        }
        return std::unique_ptr<acquisition::EmbeddedRig>(
            std::make_unique<SimEmbeddedRig>(std::move(*s)));
    };
}

}  // namespace gonio::tools
