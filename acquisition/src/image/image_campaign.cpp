#include "gonio/acquisition/image/image_campaign.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <thread>

#include "gonio/acquisition/image/image_journal.h"
#include "gonio/base/atomic_file.h"
#include "gonio/base/check.h"
#include "gonio/base/strict_json.h"
#include "gonio/brdf/merl.h"
#include "gonio/brdf/rig_geometry.h"

namespace gonio::acquisition {
namespace {

constexpr const char* kChannelName[3] = {"red", "green", "blue"};

std::string describe(const CaptureRequest& r) {
    char spin[48] = "";
    if (r.spin_rad != 0) {
        std::snprintf(spin, sizeof spin, ", spin %.3f deg", r.spin_rad * 180 / brdf::kPi);
    }
    char placement[48] = "";
    if (r.placement != 0) {
        std::snprintf(placement, sizeof placement, ", zoomed placement %d", r.placement);
    }
    char buf[260];
    std::snprintf(buf,
                  sizeof(buf),
                  "capture (light arm %.3f deg%s%s, %s filter, %.1f us, shutter %s%s)",
                  r.light_arm_rad * 180 / brdf::kPi,
                  spin,
                  placement,
                  kChannelName[std::clamp(r.channel, 0, 2)],
                  r.exposure_us,
                  r.shutter_open ? "open" : "closed",
                  r.reference ? ", white reference" : "");
    return buf;
}

/// A pixel's value as double for any supported frame depth.
double pixel(const cv::Mat& m, int x, int y) {
    switch (m.depth()) {
        case CV_8U:
            return m.at<std::uint8_t>(y, x);
        case CV_16U:
            return m.at<std::uint16_t>(y, x);
        case CV_32F:
            return m.at<float>(y, x);
        case CV_64F:
            return m.at<double>(y, x);
        default:
            GONIO_CHECK_MSG(false, "unsupported frame depth " << m.depth());
    }
    return 0;
}

/// Runs the capture function and checks the frame against the camera model.
class Rig {
  public:
    Rig(const CaptureFn& capture, const ImageCampaignConfig& config, ImageCampaignResult* result)
        : capture_(capture), config_(config), result_(result) {}

    Expected<devices::Frame> grab(const CaptureRequest& r) {
        auto f = capture_(r);
        if (!f) {
            return make_error(describe(r) + ": " + f.error().message);
        }
        ++result_->captures;
        result_->exposure_time_s += r.exposure_us * 1e-6;
        const CameraIntrinsics& k = config_.camera.intrinsics;
        if (f->image.cols != k.width || f->image.rows != k.height || f->image.channels() != 1) {
            return make_error(describe(r) + ": frame is " + std::to_string(f->image.cols) + "x" +
                              std::to_string(f->image.rows) + "x" +
                              std::to_string(f->image.channels()) + ", the camera model says " +
                              std::to_string(k.width) + "x" + std::to_string(k.height) +
                              " single channel");
        }
        if (!f->linear) {
            return make_error(describe(r) +
                              ": frame is not linear (gamma-encoded), not radiometric");
        }
        return f;
    }

    /// Mean of config.dark_frames dark frames at this exposure (cached), CV_64F.
    Expected<cv::Mat> dark(double exposure_us, bool reference) {
        auto it = dark_.find(exposure_us);
        if (it != dark_.end()) {
            return it->second;
        }
        cv::Mat sum;
        const int n = std::max(1, config_.dark_frames);
        for (int i = 0; i < n; ++i) {
            CaptureRequest r;
            r.light_arm_rad = last_light_;
            r.spin_rad = last_spin_;
            r.placement = last_placement_;
            r.exposure_us = exposure_us;
            r.shutter_open = false;
            r.reference = reference;
            auto f = grab(r);
            if (!f) {
                return tl::unexpected(f.error());
            }
            cv::Mat d;
            f->image.convertTo(d, CV_64F);
            if (sum.empty()) {
                sum = d;
            } else {
                sum += d;
            }
        }
        sum /= n;
        dark_[exposure_us] = sum;
        return sum;
    }

    void set_light(double a, int placement = 0) {
        last_light_ = a;
        last_placement_ = placement;
    }
    /// The pose dark frames are taken at (they need no move of their own).
    void set_pose(double light, double spin) {
        last_light_ = light;
        last_spin_ = spin;
    }

