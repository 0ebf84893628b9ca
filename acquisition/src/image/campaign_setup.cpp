#include "campaign_setup.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "gonio/brdf/rig_geometry.h"

namespace gonio::acquisition::detail {
namespace {

/// The silhouette frame: lit from the allowed position closest to the camera and, when the arm
/// can reach it, from its mirror image on the other side of the detector; the pixel-wise maximum
/// of the two has no shadow crescent at the limb.
Expected<SphereGeometry> find_sphere(Rig& rig,
                                     const ImageCampaignConfig& cfg,
                                     double light,
                                     bool reference) {
    const double mirrored = brdf::wrap_pi(2 * cfg.detector_arm_rad - light);
    std::vector<double> lights = {light};
    if (mirrored >= cfg.lights.min_rad && mirrored <= cfg.lights.max_rad &&
        std::abs(mirrored - light) > 1e-9) {
        lights.push_back(mirrored);
    }
    cv::Mat combined;
    for (double a : lights) {
        CaptureRequest r;
        r.light_arm_rad = a;
        r.channel = 1;
        r.exposure_us = cfg.exposure_us;
        r.reference = reference;
        auto frame = rig.grab(r);
        if (!frame) {
            return tl::unexpected(frame.error());
        }
        cv::Mat f;
        frame->image.convertTo(f, CV_32F);
        combined = combined.empty() ? f : cv::max(combined, f);
    }
    auto g = detect_sphere(combined, cfg.camera, cfg.silhouette);
    if (!g) {
        return make_error(std::string(reference ? "white reference" : "sample") + ": " +
                          g.error().message);
    }
    return g;
}

/// The median over the white reference's pixels of signal / ((rho / pi) cos(theta_i)) in one
/// channel: its calibration constant C_c.
Expected<double> channel_constant(Rig& rig,
                                  const ImageCampaignConfig& cfg,
                                  double light,
                                  int ch,
                                  const std::vector<SpherePixel>& pixels,
                                  const std::vector<std::uint8_t>& lit) {
    const brdf::Vec3d l = brdf::arm_direction(light);
    CaptureRequest r;
    r.light_arm_rad = light;
    r.channel = ch;
    r.reference = true;
    auto h = capture_hdr(rig, cfg, r, pixels, lit);
    if (!h) {
        return tl::unexpected(h.error());
    }
    std::vector<double> ratios;
    for (std::size_t i = 0; i < pixels.size(); ++i) {
        if (h->ok[i]) {
            const double cos_i = pixels[i].normal.dot(l);
            ratios.push_back(h->signal[i] / (cfg.reference_albedo / brdf::kPi * cos_i));
        }
    }
    if (ratios.size() < 100) {
        return make_error(std::string("white reference, ") + kChannelName[ch] + " channel: " +
                          std::to_string(ratios.size()) + " usable pixels, need at least 100");
    }
    std::nth_element(ratios.begin(), ratios.begin() + ratios.size() / 2, ratios.end());
    const double c = ratios[ratios.size() / 2];
    if (!(c > 0) || !std::isfinite(c)) {
        return make_error(std::string("white reference, ") + kChannelName[ch] +
                          " channel: calibration constant " + std::to_string(c) +
                          " is not positive (no light, or shutter stuck closed?)");
    }
    return c;
}

/// Step 1: the white reference sphere and the calibration constants per channel.
Expected<std::array<double, 3>> calibrate(Rig& rig,
                                          const ImageCampaignConfig& cfg,
                                          double light,
                                          SphereGeometry* sphere_out) {
    if (!(cfg.reference_albedo > 0 && cfg.reference_albedo <= 1)) {
        return make_error("reference_albedo = " + std::to_string(cfg.reference_albedo) +
                          " outside (0, 1]");
    }
    auto sphere = find_sphere(rig, cfg, light, true);
    if (!sphere) {
        return tl::unexpected(sphere.error());
    }
    *sphere_out = *sphere;
    ExclusionRules rules = cfg.rules;
    rules.max_theta_o = std::min(rules.max_theta_o, cfg.reference_max_theta);
    rules.max_theta_i = std::min(rules.max_theta_i, cfg.reference_max_theta);
    const std::vector<SpherePixel> pixels = sphere_pixels(cfg.camera, *sphere, rules, nullptr);
    PixelCounts ignored;
    const std::vector<std::uint8_t> lit =
        lit_pixels(pixels, brdf::arm_direction(light), rules, &ignored);
    std::array<double, 3> c{};
    for (int ch = 0; ch < 3; ++ch) {
        auto k = channel_constant(rig, cfg, light, ch, pixels, lit);
        if (!k) {
            return tl::unexpected(k.error());
        }
        c[ch] = *k;
    }
    return c;
}

/// A resumed journal's set-up must be of this configuration's campaign (kind, tables, detector).
Expected<void> check_resumed_setup(const ImageJournalSetup& s,
                                   const ImageCampaignConfig& cfg,
                                   const std::string& journal_path) {
    const TableLayout& l = cfg.layout;
    if (s.anisotropic != cfg.anisotropic ||
        (cfg.anisotropic && s.aniso_layout.describe() != cfg.aniso_layout.describe())) {
        return make_error(journal_path + ": the journal's campaign is " +
                          (s.anisotropic ? "anisotropic (" + s.aniso_layout.describe() + ")"
                                         : std::string("isotropic")) +
                          "; this configuration asks for " +
                          (cfg.anisotropic
                               ? "an anisotropic campaign (" + cfg.aniso_layout.describe() + ")"
                               : std::string("an isotropic campaign")) +
                          " (resume with the campaign's own settings)");
    }
    if (s.layout.n_theta_h != l.n_theta_h || s.layout.n_theta_d != l.n_theta_d ||
        s.layout.n_phi_d != l.n_phi_d ||
        std::abs(s.detector_arm_rad - cfg.detector_arm_rad) > 1e-9) {
        return make_error(journal_path + ": the journal's campaign has a " +
                          std::to_string(s.layout.n_theta_h) + "x" +
                          std::to_string(s.layout.n_theta_d) + "x" +
                          std::to_string(s.layout.n_phi_d) + " table and the detector arm at " +
                          std::to_string(s.detector_arm_rad * 180 / brdf::kPi) +
                          " deg; this configuration asks for " + std::to_string(l.n_theta_h) + "x" +
                          std::to_string(l.n_theta_d) + "x" + std::to_string(l.n_phi_d) + " at " +
                          std::to_string(cfg.detector_arm_rad * 180 / brdf::kPi) +
                          " deg (resume with the campaign's own settings)");
    }
    return {};
}

/// Steps 1 and 2 captured, and recorded in the journal when there is one.
Expected<void> capture_setup(Rig& rig,
                             const ImageCampaignConfig& cfg,
                             std::optional<ImageJournal>& journal,
                             double front,
                             ImageCampaignResult* result) {
    auto cal = calibrate(rig, cfg, front, &result->reference_sphere);
    if (!cal) {
        return tl::unexpected(cal.error());
    }
    result->calibration = *cal;
    // The sample sphere.
    auto sphere = find_sphere(rig, cfg, front, false);
    if (!sphere) {
        return tl::unexpected(sphere.error());
    }
    result->sphere = *sphere;
    if (!journal) {
        return {};
    }
    ImageJournalSetup s;
    s.layout = cfg.layout;
    s.detector_arm_rad = cfg.detector_arm_rad;
    s.calibration = result->calibration;
    s.sphere = result->sphere;
    s.reference_sphere = result->reference_sphere;
    s.captures = result->captures;
    s.exposure_time_s = result->exposure_time_s;
    s.anisotropic = cfg.anisotropic;
    s.aniso_layout = cfg.aniso_layout;
    return journal->append_setup(s);
}

}  // namespace

Expected<void> set_up_campaign(Rig& rig,
                               const ImageCampaignConfig& cfg,
                               std::optional<ImageJournal>& journal,
                               const std::string& journal_path,
                               double front,
                               ImageCampaignResult* result) {
    if (!journal || !journal->setup()) {
        return capture_setup(rig, cfg, journal, front, result);
    }
    // Resume: the set-up as recorded (no reference or silhouette captures).
    const ImageJournalSetup& s = *journal->setup();
    if (auto c = check_resumed_setup(s, cfg, journal_path); !c) {
        return c;
    }
    result->calibration = s.calibration;
    result->sphere = s.sphere;
    result->reference_sphere = s.reference_sphere;
    result->captures = s.captures;
    result->exposure_time_s = s.exposure_time_s;
    return {};
}

}  // namespace gonio::acquisition::detail
