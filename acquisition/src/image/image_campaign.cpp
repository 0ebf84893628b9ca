// The campaign's steps (image_campaign.h) live by job beside this file: hdr_capture (the rig
// seam, HDR capture, binning a frame's pixels), campaign_setup (steps 1 and 2: white reference
// and sample sphere), light_choice (the candidates and the choice of the next frame),
// frame_loop (steps 3 to 5, one loop for the isotropic and the anisotropic path), coverage_prediction,
// campaign_outputs (the campaign folder's files) and device_capture (the capture function over
// real devices). Here: the result's summaries, the run in order, and the settings of a rig.

#include "gonio/acquisition/image/image_campaign.h"

#include <algorithm>
#include <optional>

#include "campaign_setup.h"
#include "frame_loop.h"
#include "gonio/acquisition/image/image_journal.h"
#include "light_choice.h"

namespace gonio::acquisition {

double ImageCampaignResult::coverage_fraction() const {
    return aniso_coverage ? aniso_coverage->fraction() : coverage.fraction();
}

std::size_t ImageCampaignResult::valid_bins() const {
    return aniso_coverage ? aniso_coverage->valid_bins() : coverage.valid_bins();
}

std::size_t ImageCampaignResult::covered_bins() const {
    return aniso_coverage ? aniso_coverage->covered_bins() : coverage.covered_bins();
}

std::size_t ImageCampaignResult::filled_bins() const {
    return aniso_table ? aniso_table->filled_bins() : table.filled_bins();
}

Expected<ImageCampaignResult> run_image_campaign(const CaptureFn& capture,
                                                 const ImageCampaignConfig& cfg,
                                                 const ImageProgressFn& progress,
                                                 const std::string& journal_path,
                                                 const ImageStateFn& state) {
    if (!(cfg.bracket_factor > 1) || !(cfg.exposure_us > 0) || !(cfg.electrons_per_count > 0) ||
        !(cfg.lights.step_rad > 0)) {
        return make_error(
            "image campaign: exposure_us, electrons_per_count and lights.step_rad must be > 0 "
            "and bracket_factor > 1");
    }
    ImageCampaignResult result(cfg.layout);
    detail::Rig rig(capture, cfg, &result);
    const double front = detail::front_light(cfg);
    rig.set_pose(front);

    std::optional<ImageJournal> journal;
    if (!journal_path.empty()) {
        auto j = ImageJournal::open(journal_path);
        if (!j) {
            return tl::unexpected(j.error());
        }
        journal.emplace(std::move(*j));
    }
    if (auto s = detail::set_up_campaign(rig, cfg, journal, journal_path, front, &result); !s) {
        return tl::unexpected(s.error());
    }
    if (cfg.anisotropic && (!cfg.aniso_layout.sane() || !(cfg.spins.step_rad > 0) ||
                            !(cfg.spins.max_rad >= cfg.spins.min_rad))) {
        return make_error("image campaign: the 4-D table " + cfg.aniso_layout.describe() +
                          " needs 1..720 bins per axis and the spin range a step > 0");
    }
    if (auto f =
            detail::run_frames(rig, cfg, journal, journal_path, front, progress, state, &result);
        !f) {
        return tl::unexpected(f.error());
    }
    return result;
}

ImageCampaignConfig image_campaign_config(const RigConfig& rig,
                                          const CameraModel& camera,
                                          int table_factor,
                                          double coverage_target,
                                          int max_frames) {
    return image_campaign_config(
        rig,
        camera,
        table_factor <= 1 ? TableLayout::merl() : coarse_layout(table_factor),
        coverage_target,
        max_frames);
}

ImageCampaignConfig image_campaign_config(const RigConfig& rig,
                                          const CameraModel& camera,
                                          const TableLayout& layout,
                                          double coverage_target,
                                          int max_frames) {
    constexpr double kDeg = brdf::kPi / 180;
    ImageCampaignConfig cfg;
    cfg.camera = camera;
    cfg.layout = layout;
    cfg.detector_arm_rad = 0;
    const devices::SoftLimits& lim = rig.axes[static_cast<int>(AxisRole::kLight)].limits;
    cfg.lights.min_rad = std::max(lim.min_deg, -180.0) * kDeg;
    cfg.lights.max_rad = std::min(lim.max_deg, 180.0) * kDeg;
    // Light positions a quarter of a theta_d row apart in separation (theta_d is half the
    // separation), at most 1 degree: several frames per row, each sampling the sphere's pixels at
    // other normals, fill the narrow theta_h bins of fine tables.
    cfg.lights.step_rad = std::min(kDeg, (brdf::kPi / cfg.layout.n_theta_d) / 4);
    cfg.lights.blind_zone_rad = rig.blind_angle_deg * kDeg;
    // The exclusion rules' grazing limits stay at their defaults (80 degrees), inside the rig's
    // max_theta_deg: pixels beyond them are too sensitive to the normal's error.
    cfg.rules.max_theta_i = std::min(cfg.rules.max_theta_i, rig.max_theta_deg * kDeg);
    cfg.rules.max_theta_o = std::min(cfg.rules.max_theta_o, rig.max_theta_deg * kDeg);
    // A frame fills (part of) one theta_d row: the smallest gain worth a frame is a share of a
    // row, not of the table (0.05 % of a 30-row table's valid bins, 0.017 % of the MERL table's,
    // 183 bins: a light position costs about half a second of rig time, and even 183 bins in it
    // beat point mode's one or two bins per second a hundredfold).
    cfg.min_gain_fraction = 0.0005 * std::min(1.0, 30.0 / std::max(1, layout.n_theta_d));
    // Fine theta_h rows are narrower than two pixels' footprint: predict every pixel.
    cfg.plan_pixel_stride = layout.n_theta_h >= 60 ? 1 : cfg.plan_pixel_stride;
    cfg.coverage_target = coverage_target;
    cfg.max_frames = max_frames;
    cfg.silhouette.radius_m = rig.sphere_radius_m;
    // The rig's sphere is of known size and its camera calibrated: the outline gives the centre.
    cfg.silhouette.orthographic_known_radius = true;
    cfg.min_exposure_us = std::max(cfg.min_exposure_us, rig.capture.min_exposure_us);
    cfg.exposure_us = std::clamp(10000.0, rig.capture.min_exposure_us, rig.capture.max_exposure_us);
    // Conversion gain and read noise at the capture gain (electrons are what the sensor counts).
    cfg.electrons_per_count = rig.noise.e_per_count / rig.capture.gain;
    cfg.read_noise_counts = rig.noise.read_noise_counts * rig.capture.gain;
    cfg.reference_albedo = rig.white_reflectance;
    cfg.error_budget = rig.error_budget;
    cfg.dynamics = rig_dynamics(rig);
    cfg.capture_timeout = std::chrono::milliseconds(rig.capture.timeout_ms);
    for (const PlacementConfig& p : rig.placements) {
        cfg.placements.push_back(p.placement);
    }
    return cfg;
}

void make_anisotropic(ImageCampaignConfig* cfg, const RigConfig& rig, const AnisoLayout& layout) {
    constexpr double kDeg = brdf::kPi / 180;
    cfg->anisotropic = true;
    cfg->aniso_layout = layout;
    // The 4-D campaign takes every frame in the wide view.
    cfg->placements.clear();
    // A quarter of a theta_d row in separation (theta_d is half the separation): each row is
    // seen from four light positions, each at every spin.
    cfg->lights.step_rad = (brdf::kPi / std::max(1, layout.n_theta_d)) / 4;
    const devices::SoftLimits& lim = rig.axes[static_cast<int>(AxisRole::kSpin)].limits;
    cfg->spins.min_rad = std::max(lim.min_deg, -180.0) * kDeg;
    cfg->spins.max_rad = std::min(lim.max_deg, cfg->spins.min_rad / kDeg + 360.0) * kDeg;
    // Half a phi_h bin: a spin turns the tangent of the pixels facing the holder's normal by the
    // same angle, and those elsewhere by about as much.
    cfg->spins.step_rad = brdf::kPi / std::max(1, layout.n_phi_h);
    // A pose fills a few hundred of the 4-D table's bins: stop when the best adds fewer than
    // 0.05 % of them.
    cfg->min_gain_fraction = 0.0005;
}

}  // namespace gonio::acquisition