  private:
    const CaptureFn& capture_;
    const ImageCampaignConfig& config_;
    ImageCampaignResult* result_;
    std::map<double, cv::Mat> dark_;
    double last_light_ = 0;
    double last_spin_ = 0;
    int last_placement_ = 0;
};

/// Per-pixel HDR signal over a pixel list.
struct HdrSamples {
    std::vector<double> signal;    ///< counts / us, dark subtracted
    std::vector<double> variance;  ///< (counts / us)^2
    std::vector<std::uint8_t> ok;  ///< 0 = saturated at every exposure
    int exposures = 0;
};

Expected<HdrSamples> capture_hdr(Rig& rig,
                                 const ImageCampaignConfig& cfg,
                                 CaptureRequest req,
                                 const std::vector<SpherePixel>& pixels,
                                 const std::vector<std::uint8_t>& wanted) {
    HdrSamples h;
    h.signal.assign(pixels.size(), 0.0);
    h.variance.assign(pixels.size(), 0.0);
    h.ok.assign(pixels.size(), 0);
    std::vector<std::uint8_t> pending = wanted;
    double exposure = cfg.exposure_us;
    const double n_dark = std::max(1, cfg.dark_frames);
    for (int b = 0; b < std::max(1, cfg.max_brackets); ++b) {
        req.exposure_us = exposure;
        req.shutter_open = true;
        auto frame = rig.grab(req);
        if (!frame) {
            return tl::unexpected(frame.error());
        }
        auto dark = rig.dark(exposure, req.reference);
        if (!dark) {
            return tl::unexpected(dark.error());
        }
        ++h.exposures;
        const double black = frame->black_level;
        const double sat = black + cfg.saturation_fraction * (frame->saturation_level - black);
        std::size_t left = 0;
        for (std::size_t i = 0; i < pixels.size(); ++i) {
            if (!pending[i]) {
                continue;
            }
            const double counts = pixel(frame->image, pixels[i].x, pixels[i].y);
            if (counts >= sat) {
                // Saturated at this exposure: try the next, shorter one.
                ++left;
                continue;
            }
            const double d = dark->at<double>(pixels[i].y, pixels[i].x);
            const double var_counts =
                std::max(counts - black, 0.0) / cfg.electrons_per_count +
                cfg.read_noise_counts * cfg.read_noise_counts * (1.0 + 1.0 / n_dark) + 1.0 / 12.0;
            h.signal[i] = (counts - d) / exposure;
            h.variance[i] = var_counts / (exposure * exposure);
            h.ok[i] = 1;
            pending[i] = 0;
        }
        const double next = exposure / cfg.bracket_factor;
        if (left == 0 || next < cfg.min_exposure_us) {
            break;
        }
        exposure = next;
    }
    return h;
}

/// Which pixels the light reaches usefully (theta_i within the limit), counting the others.
std::vector<std::uint8_t> lit_pixels(const std::vector<SpherePixel>& pixels,
                                     const brdf::Vec3d& l,
                                     const ExclusionRules& rules,
                                     PixelCounts* counts) {
    const double cos_max_i = std::cos(rules.max_theta_i);
    std::vector<std::uint8_t> lit(pixels.size(), 0);
    for (std::size_t i = 0; i < pixels.size(); ++i) {
        const double cos_i = pixels[i].normal.dot(l);
        if (cos_i <= 0) {
            // In the sphere's own shadow.
            ++counts->shadow;
        } else if (cos_i < cos_max_i) {
            // Lit at a grazing angle: too sensitive to the normal's error.
            ++counts->grazing_light;
        } else {
            lit[i] = 1;
        }
    }
    return lit;
}

brdf::Vec3d light_direction(double a) {
    return {std::cos(a), std::sin(a), 0.0};
}

/// What bounds the reachable part of the table under this configuration.
HoleLimits hole_limits(const ImageCampaignConfig& cfg) {
    HoleLimits limits;
    limits.blind_zone_rad = cfg.lights.blind_zone_rad;
    limits.max_separation_rad =
        std::min(brdf::kPi,
                 std::max(brdf::arm_separation(cfg.lights.min_rad, cfg.detector_arm_rad),
                          brdf::arm_separation(cfg.lights.max_rad, cfg.detector_arm_rad)));
    limits.max_theta_i = cfg.rules.max_theta_i;
    limits.max_theta_o = cfg.rules.max_theta_o;
    return limits;
}

/// The campaign's next light position (step 5 of run_image_campaign, and its prediction): the
/// index into `candidates`, or -1 with the reason when the campaign stops there (the coverage
/// target met, or no position adding the stop rule's share of the valid bins). Wide frames come
/// first; once the wide view's choice adds less than the stop rule's share, *zoom_phase is set
/// and only zoomed candidates are chosen from then on (a campaign holding a zoomed frame is in
/// that phase).
int next_campaign_light(const ImageCampaignConfig& cfg,
                        const std::vector<LightCandidate>& candidates,
                        const std::vector<std::size_t>& gains,
                        const CoverageMap& coverage,
                        double current_light_rad,
                        bool* zoom_phase,
                        std::string* stop_reason) {
    if (coverage.fraction() >= cfg.coverage_target) {
        *stop_reason = "coverage target met";
        return -1;
    }
    const std::size_t min_gain =
        std::max<std::size_t>(1,
                              static_cast<std::size_t>(cfg.min_gain_fraction *
                                                       static_cast<double>(coverage.valid_bins())));
    // The gains of one view kind (wide or zoomed), the others' zero.
    auto of_kind = [&](bool zoomed) {
        std::vector<std::size_t> g(gains.size(), 0);
        for (std::size_t k = 0; k < candidates.size(); ++k) {
            if ((candidates[k].placement != 0) == zoomed) {
                g[k] = gains[k];
            }
        }
        return g;
    };
    if (!*zoom_phase) {
        const int next =
            next_light(candidates, of_kind(false), current_light_rad, cfg.light_gain_fraction);
        if (next >= 0 && gains[next] >= min_gain) {
            return next;
        }
        if (cfg.placements.empty()) {
            *stop_reason = "no light position adds enough bins";
            return -1;
        }
        *zoom_phase = true;
    }
    const int next =
        next_light(candidates, of_kind(true), current_light_rad, cfg.light_gain_fraction);
    if (next < 0 || gains[next] < min_gain) {
        *stop_reason = "no light position adds enough bins";
        return -1;
    }
    return next;
}

/// A view of the sample sphere: the wide view (placement 0) or a zoomed placement, with the
/// sphere and the exclusion rules in its pixels.
struct SphereView {
    CameraModel camera;
    SphereGeometry sphere;
    ExclusionRules rules;
};

SphereView sphere_view(const ImageCampaignConfig& cfg,
                       const SphereGeometry& wide_sphere,
                       int placement) {
    SphereView v;
    if (placement == 0) {
        v.camera = cfg.camera;
        v.sphere = wide_sphere;
        v.rules = cfg.rules;
        return v;
    }
    GONIO_CHECK(placement > 0 && placement <= static_cast<int>(cfg.placements.size()));
    const Placement& p = cfg.placements[static_cast<std::size_t>(placement - 1)];
    v.camera = placement_camera(cfg.camera, p);
    v.sphere = placement_sphere(wide_sphere, v.camera, p.magnification);
    v.rules = placement_rules(cfg.rules, p.magnification);
    return v;
}

/// The light positions of the configuration's range outside the blind zone.
std::vector<double> range_positions(const ImageCampaignConfig& cfg) {
    const LightRange& r = cfg.lights;
    std::vector<double> out;
    const int steps = static_cast<int>(std::floor((r.max_rad - r.min_rad) / r.step_rad + 1e-9));
    for (int k = 0; k <= steps; ++k) {
        const double a = r.min_rad + k * r.step_rad;
        if (brdf::arm_separation(a, cfg.detector_arm_rad) >= r.blind_zone_rad) {
            out.push_back(a);
        }
    }
    return out;
}

/// Every view's candidates: the wide view's light positions, then each zoomed placement's at
/// the positions whose highlight it sees (placement_sees_highlight).
std::vector<LightCandidate> view_candidates(const ImageCampaignConfig& cfg,
                                            const SphereGeometry& sphere,
                                            int pixel_stride) {
    std::vector<LightCandidate> out = light_candidates(
        cfg.camera, sphere, cfg.rules, cfg.layout, cfg.detector_arm_rad, cfg.lights, pixel_stride);
    if (cfg.placements.empty()) {
        return out;
    }
    const std::vector<double> lights = range_positions(cfg);
    for (int k = 1; k <= static_cast<int>(cfg.placements.size()); ++k) {
        const SphereView v = sphere_view(cfg, sphere, k);
        std::vector<double> seen;
        for (double a : lights) {
            if (placement_sees_highlight(v.camera, v.sphere, brdf::arm_direction(a))) {
                seen.push_back(a);
            }
        }
        std::vector<LightCandidate> c =
            light_candidates_at(v.camera, v.sphere, v.rules, cfg.layout, seen, pixel_stride);
        for (LightCandidate& x : c) {
            x.placement = k;
            out.push_back(std::move(x));
        }
    }
    return out;
}

/// The allowed light position closest to the detector (front lighting for the silhouette).
double front_light(const ImageCampaignConfig& cfg) {
    const LightRange& r = cfg.lights;
    double best = r.min_rad;
    double best_sep = 1e9;
    const int steps = static_cast<int>(std::floor((r.max_rad - r.min_rad) / r.step_rad + 1e-9));
    for (int k = 0; k <= steps; ++k) {
        const double a = r.min_rad + k * r.step_rad;
        const double sep = brdf::arm_separation(a, cfg.detector_arm_rad);
        if (sep >= r.blind_zone_rad && sep < best_sep) {
            best = a;
            best_sep = sep;
        }
    }
    return best;
}

/// The silhouette frame: lit from the allowed position closest to the camera and, when the arm
/// can reach it, from its mirror image on the other side of the detector; the pixel-wise maximum
/// of the two has no shadow crescent at the limb.
/// One pose in the three colour channels (capture_hdr each); the exposures each took go to
/// rec->exposures, *bracketed is set when any needed a shorter one.
Expected<std::array<HdrSamples, 3>> capture_channels(Rig& rig,
                                                     const ImageCampaignConfig& cfg,
                                                     const CaptureRequest& pose,
                                                     const std::vector<SpherePixel>& pixels,
                                                     const std::vector<std::uint8_t>& lit,
                                                     FrameRecord* rec,
                                                     bool* bracketed) {
    std::array<HdrSamples, 3> hdr;
    *bracketed = false;
    for (int ch = 0; ch < 3; ++ch) {
        CaptureRequest r = pose;
        r.channel = ch;
        auto h = capture_hdr(rig, cfg, r, pixels, lit);
        if (!h) {
            return tl::unexpected(h.error());
        }
        hdr[ch] = std::move(*h);
        rec->exposures[ch] = hdr[ch].exposures;
        *bracketed = *bracketed || hdr[ch].exposures > 1;
    }
    return hdr;
}

/// Every lit pixel unsaturated in all channels, as f_r = signal / (C_c cos(theta_i)) with its
/// variance, added to `bins` at the directions `dirs(i)` gives; the pixels left out are counted.
template <class Bins, class Directions>
void bin_pixels(const std::array<HdrSamples, 3>& hdr,
                const std::vector<std::uint8_t>& lit,
                const std::array<double, 3>& calibration,
                Directions dirs,
                Bins* bins,
                PixelCounts* counts) {
    for (std::size_t i = 0; i < lit.size(); ++i) {
        if (!lit[i]) {
            continue;
        }
        if (!hdr[0].ok[i] || !hdr[1].ok[i] || !hdr[2].ok[i]) {
            // Saturated at the shortest exposure in some channel.
            ++counts->saturated;
            continue;
        }
        const auto [wi, wo] = dirs(i);
        const double cos_i = wi.z();
        brdf::Rgbd value;
        brdf::Rgbd var;
        for (int ch = 0; ch < 3; ++ch) {
            const double k = calibration[ch] * cos_i;
            value[ch] = hdr[ch].signal[i] / k;
            var[ch] = hdr[ch].variance[i] / (k * k);
        }
        if (!value.allFinite() || !var.allFinite()) {
            // Cannot happen with cos_i >= cos(max_theta_i) > 0 and finite frames; counted.
            ++counts->nonfinite;
            continue;
        }
        bins->add(wi, wo, value, var);
        ++counts->used;
    }
}

/// A frame read back from the journal, in the result as when it was captured (its spin is 0 in an
/// isotropic campaign).
void account_journaled_frame(const ImageJournalFrame& f, ImageCampaignResult* result) {
    FrameRecord rec;
    rec.light_arm_rad = f.light_arm_rad;
    rec.spin_rad = f.spin_rad;
    rec.placement = f.placement;
    rec.counts = f.counts;
    rec.exposures = f.exposures;
    rec.coverage_after = f.coverage_after;
    result->counts += f.counts;
    result->frames.push_back(rec);
    result->bracketed = result->bracketed || f.bracketed;
    result->captures += f.captures;
    result->exposure_time_s += f.exposure_time_s;
}

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
    const brdf::Vec3d l = light_direction(light);
    PixelCounts ignored;
    const std::vector<std::uint8_t> lit = lit_pixels(pixels, l, rules, &ignored);
    std::array<double, 3> c{};
    for (int ch = 0; ch < 3; ++ch) {
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
        c[ch] = ratios[ratios.size() / 2];
        if (!(c[ch] > 0) || !std::isfinite(c[ch])) {
            return make_error(std::string("white reference, ") + kChannelName[ch] +
                              " channel: calibration constant " + std::to_string(c[ch]) +
                              " is not positive (no light, or shutter stuck closed?)");
        }
    }
    return c;
}

}  // namespace

