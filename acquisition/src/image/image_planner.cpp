#include "gonio/acquisition/image/image_planner.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string_view>
#include <tuple>
#include <vector>

#include "gonio/base/atomic_file.h"
#include "gonio/base/check.h"
#include "gonio/brdf/rig_geometry.h"
#include "next_choice.h"

namespace gonio::acquisition {

std::vector<double> light_positions(const LightRange& range, double detector_arm_rad) {
    GONIO_CHECK(range.step_rad > 0);
    std::vector<double> lights;
    for (const double a : detail::range_steps(range.min_rad, range.max_rad, range.step_rad)) {
        if (brdf::arm_separation(a, detector_arm_rad) < range.blind_zone_rad) {
            // Inside the blind zone around the detector.
            continue;
        }
        lights.push_back(a);
    }
    return lights;
}

std::vector<LightCandidate> light_candidates(const CameraModel& camera,
                                             const SphereGeometry& sphere,
                                             const ExclusionRules& rules,
                                             const TableLayout& layout,
                                             double detector_arm_rad,
                                             const LightRange& range,
                                             int pixel_stride) {
    GONIO_CHECK(range.step_rad > 0 && pixel_stride >= 1);
    return light_candidates_at(
        camera, sphere, rules, layout, light_positions(range, detector_arm_rad), pixel_stride);
}

std::vector<LightCandidate> light_candidates_at(const CameraModel& camera,
                                                const SphereGeometry& sphere,
                                                const ExclusionRules& rules,
                                                const TableLayout& layout,
                                                const std::vector<double>& light_arm_rad,
                                                int pixel_stride) {
    GONIO_CHECK(pixel_stride >= 1);
    const std::vector<SpherePixel> pixels =
        detail::strided_pixels(camera, sphere, rules, pixel_stride);
    const double cos_max_i = std::cos(rules.max_theta_i);
    std::vector<LightCandidate> out;
    detail::BinMarks marks(layout.size());
    for (const double a : light_arm_rad) {
        const brdf::Vec3d l = brdf::arm_direction(a);
        LightCandidate c;
        c.light_arm_rad = a;
        c.bins = detail::predicted_bins(
            pixels.size(),
            cos_max_i,
            [&](std::size_t i, brdf::Vec3d* wi, brdf::Vec3d* wo) {
                std::tie(*wi, *wo) = local_directions(pixels[i], l);
                return true;
            },
            [&](const brdf::Vec3d& wi, const brdf::Vec3d& wo) {
                const brdf::HalfDiff<double> hd = brdf::to_half_diff(wi, wo);
                return bin_index(layout, hd.theta_h, hd.theta_d, hd.phi_d);
            },
            [&](std::size_t b) { return bin_valid(layout, b); },
            &marks);
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

namespace {

std::vector<std::uint8_t> valid_flags(const TableLayout& layout) {
    std::vector<std::uint8_t> valid(layout.size(), 0);
    for (std::size_t b = 0; b < layout.size(); ++b) {
        valid[b] = bin_valid(layout, b) ? 1 : 0;
    }
    return valid;
}

}  // namespace

CoverageMap::CoverageMap(const TableLayout& layout)
    : BinCoverage(valid_flags(layout)), layout_(layout) {}

void CoverageMap::cover_from(const BinnedTable& table, std::uint32_t min_count) {
    GONIO_CHECK(table.size() == size());
    cover_counts([&](std::size_t b) { return table.count(b); }, min_count);
}

std::vector<double> coverage_cells(const CoverageMap& coverage) {
    return cell_fractions(coverage.layout(),
                          [&](std::size_t b, std::size_t* valid, std::size_t* covered) {
                              *valid += coverage.valid(b) ? 1 : 0;
                              *covered += coverage.covered(b) ? 1 : 0;
                          });
}

int next_light(const std::vector<LightCandidate>& candidates,
               const CoverageMap& coverage,
               double current_light_rad,
               double gain_fraction) {
    return next_light(
        candidates, candidate_gains(candidates, coverage), current_light_rad, gain_fraction);
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
    GONIO_CHECK(gain_fraction > 0 && gain_fraction <= 1);
    return detail::choose_next(candidates, gains, gain_fraction, [&](const LightCandidate& c) {
        return std::abs(c.light_arm_rad - current_light_rad);
    });
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
            all.cover_all(c.bins);
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
        map.cover_all(candidates[i].bins);
        current = candidates[i].light_arm_rad;
        plan.light_arm_rad.push_back(current);
        plan.predicted_coverage.push_back(map.fraction());
    }
    plan.target_met = map.fraction() >= coverage_target;
    return plan;
}

namespace {

/// The holes of the coverage: each valid empty bin gets the reason `classify(i_h, i_d, i_p,
/// reachable)` (an index into `reasons`, `reachable` whether some candidate's bins hold it), then
/// the bins are grouped by theta_d cell and reason, in the order of `reasons`.
template <class Classify>
std::vector<CoverageHole> holes_by_reason(const CoverageMap& coverage,
                                          const std::vector<LightCandidate>& candidates,
                                          const std::vector<const char*>& reasons,
                                          Classify classify) {
    const TableLayout& l = coverage.layout();
    std::vector<std::uint8_t> reachable(l.size(), 0);
    for (const LightCandidate& c : candidates) {
        for (std::uint32_t b : c.bins) {
            reachable[b] = 1;
        }
    }
    std::vector<CoverageHole> holes;
    for (int i_d = 0; i_d < l.n_theta_d; ++i_d) {
        std::vector<CoverageHole> by_reason(reasons.size());
        for (int i_h = 0; i_h < l.n_theta_h; ++i_h) {
            for (int i_p = 0; i_p < l.n_phi_d; ++i_p) {
                const std::size_t b = l.index(i_h, i_d, i_p);
                if (!coverage.valid(b) || coverage.covered(b)) {
                    continue;
                }
                CoverageHole& h = by_reason[classify(i_h, i_d, i_p, reachable[b] != 0)];
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
        for (std::size_t r = 0; r < reasons.size(); ++r) {
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

}  // namespace

std::vector<CoverageHole> coverage_holes(const CoverageMap& coverage,
                                         const std::vector<LightCandidate>& candidates,
                                         double blind_zone_rad) {
    const TableLayout& l = coverage.layout();
    return holes_by_reason(coverage,
                           candidates,
                           {"blind zone", "excluded (grazing or limits)", "not measured"},
                           [&](int, int i_d, int, bool reachable) -> std::size_t {
                               if (reachable) {
                                   return 2;
                               }
                               return l.theta_d_centre(i_d) < blind_zone_rad / 2 ? 0 : 1;
                           });
}

std::vector<CoverageHole> coverage_holes(const CoverageMap& coverage,
                                         const std::vector<LightCandidate>& candidates,
                                         const HoleLimits& limits) {
    const TableLayout& l = coverage.layout();
    const double cos_i = std::cos(limits.max_theta_i);
    const double cos_o = std::cos(limits.max_theta_o);
    return holes_by_reason(coverage,
                           candidates,
                           {"blind zone",
                            "arm limits",
                            "grazing (beyond max_theta)",
                            "finer than a pixel",
                            "not measured"},
                           [&](int i_h, int i_d, int i_p, bool reachable) -> std::size_t {
                               if (reachable) {
                                   return 4;
                               }
                               const double theta_d = l.theta_d_centre(i_d);
                               const auto [wi, wo] = l.centre_directions(i_h, i_d, i_p);
                               // Reciprocity: the pair may be measured either way round.
                               const bool within = (wi.z() >= cos_i && wo.z() >= cos_o) ||
                                                   (wo.z() >= cos_i && wi.z() >= cos_o);
                               if (theta_d < limits.blind_zone_rad / 2) {
                                   return 0;
                               }
                               if (theta_d > limits.max_separation_rad / 2) {
                                   return 1;
                               }
                               return within ? 3 : 2;
                           });
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
