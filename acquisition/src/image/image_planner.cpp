#include "gonio/acquisition/image/image_planner.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string_view>
#include <vector>

#include "gonio/base/atomic_file.h"
#include "gonio/base/check.h"
#include "gonio/brdf/rig_geometry.h"

namespace gonio::acquisition {

std::vector<LightCandidate> light_candidates(const CameraModel& camera,
                                             const SphereGeometry& sphere,
                                             const ExclusionRules& rules,
                                             const TableLayout& layout,
                                             double detector_arm_rad,
                                             const LightRange& range,
                                             int pixel_stride) {
    GONIO_CHECK(range.step_rad > 0 && pixel_stride >= 1);
    std::vector<double> lights;
    const int steps =
        static_cast<int>(std::floor((range.max_rad - range.min_rad) / range.step_rad + 1e-9));
    for (int k = 0; k <= steps; ++k) {
        const double a = range.min_rad + k * range.step_rad;
        if (brdf::arm_separation(a, detector_arm_rad) < range.blind_zone_rad) {
            // Inside the blind zone around the detector.
            continue;
        }
        lights.push_back(a);
    }
    return light_candidates_at(camera, sphere, rules, layout, lights, pixel_stride);
}

std::vector<LightCandidate> light_candidates_at(const CameraModel& camera,
                                                const SphereGeometry& sphere,
                                                const ExclusionRules& rules,
                                                const TableLayout& layout,
                                                const std::vector<double>& light_arm_rad,
                                                int pixel_stride) {
    GONIO_CHECK(pixel_stride >= 1);
    std::vector<SpherePixel> pixels = sphere_pixels(camera, sphere, rules, nullptr);
    if (pixel_stride > 1) {
        pixels.erase(std::remove_if(pixels.begin(),
                                    pixels.end(),
                                    [&](const SpherePixel& p) {
                                        return p.x % pixel_stride != 0 || p.y % pixel_stride != 0;
                                    }),
                     pixels.end());
    }
    const double cos_max_i = std::cos(rules.max_theta_i);
    std::vector<LightCandidate> out;
    for (const double a : light_arm_rad) {
        const brdf::Vec3d l(std::cos(a), std::sin(a), 0);
        LightCandidate c;
        c.light_arm_rad = a;
        for (const SpherePixel& p : pixels) {
            const auto [wi, wo] = local_directions(p, l);
            if (wi.z() < cos_max_i) {
                // Shadowed or grazing light: no sample from this pixel.
                continue;
            }
            const brdf::HalfDiff<double> hd = brdf::to_half_diff(wi, wo);
            const std::size_t b = bin_index(layout, hd.theta_h, hd.theta_d, hd.phi_d);
            if (bin_valid(layout, b)) {
                c.bins.push_back(static_cast<std::uint32_t>(b));
            }
        }
        std::sort(c.bins.begin(), c.bins.end());
        c.bins.erase(std::unique(c.bins.begin(), c.bins.end()), c.bins.end());
        c.theta_d_lo = layout.n_theta_d;
        c.theta_d_hi = -1;
        for (std::uint32_t b : c.bins) {
            const int i_d = layout.unflatten(b)[1];
            c.theta_d_lo = std::min(c.theta_d_lo, i_d);
            c.theta_d_hi = std::max(c.theta_d_hi, i_d);
        }
        if (!c.bins.empty()) {
            out.push_back(std::move(c));
        }
    }
    return out;
}

CoverageMap::CoverageMap(const TableLayout& layout)
    : layout_(layout), valid_(layout.size(), 0), covered_(layout.size(), 0) {
    for (std::size_t b = 0; b < layout.size(); ++b) {
        valid_[b] = bin_valid(layout, b) ? 1 : 0;
        valid_count_ += valid_[b];
    }
}

double CoverageMap::fraction() const {
    if (valid_count_ == 0) {
        // A layout without valid bins (never with positive bin counts): nothing to cover.
        return 1.0;
    }
    return static_cast<double>(covered_count_) / static_cast<double>(valid_count_);
}

void CoverageMap::cover(std::size_t bin) {
    GONIO_CHECK(bin < covered_.size());
    if (valid_[bin] && !covered_[bin]) {
        covered_[bin] = 1;
        ++covered_count_;
    }
}

void CoverageMap::cover_from(const BinnedTable& table, std::uint32_t min_count) {
    GONIO_CHECK(table.size() == covered_.size());
    for (std::size_t b = 0; b < table.size(); ++b) {
        if (table.count(b) >= std::max<std::uint32_t>(min_count, 1)) {
            cover(b);
        }
    }
}

std::size_t CoverageMap::gain(const std::vector<std::uint32_t>& bins) const {
    std::size_t g = 0;
    for (std::uint32_t b : bins) {
        g += (valid_[b] && !covered_[b]) ? 1 : 0;
    }
    return g;
}

int next_light(const std::vector<LightCandidate>& candidates,
               const CoverageMap& coverage,
               double current_light_rad,
               double gain_fraction) {
    GONIO_CHECK(gain_fraction > 0 && gain_fraction <= 1);
    std::vector<std::size_t> gains(candidates.size());
    std::size_t best_gain = 0;
    for (std::size_t i = 0; i < candidates.size(); ++i) {
        gains[i] = coverage.gain(candidates[i].bins);
        best_gain = std::max(best_gain, gains[i]);
    }
    if (best_gain == 0) {
        // Nothing left that any candidate can add.
        return -1;
    }
    const double threshold = gain_fraction * static_cast<double>(best_gain);
    int best = -1;
    std::size_t chosen_gain = 0;
    double best_move = 0;
    for (std::size_t i = 0; i < candidates.size(); ++i) {
        if (gains[i] == 0 || static_cast<double>(gains[i]) < threshold) {
            continue;
        }
        // With gain_fraction = 1 only the largest gains pass: "largest gain, then shortest move".
        const double move = std::abs(candidates[i].light_arm_rad - current_light_rad);
        if (best < 0 || move < best_move || (move == best_move && gains[i] > chosen_gain)) {
            best = static_cast<int>(i);
            chosen_gain = gains[i];
            best_move = move;
        }
    }
    return best;
}

std::vector<std::size_t> candidate_gains(const std::vector<LightCandidate>& candidates,
                                         const CoverageMap& coverage) {
    std::vector<std::size_t> gains(candidates.size());
    for (std::size_t i = 0; i < candidates.size(); ++i) {
        gains[i] = coverage.gain(candidates[i].bins);
    }
    return gains;
}

void update_gains(const std::vector<LightCandidate>& candidates,
                  const CoverageMap& coverage,
                  int theta_d_lo,
                  int theta_d_hi,
                  std::vector<std::size_t>* gains) {
    GONIO_CHECK(gains->size() == candidates.size());
    for (std::size_t i = 0; i < candidates.size(); ++i) {
        const LightCandidate& c = candidates[i];
        if (c.theta_d_hi >= theta_d_lo && c.theta_d_lo <= theta_d_hi) {
            (*gains)[i] = coverage.gain(c.bins);
        }
    }
}

int next_light(const std::vector<LightCandidate>& candidates,
               const std::vector<std::size_t>& gains,
               double current_light_rad,
               double gain_fraction) {
    GONIO_CHECK(gain_fraction > 0 && gain_fraction <= 1 && gains.size() == candidates.size());
    const std::size_t best_gain = gains.empty() ? 0 : *std::max_element(gains.begin(), gains.end());
    if (best_gain == 0) {
        // Nothing left that any candidate can add.
        return -1;
    }
    const double threshold = gain_fraction * static_cast<double>(best_gain);
    int best = -1;
    std::size_t chosen_gain = 0;
    double best_move = 0;
    for (std::size_t i = 0; i < candidates.size(); ++i) {
        if (gains[i] == 0 || static_cast<double>(gains[i]) < threshold) {
            continue;
        }
        const double move = std::abs(candidates[i].light_arm_rad - current_light_rad);
        if (best < 0 || move < best_move || (move == best_move && gains[i] > chosen_gain)) {
            best = static_cast<int>(i);
            chosen_gain = gains[i];
            best_move = move;
        }
    }
    return best;
}

CoveragePlan plan_lights(const std::vector<LightCandidate>& candidates,
                         const TableLayout& layout,
                         double coverage_target,
                         int max_lights,
                         double start_light_rad) {
    CoverageMap map(layout);
    CoveragePlan plan;
    plan.valid_bins = map.valid_bins();
    {
        CoverageMap all(layout);
        for (const LightCandidate& c : candidates) {
            for (std::uint32_t b : c.bins) {
                all.cover(b);
            }
        }
        plan.reachable_bins = all.covered_bins();
    }
    double current = start_light_rad;
    while (static_cast<int>(plan.light_arm_rad.size()) < max_lights &&
           map.fraction() < coverage_target) {
        const int i = next_light(candidates, map, current);
        if (i < 0) {
            break;
        }
        for (std::uint32_t b : candidates[i].bins) {
            map.cover(b);
        }
        current = candidates[i].light_arm_rad;
        plan.light_arm_rad.push_back(current);
        plan.predicted_coverage.push_back(map.fraction());
    }
    plan.target_met = map.fraction() >= coverage_target;
    return plan;
}

std::vector<CoverageHole> coverage_holes(const CoverageMap& coverage,
                                         const std::vector<LightCandidate>& candidates,
                                         double blind_zone_rad) {
    const TableLayout& l = coverage.layout();
    std::vector<std::uint8_t> reachable(l.size(), 0);
    for (const LightCandidate& c : candidates) {
        for (std::uint32_t b : c.bins) {
            reachable[b] = 1;
        }
    }
    std::vector<CoverageHole> holes;
    for (int i_d = 0; i_d < l.n_theta_d; ++i_d) {
        // Up to three holes per theta_d cell, one per reason.
        CoverageHole by_reason[3];
        const char* reasons[3] = {"blind zone", "excluded (grazing or limits)", "not measured"};
        for (int i_h = 0; i_h < l.n_theta_h; ++i_h) {
            for (int i_p = 0; i_p < l.n_phi_d; ++i_p) {
                const std::size_t b = l.index(i_h, i_d, i_p);
                if (!coverage.valid(b) || coverage.covered(b)) {
                    continue;
                }
                const double theta_d = l.theta_d_centre(i_d);
                int r = 2;
                if (!reachable[b]) {
                    r = theta_d < blind_zone_rad / 2 ? 0 : 1;
                }
                CoverageHole& h = by_reason[r];
                const double th = l.theta_h_centre(i_h);
                if (h.bins == 0) {
                    h.theta_h_min = th;
                    h.theta_h_max = th;
                }
                h.theta_h_min = std::min(h.theta_h_min, th);
                h.theta_h_max = std::max(h.theta_h_max, th);
                ++h.bins;
            }
        }
        for (int r = 0; r < 3; ++r) {
            if (by_reason[r].bins > 0) {
                by_reason[r].theta_d_min = static_cast<double>(i_d) / l.n_theta_d * brdf::kPi / 2;
                by_reason[r].theta_d_max =
                    static_cast<double>(i_d + 1) / l.n_theta_d * brdf::kPi / 2;
                by_reason[r].reason = reasons[r];
                holes.push_back(by_reason[r]);
            }
        }
    }
    return holes;
}

std::vector<CoverageHole> coverage_holes(const CoverageMap& coverage,
                                         const std::vector<LightCandidate>& candidates,
                                         const HoleLimits& limits) {
    const TableLayout& l = coverage.layout();
    std::vector<std::uint8_t> reachable(l.size(), 0);
    for (const LightCandidate& c : candidates) {
        for (std::uint32_t b : c.bins) {
            reachable[b] = 1;
        }
    }
    constexpr int kReasons = 5;
    const char* reasons[kReasons] = {"blind zone",
                                     "arm limits",
                                     "grazing (beyond max_theta)",
                                     "finer than a pixel",
                                     "not measured"};
    const double cos_i = std::cos(limits.max_theta_i);
    const double cos_o = std::cos(limits.max_theta_o);
    std::vector<CoverageHole> holes;
    for (int i_d = 0; i_d < l.n_theta_d; ++i_d) {
        CoverageHole by_reason[kReasons];
        const double theta_d = l.theta_d_centre(i_d);
        for (int i_h = 0; i_h < l.n_theta_h; ++i_h) {
            for (int i_p = 0; i_p < l.n_phi_d; ++i_p) {
                const std::size_t b = l.index(i_h, i_d, i_p);
                if (!coverage.valid(b) || coverage.covered(b)) {
                    continue;
                }
                int r = 4;
                if (!reachable[b]) {
                    const auto [wi, wo] = l.centre_directions(i_h, i_d, i_p);
                    // Reciprocity: the pair may be measured either way round.
                    const bool within = (wi.z() >= cos_i && wo.z() >= cos_o) ||
                                        (wo.z() >= cos_i && wi.z() >= cos_o);
                    if (theta_d < limits.blind_zone_rad / 2) {
                        r = 0;
                    } else if (theta_d > limits.max_separation_rad / 2) {
                        r = 1;
                    } else if (!within) {
                        r = 2;
                    } else {
                        r = 3;
                    }
                }
                CoverageHole& h = by_reason[r];
                const double th = l.theta_h_centre(i_h);
                if (h.bins == 0) {
                    h.theta_h_min = th;
                    h.theta_h_max = th;
                }
                h.theta_h_min = std::min(h.theta_h_min, th);
                h.theta_h_max = std::max(h.theta_h_max, th);
                ++h.bins;
            }
        }
        for (int r = 0; r < kReasons; ++r) {
            if (by_reason[r].bins > 0) {
                by_reason[r].theta_d_min = static_cast<double>(i_d) / l.n_theta_d * brdf::kPi / 2;
                by_reason[r].theta_d_max =
                    static_cast<double>(i_d + 1) / l.n_theta_d * brdf::kPi / 2;
                by_reason[r].reason = reasons[r];
                holes.push_back(by_reason[r]);
            }
        }
    }
    return holes;
}

Expected<void> write_coverage_png(const std::string& path,
                                  const std::vector<double>& cells,
                                  const TableLayout& layout,
                                  int scale) {
    if (cells.size() != static_cast<std::size_t>(layout.n_theta_h) * layout.n_theta_d ||
        scale < 1) {
        return make_error(path + ": coverage has " + std::to_string(cells.size()) +
                          " cells, expected n_theta_h x n_theta_d");
    }
    cv::Mat gray(layout.n_theta_d, layout.n_theta_h, CV_8U);
    cv::Mat invalid(layout.n_theta_d, layout.n_theta_h, CV_8U, cv::Scalar(0));
    for (int y = 0; y < layout.n_theta_d; ++y) {
        for (int x = 0; x < layout.n_theta_h; ++x) {
            const double v = cells[static_cast<std::size_t>(y) * layout.n_theta_h + x];
            gray.at<std::uint8_t>(y, x) =
                static_cast<std::uint8_t>(std::lround(std::clamp(v, 0.0, 1.0) * 255));
            invalid.at<std::uint8_t>(y, x) = v < 0 ? 255 : 0;
        }
    }
    cv::Mat colour;
    cv::applyColorMap(gray, colour, cv::COLORMAP_VIRIDIS);
    colour.setTo(cv::Scalar(128, 128, 128), invalid);
    cv::Mat big;
    cv::resize(colour, big, cv::Size(), scale, scale, cv::INTER_NEAREST);
    std::vector<std::uint8_t> bytes;
    try {
        if (!cv::imencode(".png", big, bytes)) {
            return make_error(path + ": cannot encode PNG");
        }
    } catch (const cv::Exception& e) {
        return make_error(path + ": " + e.what());
    }
    return write_file_atomic(
        path, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
}

}  // namespace gonio::acquisition