namespace {

/// Steps 3 to 5 of an anisotropic campaign (file comment of image_campaign.h): candidate poses
/// (light arm, spin) and their predicted 4-D bins, the journal's frames merged, then frames until
/// the coverage target or the stop rules.
Expected<void> run_aniso_frames(Rig& rig,
                                const ImageCampaignConfig& cfg,
                                std::optional<ImageJournal>& journal,
                                double front,
                                const ImageProgressFn& progress,
                                const ImageStateFn& state,
                                ImageCampaignResult& result) {
    PixelCounts geometry_counts;
    const std::vector<SpherePixel> pixels =
        sphere_pixels(cfg.camera, result.sphere, cfg.rules, &geometry_counts);
    std::vector<PoseCandidate> candidates = pose_candidates(cfg.camera,
                                                            result.sphere,
                                                            cfg.rules,
                                                            cfg.aniso_layout,
                                                            cfg.detector_arm_rad,
                                                            cfg.lights,
                                                            cfg.spins,
                                                            cfg.pole_rad,
                                                            std::max(1, cfg.plan_pixel_stride));
    result.aniso_table.emplace(cfg.aniso_layout);
    result.aniso_coverage.emplace(cfg.aniso_layout);
    AnisoTable& table = *result.aniso_table;
    AnisoCoverage& coverage = *result.aniso_coverage;
    {
        AnisoCoverage reach(cfg.aniso_layout);
        for (const PoseCandidate& c : candidates) {
            for (std::uint32_t b : c.bins) {
                reach.cover(b);
            }
        }
        result.reachable_bins = reach.covered_bins();
    }
    // The candidates' isotropic bins, for naming the holes of the isotropic projection.
    std::vector<LightCandidate> projected;
    for (const PoseCandidate& c : candidates) {
        LightCandidate p;
        p.light_arm_rad = c.light_arm_rad;
        for (std::uint32_t b : c.bins) {
            p.bins.push_back(static_cast<std::uint32_t>(cfg.aniso_layout.iso_bin(b)));
        }
        std::sort(p.bins.begin(), p.bins.end());
        p.bins.erase(std::unique(p.bins.begin(), p.bins.end()), p.bins.end());
        projected.push_back(std::move(p));
    }
    double current_light = front;
    double current_spin = 0;
    if (journal) {
        for (const ImageJournalFrame& f : journal->frames()) {
            for (const AnisoBinAggregate& a : f.aniso_bins) {
                table.merge(a);
            }
            account_journaled_frame(f, &result);
            candidates.erase(std::remove_if(candidates.begin(),
                                            candidates.end(),
                                            [&](const PoseCandidate& c) {
                                                return std::abs(c.light_arm_rad - f.light_arm_rad) <
                                                           1e-9 &&
                                                       std::abs(c.spin_rad - f.spin_rad) < 1e-9;
                                            }),
                             candidates.end());
            current_light = f.light_arm_rad;
            current_spin = f.spin_rad;
        }
        result.resumed_frames = journal->frames().size();
        coverage.cover_from(table, cfg.min_count);
    }
    result.coverage = coverage.isotropic();
    std::vector<std::size_t> gains(candidates.size());
    for (std::size_t k = 0; k < candidates.size(); ++k) {
        gains[k] = coverage.gain(candidates[k].bins);
    }
    const std::size_t min_gain =
        std::max<std::size_t>(1,
                              static_cast<std::size_t>(cfg.min_gain_fraction *
                                                       static_cast<double>(coverage.valid_bins())));
    result.stop_reason = "frame limit";
    if (state) {
        state(result);
    }
    while (static_cast<int>(result.frames.size()) < cfg.max_frames) {
        if (coverage.fraction() >= cfg.coverage_target) {
            result.stop_reason = "coverage target met";
            break;
        }
        const int next =
            next_pose(candidates, gains, current_light, current_spin, cfg.light_gain_fraction);
        if (next < 0 || gains[static_cast<std::size_t>(next)] < min_gain) {
            result.stop_reason = "no pose adds enough bins";
            break;
        }
        const double a = candidates[static_cast<std::size_t>(next)].light_arm_rad;
        const double spin = candidates[static_cast<std::size_t>(next)].spin_rad;
        candidates.erase(candidates.begin() + next);
        gains.erase(gains.begin() + next);
        current_light = a;
        current_spin = spin;
        rig.set_pose(a, spin);
        const std::uint64_t captures_before = result.captures;
        const double exposure_before = result.exposure_time_s;
        FrameRecord rec;
        rec.light_arm_rad = a;
        rec.spin_rad = spin;
        rec.counts = geometry_counts;
        const brdf::Vec3d l = light_direction(a);
        std::vector<std::uint8_t> lit = lit_pixels(pixels, l, cfg.rules, &rec.counts);
        const brdf::Vec3d axis = lathe_axis_world(0, spin);
        std::vector<brdf::Vec3d> tangents(pixels.size(), brdf::Vec3d::Zero());
        for (std::size_t i = 0; i < pixels.size(); ++i) {
            if (!lit[i]) {
                continue;
            }
            tangents[i] = lathe_tangent(pixels[i].normal, axis, cfg.pole_rad);
            if (tangents[i] == brdf::Vec3d::Zero()) {
                // Within a pole cap of the turned sphere: the tangent is not known well enough.
                ++rec.counts.pole;
                lit[i] = 0;
            }
        }
        CaptureRequest pose;
        pose.light_arm_rad = a;
        pose.spin_rad = spin;
        bool bracketed = false;
        auto hdr = capture_channels(rig, cfg, pose, pixels, lit, &rec, &bracketed);
        if (!hdr) {
            return tl::unexpected(hdr.error());
        }
        AnisoFrameBins frame_bins(cfg.aniso_layout);
        bin_pixels(
            *hdr,
            lit,
            result.calibration,
            [&](std::size_t i) { return local_directions(pixels[i], tangents[i], l); },
            &frame_bins,
            &rec.counts);
        ImageJournalFrame jf;
        jf.anisotropic = true;
        jf.light_arm_rad = a;
        jf.spin_rad = spin;
        jf.exposures = rec.exposures;
        jf.counts = rec.counts;
        jf.bracketed = bracketed;
        jf.captures = result.captures - captures_before;
        jf.exposure_time_s = result.exposure_time_s - exposure_before;
        jf.aniso_bins = frame_bins.aggregates();
        for (const AnisoBinAggregate& b : jf.aniso_bins) {
            table.merge(b);
            if (table.count(b.bin) >= std::max<std::uint32_t>(cfg.min_count, 1)) {
                coverage.cover(b.bin);
            }
        }
        for (std::size_t k = 0; k < candidates.size(); ++k) {
            gains[k] = coverage.gain(candidates[k].bins);
        }
        result.bracketed = result.bracketed || bracketed;
        rec.coverage_after = coverage.fraction();
        jf.coverage_after = rec.coverage_after;
        if (journal) {
            // Durable before the arms move on.
            if (auto w = journal->append_frame(jf); !w) {
                return tl::unexpected(w.error());
            }
        }
        result.counts += rec.counts;
        result.frames.push_back(rec);
        result.coverage = coverage.isotropic();
        if (progress) {
            progress(result.frames.size() - 1, rec);
        }
        if (state) {
            state(result);
        }
    }
    result.target_met = coverage.fraction() >= cfg.coverage_target;
    if (result.target_met) {
        result.stop_reason = "coverage target met";
    }
    result.holes = coverage_holes(result.coverage, projected, hole_limits(cfg));
    return {};
}

}  // namespace

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
    Rig rig(capture, cfg, &result);
    const double front = front_light(cfg);
    rig.set_light(front);

    std::optional<ImageJournal> journal;
    if (!journal_path.empty()) {
        auto j = ImageJournal::open(journal_path);
        if (!j) {
            return tl::unexpected(j.error());
        }
        journal.emplace(std::move(*j));
    }
    if (journal && journal->setup()) {
        // Resume: the set-up as recorded (no reference or silhouette captures).
        const ImageJournalSetup& s = *journal->setup();
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
                              " deg; this configuration asks for " + std::to_string(l.n_theta_h) +
                              "x" + std::to_string(l.n_theta_d) + "x" + std::to_string(l.n_phi_d) +
                              " at " + std::to_string(cfg.detector_arm_rad * 180 / brdf::kPi) +
                              " deg (resume with the campaign's own settings)");
        }
        result.calibration = s.calibration;
        result.sphere = s.sphere;
        result.reference_sphere = s.reference_sphere;
        result.captures = s.captures;
        result.exposure_time_s = s.exposure_time_s;
    } else {
        // 1. White reference: calibration constants per channel.
        auto cal = calibrate(rig, cfg, front, &result.reference_sphere);
        if (!cal) {
            return tl::unexpected(cal.error());
        }
        result.calibration = *cal;

        // 2. The sample sphere.
        auto sphere = find_sphere(rig, cfg, front, false);
        if (!sphere) {
            return tl::unexpected(sphere.error());
        }
        result.sphere = *sphere;
        if (journal) {
            ImageJournalSetup s;
            s.layout = cfg.layout;
            s.detector_arm_rad = cfg.detector_arm_rad;
            s.calibration = result.calibration;
            s.sphere = result.sphere;
            s.reference_sphere = result.reference_sphere;
            s.captures = result.captures;
            s.exposure_time_s = result.exposure_time_s;
            s.anisotropic = cfg.anisotropic;
            s.aniso_layout = cfg.aniso_layout;
            if (auto a = journal->append_setup(s); !a) {
                return tl::unexpected(a.error());
            }
        }
    }
    if (cfg.anisotropic) {
        if (!cfg.aniso_layout.sane() || !(cfg.spins.step_rad > 0) ||
            !(cfg.spins.max_rad >= cfg.spins.min_rad)) {
            return make_error("image campaign: the 4-D table " + cfg.aniso_layout.describe() +
                              " needs 1..720 bins per axis and the spin range a step > 0");
        }
        if (auto a = run_aniso_frames(rig, cfg, journal, front, progress, state, result); !a) {
            return tl::unexpected(a.error());
        }
        return result;
    }
    // The pixels of the view in use (the wide view first; a zoomed placement's when a frame
    // needs it).
    int view_placement = 0;
    PixelCounts geometry_counts;
    std::vector<SpherePixel> pixels =
        sphere_pixels(cfg.camera, result.sphere, cfg.rules, &geometry_counts);
    ExclusionRules view_rules = cfg.rules;

    // 3. Candidate light positions (and placements) and their predicted bins.
    std::vector<LightCandidate> candidates =
        view_candidates(cfg, result.sphere, std::max(1, cfg.plan_pixel_stride));
    {
        CoverageMap reach(cfg.layout);
        for (const LightCandidate& c : candidates) {
            for (std::uint32_t b : c.bins) {
                reach.cover(b);
            }
        }
        result.reachable_bins = reach.covered_bins();
    }
    const std::vector<LightCandidate> all_candidates = candidates;

    // 4. Frames already journaled: merged, their light positions taken off the candidates.
    double current = front;
    bool zoom_phase = false;
    if (journal) {
        for (const ImageJournalFrame& f : journal->frames()) {
            if (f.placement > 0) {
                // The placement must be the one the configuration has under that number.
                const std::size_t k = static_cast<std::size_t>(f.placement);
                if (k > cfg.placements.size() ||
                    std::abs(cfg.placements[k - 1].magnification - f.magnification) > 1e-9 ||
                    std::abs(cfg.placements[k - 1].offset_m[0] - f.offset_m[0]) > 1e-12 ||
                    std::abs(cfg.placements[k - 1].offset_m[1] - f.offset_m[1]) > 1e-12) {
                    return make_error(journal_path + ": a frame of zoomed placement " +
                                      std::to_string(f.placement) + " (magnification " +
                                      std::to_string(f.magnification) +
                                      ") that the rig description does not have (resume with "
                                      "the campaign's own rig)");
                }
            }
            for (const BinAggregate& a : f.bins) {
                result.table.merge(a);
            }
            account_journaled_frame(f, &result);
            zoom_phase = zoom_phase || f.placement > 0;
            candidates.erase(std::remove_if(candidates.begin(),
                                            candidates.end(),
                                            [&](const LightCandidate& c) {
                                                return std::abs(c.light_arm_rad - f.light_arm_rad) <
                                                           1e-9 &&
                                                       c.placement == f.placement;
                                            }),
                             candidates.end());
            current = f.light_arm_rad;
        }
        result.resumed_frames = journal->frames().size();
        result.coverage.cover_from(result.table, cfg.min_count);
    }

    // 5. Frames until the coverage target.
    std::vector<std::size_t> gains = candidate_gains(candidates, result.coverage);
    result.stop_reason = "frame limit";
    if (state) {
        state(result);
    }
    while (static_cast<int>(result.frames.size()) < cfg.max_frames) {
        const int next = next_campaign_light(
            cfg, candidates, gains, result.coverage, current, &zoom_phase, &result.stop_reason);
        if (next < 0) {
            break;
        }
        const double a = candidates[next].light_arm_rad;
        const int placement = candidates[next].placement;
        candidates.erase(candidates.begin() + next);
        gains.erase(gains.begin() + next);
        current = a;
        rig.set_light(a, placement);
        if (placement != view_placement) {
            const SphereView v = sphere_view(cfg, result.sphere, placement);
            geometry_counts = PixelCounts{};
            pixels = sphere_pixels(v.camera, v.sphere, v.rules, &geometry_counts);
            view_rules = v.rules;
            view_placement = placement;
        }
        const std::uint64_t captures_before = result.captures;
        const double exposure_before = result.exposure_time_s;
        FrameRecord rec;
        rec.light_arm_rad = a;
        rec.placement = placement;
        rec.counts = geometry_counts;
        const brdf::Vec3d l = light_direction(a);
        const std::vector<std::uint8_t> lit = lit_pixels(pixels, l, view_rules, &rec.counts);
        CaptureRequest pose;
        pose.light_arm_rad = a;
        pose.placement = placement;
        bool bracketed = false;
        auto hdr = capture_channels(rig, cfg, pose, pixels, lit, &rec, &bracketed);
        if (!hdr) {
            return tl::unexpected(hdr.error());
        }
        FrameBins frame_bins(cfg.layout);
        bin_pixels(
            *hdr,
            lit,
            result.calibration,
            [&](std::size_t i) { return local_directions(pixels[i], l); },
            &frame_bins,
            &rec.counts);
        ImageJournalFrame jf;
        jf.light_arm_rad = a;
        if (placement > 0) {
            const Placement& p = cfg.placements[static_cast<std::size_t>(placement - 1)];
            jf.placement = placement;
            jf.magnification = p.magnification;
            jf.offset_m = p.offset_m;
        }
        jf.exposures = rec.exposures;
        jf.counts = rec.counts;
        jf.bracketed = bracketed;
        jf.captures = result.captures - captures_before;
        jf.exposure_time_s = result.exposure_time_s - exposure_before;
        jf.bins = frame_bins.aggregates();
        int rows_lo = cfg.layout.n_theta_d;
        int rows_hi = -1;
        for (const BinAggregate& b : jf.bins) {
            result.table.merge(b);
            if (result.table.count(b.bin) >= std::max<std::uint32_t>(cfg.min_count, 1)) {
                result.coverage.cover(b.bin);
            }
            const int i_d = cfg.layout.unflatten(b.bin)[1];
            rows_lo = std::min(rows_lo, i_d);
            rows_hi = std::max(rows_hi, i_d);
        }
        update_gains(candidates, result.coverage, rows_lo, rows_hi, &gains);
        result.bracketed = result.bracketed || bracketed;
        rec.coverage_after = result.coverage.fraction();
        jf.coverage_after = rec.coverage_after;
        if (journal) {
            // Durable before the light arm moves on.
            if (auto w = journal->append_frame(jf); !w) {
                return tl::unexpected(w.error());
            }
        }
        result.counts += rec.counts;
        result.frames.push_back(rec);
        if (progress) {
            progress(result.frames.size() - 1, rec);
        }
        if (state) {
            state(result);
        }
    }
    result.target_met = result.coverage.fraction() >= cfg.coverage_target;
    if (result.target_met) {
        result.stop_reason = "coverage target met";
    }
    result.holes = coverage_holes(result.coverage, all_candidates, hole_limits(cfg));
    return result;
}

namespace {

/// predict_image_coverage() of an anisotropic campaign: the poses run_aniso_frames would choose.
void predict_aniso(const ImageCampaignConfig& cfg,
                   const SphereGeometry& sphere,
                   ImageCoveragePrediction* p) {
    std::vector<PoseCandidate> candidates = pose_candidates(cfg.camera,
                                                            sphere,
                                                            cfg.rules,
                                                            cfg.aniso_layout,
                                                            cfg.detector_arm_rad,
                                                            cfg.lights,
                                                            cfg.spins,
                                                            cfg.pole_rad,
                                                            std::max(1, cfg.plan_pixel_stride));
    p->candidates = candidates.size();
    AnisoCoverage coverage(cfg.aniso_layout);
    p->valid_bins = coverage.valid_bins();
    std::vector<LightCandidate> projected;
    {
        AnisoCoverage reach(cfg.aniso_layout);
        for (const PoseCandidate& c : candidates) {
            LightCandidate lc;
            lc.light_arm_rad = c.light_arm_rad;
            for (std::uint32_t b : c.bins) {
                reach.cover(b);
                lc.bins.push_back(static_cast<std::uint32_t>(cfg.aniso_layout.iso_bin(b)));
            }
            std::sort(lc.bins.begin(), lc.bins.end());
            lc.bins.erase(std::unique(lc.bins.begin(), lc.bins.end()), lc.bins.end());
            projected.push_back(std::move(lc));
        }
        p->reachable_bins = reach.covered_bins();
    }
    std::vector<std::size_t> gains(candidates.size());
    for (std::size_t k = 0; k < candidates.size(); ++k) {
        gains[k] = coverage.gain(candidates[k].bins);
    }
    const std::size_t min_gain =
        std::max<std::size_t>(1,
                              static_cast<std::size_t>(cfg.min_gain_fraction *
                                                       static_cast<double>(coverage.valid_bins())));
    double light = front_light(cfg);
    double spin = 0;
    p->stop_reason = "frame limit";
    while (static_cast<int>(p->light_arm_rad.size()) < cfg.max_frames) {
        if (coverage.fraction() >= cfg.coverage_target) {
            p->stop_reason = "coverage target met";
            break;
        }
        const int next = next_pose(candidates, gains, light, spin, cfg.light_gain_fraction);
        if (next < 0 || gains[static_cast<std::size_t>(next)] < min_gain) {
            p->stop_reason = "no pose adds enough bins";
            break;
        }
        const PoseCandidate chosen = candidates[static_cast<std::size_t>(next)];
        candidates.erase(candidates.begin() + next);
        gains.erase(gains.begin() + next);
        p->light_travel_rad += std::abs(chosen.light_arm_rad - light);
        p->spin_travel_rad += std::abs(chosen.spin_rad - spin);
        light = chosen.light_arm_rad;
        spin = chosen.spin_rad;
        for (std::uint32_t b : chosen.bins) {
            coverage.cover(b);
        }
        for (std::size_t k = 0; k < candidates.size(); ++k) {
            gains[k] = coverage.gain(candidates[k].bins);
        }
        p->light_arm_rad.push_back(light);
        p->spin_rad.push_back(spin);
        p->predicted_coverage.push_back(coverage.fraction());
    }
    p->target_met = coverage.fraction() >= cfg.coverage_target;
    if (p->target_met) {
        p->stop_reason = "coverage target met";
    }
    p->covered_bins = coverage.covered_bins();
    p->holes = coverage_holes(coverage.isotropic(), projected, hole_limits(cfg));
}

}  // namespace

Expected<ImageCoveragePrediction> predict_image_coverage(const ImageCampaignConfig& cfg) {
    if (!(cfg.silhouette.radius_m > 0) || !(cfg.lights.step_rad > 0)) {
        return make_error(
            "image coverage prediction: the sphere radius and lights.step_rad must "
            "be > 0");
    }
    // The nominal sample sphere at the rig origin.
    SphereGeometry sphere;
    sphere.radius_m = cfg.silhouette.radius_m;
    const Eigen::Vector2d c_px = cfg.camera.project(sphere.centre);
    if (!c_px.allFinite()) {
        return make_error("image coverage prediction: the camera does not see the rig origin");
    }
    sphere.silhouette.cx = c_px.x();
    sphere.silhouette.cy = c_px.y();
    if (cfg.camera.projection == Projection::kOrthographic) {
        sphere.silhouette.r = sphere.radius_m * cfg.camera.intrinsics.fx;
    } else {
        // The outline of a sphere at distance d subtends asin(R / d) from the camera centre.
        const double d = (sphere.centre - cfg.camera.centre_world()).norm();
        if (!(d > sphere.radius_m)) {
            return make_error("image coverage prediction: the camera is inside the sphere");
        }
        sphere.silhouette.r = cfg.camera.intrinsics.fx * std::tan(std::asin(sphere.radius_m / d));
    }
    ImageCoveragePrediction p;
    PixelCounts counts;
    p.sphere_pixels = sphere_pixels(cfg.camera, sphere, cfg.rules, &counts).size();
    if (cfg.anisotropic) {
        predict_aniso(cfg, sphere, &p);
        return p;
    }
    // Every pixel (the campaign bins every pixel of a frame, whatever the stride it plans with).
    std::vector<LightCandidate> candidates = view_candidates(cfg, sphere, 1);
    const std::vector<LightCandidate> all_candidates = candidates;
    p.candidates = candidates.size();
    p.candidates_zoomed = static_cast<std::size_t>(
        std::count_if(candidates.begin(), candidates.end(), [](const LightCandidate& c) {
            return c.placement != 0;
        }));
    CoverageMap coverage(cfg.layout);
    p.valid_bins = coverage.valid_bins();
    {
        CoverageMap reach(cfg.layout);
        for (const LightCandidate& c : candidates) {
            for (std::uint32_t b : c.bins) {
                reach.cover(b);
            }
        }
        p.reachable_bins = reach.covered_bins();
    }
    // The campaign's choice of light positions (run_image_campaign, step 5).
    std::vector<std::size_t> gains = candidate_gains(candidates, coverage);
    double current = front_light(cfg);
    bool zoom_phase = false;
    p.stop_reason = "frame limit";
    while (static_cast<int>(p.light_arm_rad.size()) < cfg.max_frames) {
        const int next = next_campaign_light(
            cfg, candidates, gains, coverage, current, &zoom_phase, &p.stop_reason);
        if (next < 0) {
            break;
        }
        const LightCandidate chosen = candidates[next];
        candidates.erase(candidates.begin() + next);
        gains.erase(gains.begin() + next);
        p.light_travel_rad += std::abs(chosen.light_arm_rad - current);
        current = chosen.light_arm_rad;
        for (std::uint32_t b : chosen.bins) {
            coverage.cover(b);
        }
        update_gains(candidates, coverage, chosen.theta_d_lo, chosen.theta_d_hi, &gains);
        p.light_arm_rad.push_back(current);
        p.placement.push_back(chosen.placement);
        p.zoomed_frames += chosen.placement != 0 ? 1 : 0;
        p.predicted_coverage.push_back(coverage.fraction());
    }
    p.target_met = coverage.fraction() >= cfg.coverage_target;
    if (p.target_met) {
        p.stop_reason = "coverage target met";
    }
    p.covered_bins = coverage.covered_bins();
    p.holes = coverage_holes(coverage, all_candidates, hole_limits(cfg));
    return p;
}

Expected<void> write_image_campaign(const std::string& dir,
                                    const ImageCampaignResult& result,
                                    const ImageCampaignConfig& config,
                                    const std::string& extra_json) {
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    if (ec) {
        return make_error(dir + ": cannot create directory: " + ec.message());
    }
    const std::string base = (std::filesystem::path(dir) / "").string();
    const bool aniso = result.aniso_table.has_value() && result.aniso_coverage.has_value();
    const brdf::Dataset data =
        aniso ? result.aniso_table->to_dataset(
                    "anisotropic image-mode campaign", config.min_count, result.bracketed)
              : result.table.to_dataset("image-mode campaign", config.min_count, result.bracketed);
    if (auto r = brdf::write_dataset_csv(base + "dataset.csv", data); !r) {
        return r;
    }
    const TableLayout& l = aniso ? result.aniso_table->layout().iso() : config.layout;
    const bool merl = l.n_theta_h == 90 && l.n_theta_d == 90 && l.n_phi_d == 180;
    // The isotropic half/difference table has no place for phi_h: an anisotropic campaign writes
    // its 4-D bins as the dataset only.
    const std::string table_name = aniso ? "" : merl ? "table.binary" : "table.gtab";
    if (!aniso) {
        if (auto r = brdf::write_merl(
                base + table_name,
                to_tabulated(result.table, config.min_count, "image-mode campaign"));
            !r) {
            return r;
        }
    }
    if (auto r = write_coverage_png(
            base + "coverage.png",
            aniso ? result.aniso_coverage->cells() : coverage_cells(result.table, config.min_count),
            l);
        !r) {
        return r;
    }
    nlohmann::json j;
    j["mode"] = "image";
    j["camera_model"] = nlohmann::json::parse(camera_model_to_json(config.camera));
    j["sphere"] = {
        {"centre_m",
         {result.sphere.centre.x(), result.sphere.centre.y(), result.sphere.centre.z()}},
        {"radius_m", result.sphere.radius_m},
        {"silhouette_px",
         {result.sphere.silhouette.cx, result.sphere.silhouette.cy, result.sphere.silhouette.r}},
        {"fit_rms_px", result.sphere.rms_residual_px}};
    j["calibration_counts_per_us_per_inv_sr"] = result.calibration;
    j["reference_albedo"] = config.reference_albedo;
    if (aniso) {
        const AnisoLayout& a = result.aniso_table->layout();
        j["anisotropic"] = true;
        j["sample_shape"] =
            "turned sphere: tangent along the circles of latitude about the lathe axis, mounted "
            "along the holder's y axis";
        j["table"] = {{"n_theta_h", a.n_theta_h},
                      {"n_phi_h", a.n_phi_h},
                      {"n_theta_d", a.n_theta_d},
                      {"n_phi_d", a.n_phi_d},
                      {"frame", "material (normal and tangent)"},
                      {"file", nullptr}};
        j["pole_cap_deg"] = config.pole_rad * 180 / brdf::kPi;
    } else {
        j["table"] = {{"n_theta_h", l.n_theta_h},
                      {"n_theta_d", l.n_theta_d},
                      {"n_phi_d", l.n_phi_d},
                      {"file", table_name}};
    }
    j["coverage"] = {{"target", config.coverage_target},
                     {"achieved", result.coverage_fraction()},
                     {"target_met", result.target_met},
                     {"stop_reason", result.stop_reason},
                     {"valid_bins", result.valid_bins()},
                     {"covered_bins", result.covered_bins()},
                     {"reachable_bins", result.reachable_bins}};
    const PixelCounts& c = result.counts;
    j["pixels"] = {{"on_sphere", c.on_sphere},
                   {"edge", c.edge},
                   {"grazing_view", c.grazing_view},
                   {"shadow", c.shadow},
                   {"grazing_light", c.grazing_light},
                   {"saturated", c.saturated},
                   {"nonfinite", c.nonfinite},
                   {"pole", c.pole},
                   {"used", c.used}};
    nlohmann::json frames = nlohmann::json::array();
    for (const FrameRecord& f : result.frames) {
        nlohmann::json fj = {{"light_arm_deg", f.light_arm_rad * 180 / brdf::kPi},
                             {"used_pixels", f.counts.used},
                             {"saturated_pixels", f.counts.saturated},
                             {"exposures", f.exposures},
                             {"coverage_after", f.coverage_after}};
        if (aniso) {
            fj["spin_deg"] = f.spin_rad * 180 / brdf::kPi;
        }
        if (f.placement > 0) {
            fj["placement"] = config.placements[static_cast<std::size_t>(f.placement - 1)].name;
        }
        frames.push_back(fj);
    }
    j["frames"] = frames;
    if (!config.placements.empty()) {
        nlohmann::json placements = nlohmann::json::array();
        for (const Placement& p : config.placements) {
            placements.push_back({{"name", p.name},
                                  {"magnification", p.magnification},
                                  {"offset_m", {p.offset_m[0], p.offset_m[1]}}});
        }
        j["placements"] = placements;
    }
    nlohmann::json holes = nlohmann::json::array();
    for (const CoverageHole& h : result.holes) {
        holes.push_back(
            {{"theta_d_deg", {h.theta_d_min * 180 / brdf::kPi, h.theta_d_max * 180 / brdf::kPi}},
             {"theta_h_deg", {h.theta_h_min * 180 / brdf::kPi, h.theta_h_max * 180 / brdf::kPi}},
             {"bins", h.bins},
             {"reason", h.reason}});
    }
    j["holes"] = holes;
    j["captures"] = result.captures;
    j["exposure_time_s"] = result.exposure_time_s;
    try {
        const nlohmann::json extra = nlohmann::json::parse(extra_json);
        if (extra.is_object()) {
            j.update(extra);
        }
    } catch (const nlohmann::json::exception& e) {
        return make_error(std::string("dataset.json extra metadata: ") + json_error_text(e.what()));
    }
    const std::string path = base + "dataset.json";
    return write_file_atomic(path, j.dump(2) + "\n");
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

namespace {

struct ArmCheck {
    devices::Axis* axis = nullptr;
    double target_deg = 0;
};

std::string format_deg(double v) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.4f", v);
    return buf;
}

}  // namespace

CaptureFn make_device_capture(devices::Camera& camera,
                              devices::Light& light,
                              devices::Axis& light_arm,
                              std::function<Expected<void>(int)> select_filter,
                              std::function<Expected<void>(bool)> swap_target,
                              const DeviceCaptureOptions& options) {
    struct State {
        bool have_light = false;
        double light_deg = 0;
        bool have_detector = false;
        bool have_spin = false;
        double spin_deg = 0;
        int filter = -1;
        int target = -1;  // 1 reference, 0 sample
        int placement = -1;
        double exposure_us = -1;
        int shutter = -1;
    };
    auto state = std::make_shared<State>();
    const DeviceCaptureOptions o = options;
    return [&camera, &light, &light_arm, select_filter, swap_target, o, state](
               const CaptureRequest& r) -> Expected<devices::Frame> {
        const int target = r.reference ? 1 : 0;
        if (swap_target && state->target != target) {
            if (auto s = swap_target(r.reference); !s) {
                return tl::unexpected(s.error());
            }
            state->target = target;
        }
        const double deg = r.light_arm_rad * 180 / brdf::kPi;
        std::vector<ArmCheck> arms{{&light_arm, deg}};
        if (o.detector_arm != nullptr) {
            arms.push_back({o.detector_arm, o.detector_arm_rad * 180 / brdf::kPi});
        }
        const double spin_deg = r.spin_rad * 180 / brdf::kPi;
        std::size_t spin_index = arms.size();
        if (o.spin != nullptr) {
            arms.push_back({o.spin, spin_deg});
        } else if (r.spin_rad != 0) {
            return make_error(describe(r) + ": the rig gives this capture no spin axis");
        }
        if (state->placement != r.placement) {
            if (o.select_placement) {
                if (auto p = o.select_placement(r.placement); !p) {
                    return make_error(describe(r) + ": " + p.error().message);
                }
            } else if (r.placement != 0) {
                return make_error(describe(r) + ": the rig has no zoomed camera placement");
            }
            state->placement = r.placement;
        }
        if (select_filter && state->filter != r.channel) {
            if (auto f = select_filter(r.channel); !f) {
                return tl::unexpected(f.error());
            }
            state->filter = r.channel;
        }
        const int shutter = r.shutter_open ? 1 : 0;
        if (state->shutter != shutter) {
            if (auto s = light.set_shutter_open(r.shutter_open); !s) {
                return tl::unexpected(s.error());
            }
            state->shutter = shutter;
        }
        if (state->exposure_us != r.exposure_us) {
            if (auto e = camera.set_exposure_us(r.exposure_us); !e) {
                return tl::unexpected(e.error());
            }
            state->exposure_us = r.exposure_us;
        }
        auto note = [&](const std::string& text, bool repeat) {
            if (o.log != nullptr) {
                (repeat ? o.log->repeats : o.log->corrections) += 1;
                o.log->notes.push_back(text);
            }
        };
        auto read_back = [&](std::vector<double>* out) -> Expected<void> {
            out->clear();
            for (const ArmCheck& a : arms) {
                auto p = a.axis->position_deg();
                if (!p) {
                    return tl::unexpected(p.error());
                }
                out->push_back(*p);
            }
            return {};
        };
        std::vector<double> before;
        std::vector<double> after;
        int failures = 0;
        // Moves: the light arm when its target changed, the detector arm on the first capture;
        // then whichever arm a pose check found away from its target.
        std::vector<bool> move(arms.size(), false);
        move[0] = !state->have_light || std::abs(state->light_deg - deg) > 1e-9;
        if (o.detector_arm != nullptr) {
            move[1] = !state->have_detector;
        }
        if (spin_index < arms.size()) {
            move[spin_index] = !state->have_spin || std::abs(state->spin_deg - spin_deg) > 1e-9;
        }
        for (int attempt = 0;; ++attempt) {
            bool moved_any = false;
            for (std::size_t k = 0; k < arms.size(); ++k) {
                if (!move[k]) {
                    continue;
                }
                if (auto m = arms[k].axis->move_to(arms[k].target_deg, o.move_timeout); !m) {
                    return tl::unexpected(m.error());
                }
                move[k] = false;
                moved_any = true;
            }
            if (moved_any && o.settle.count() > 0) {
                std::this_thread::sleep_for(o.settle);
            }
            state->have_light = true;
            state->light_deg = deg;
            state->have_detector = true;
            state->have_spin = true;
            state->spin_deg = spin_deg;
            if (auto b = read_back(&before); !b) {
                return tl::unexpected(b.error());
            }
            std::string off;
            for (std::size_t k = 0; k < arms.size(); ++k) {
                if (std::abs(before[k] - arms[k].target_deg) > o.pose_tolerance_deg) {
                    off += (off.empty() ? "" : ", ") + arms[k].axis->name() + " at " +
                           format_deg(before[k]) + " deg, target " +
                           format_deg(arms[k].target_deg) + " deg";
                    move[k] = true;
                }
            }
            if (!off.empty()) {
                if (attempt >= o.max_pose_repeats) {
                    return make_error("pose check: the arms do not stay on target for the " +
                                      describe(r) + " (" + off + ") after " +
                                      std::to_string(attempt) + " corrections");
                }
                note("pose check: before the " + describe(r) + " " + off + "; moved back", false);
                continue;
            }
            // Each retry after a camera error waits twice as long: a frame that came late once
            // (the camera busy, the host loaded) is set aside when it arrives (its stamp precedes
            // the new trigger), and the new trigger's frame queues behind it.
            const auto timeout =
                (o.capture_timeout +
                 std::chrono::milliseconds(static_cast<std::int64_t>(r.exposure_us / 1000))) *
                (1 << std::min(failures, 4));
            auto frame = camera.capture(timeout);
            if (!frame) {
                if (failures >= o.capture_retries) {
                    return frame;
                }
                ++failures;
                if (o.log != nullptr) {
                    ++o.log->capture_retries;
                    o.log->notes.push_back("camera error at the " + describe(r) + " (" +
                                           frame.error().message + "); captured again");
                }
                --attempt;  // Not a pose problem.
                continue;
            }
            if (auto a = read_back(&after); !a) {
                return tl::unexpected(a.error());
            }
            std::string moved;
            for (std::size_t k = 0; k < arms.size(); ++k) {
                if (std::abs(after[k] - before[k]) > o.pose_tolerance_deg) {
                    moved += (moved.empty() ? "" : ", ") + arms[k].axis->name() + " " +
                             format_deg(before[k]) + " -> " + format_deg(after[k]) + " deg";
                    move[k] = true;
                }
            }
            if (!moved.empty()) {
                if (attempt >= o.max_pose_repeats) {
                    return make_error("pose check: the arms keep moving during the " + describe(r) +
                                      " (" + moved + ") after " + std::to_string(attempt) +
                                      " repeats");
                }
                note("pose check: an arm moved during the " + describe(r) + " (" + moved +
                         "); the capture is repeated",
                     true);
                continue;
            }
            return frame;
        }
    };
}

CaptureFn make_device_capture(devices::Camera& camera,
                              devices::Light& light,
                              devices::Axis& light_arm,
                              std::function<Expected<void>(int)> select_filter,
                              std::function<Expected<void>(bool)> swap_target,
                              std::chrono::milliseconds move_timeout) {
    DeviceCaptureOptions o;
    o.move_timeout = move_timeout;
    return make_device_capture(
        camera, light, light_arm, std::move(select_filter), std::move(swap_target), o);
}

}  // namespace gonio::acquisition
