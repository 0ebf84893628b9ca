#pragma once

// The choice of the next frame that the isotropic planner (image_planner.h: next_light, over
// light positions) and the anisotropic one (image_aniso.h: next_pose, over light and spin) share,
// and the prediction of a candidate's bins from the frame's per-pixel geometry.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "gonio/acquisition/image/sphere_geometry.h"
#include "gonio/base/check.h"

namespace gonio::acquisition::detail {

/// Index of the next candidate given the gains (new valid bins) of each, or -1 when none adds a
/// bin: among the candidates whose gain is at least `gain_fraction` of the largest (in (0, 1]),
/// the one with the smallest `move(candidate)` from the current pose, ties to the larger gain.
/// With gain_fraction = 1 only the largest gains pass: "largest gain, then shortest move".
template <class Candidate, class Move>
int choose_next(const std::vector<Candidate>& candidates,
                const std::vector<std::size_t>& gains,
                double gain_fraction,
                Move move) {
    GONIO_CHECK(gains.size() == candidates.size());
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
        const double m = move(candidates[i]);
        if (best < 0 || m < best_move || (m == best_move && gains[i] > chosen_gain)) {
            best = static_cast<int>(i);
            chosen_gain = gains[i];
            best_move = m;
        }
    }
    return best;
}

/// An arm's positions over a range: min, min + step, ... up to max (to rounding), in order.
inline std::vector<double> range_steps(double min_rad, double max_rad, double step_rad) {
    std::vector<double> out;
    const int steps = static_cast<int>(std::floor((max_rad - min_rad) / step_rad + 1e-9));
    for (int k = 0; k <= steps; ++k) {
        out.push_back(min_rad + k * step_rad);
    }
    return out;
}

/// The sphere's pixels within the rules, every `stride`-th pixel row and column.
inline std::vector<SpherePixel> strided_pixels(const CameraModel& camera,
                                               const SphereGeometry& sphere,
                                               const ExclusionRules& rules,
                                               int stride) {
    std::vector<SpherePixel> pixels = sphere_pixels(camera, sphere, rules, nullptr);
    if (stride > 1) {
        pixels.erase(std::remove_if(pixels.begin(),
                                    pixels.end(),
                                    [&](const SpherePixel& p) {
                                        return p.x % stride != 0 || p.y % stride != 0;
                                    }),
                     pixels.end());
    }
    return pixels;
}

/// Working memory of predicted_bins(), reused from one candidate to the next: one mark per bin of
/// the table (which bins the candidate's pixels already reached) and the list of the marked ones.
/// Its size is the table's (one bit per bin), never the camera's.
class BinMarks {
  public:
    explicit BinMarks(std::size_t bins) : seen_(bins, false) {}

    /// Marks `bin` (a bin index of the table).
    void add(std::size_t bin) {
        if (!seen_[bin]) {
            seen_[bin] = true;
            marked_.push_back(static_cast<std::uint32_t>(bin));
        }
    }
    /// The marked bins, sorted, in a vector of exactly their count; the marks are cleared.
    std::vector<std::uint32_t> take_sorted() {
        std::sort(marked_.begin(), marked_.end());
        for (const std::uint32_t b : marked_) {
            seen_[b] = false;
        }
        std::vector<std::uint32_t> out(marked_.begin(), marked_.end());
        marked_.clear();
        return out;
    }

  private:
    std::vector<bool> seen_;
    std::vector<std::uint32_t> marked_;
};

/// The valid bins a frame fills, sorted and unique: for each pixel i, `directions(i)` gives (wi,
/// wo) in its local frame (or false for a pixel that gives no sample), those lit within
/// `cos_max_i` are binned by `bin(wi, wo)` and kept when `valid(bin)`.
///
/// Streamed over the pixels: each bin is marked once in `marks` (sized to the table, reused from
/// one candidate to the next), so that a candidate costs the memory of its unique bins (at most
/// those of the theta_d rows it spans), never one entry per pixel of a megapixel camera.
template <class Directions, class Bin, class Valid>
std::vector<std::uint32_t> predicted_bins(std::size_t pixels,
                                          double cos_max_i,
                                          Directions directions,
                                          Bin bin,
                                          Valid valid,
                                          BinMarks* marks) {
    for (std::size_t i = 0; i < pixels; ++i) {
        brdf::Vec3d wi;
        brdf::Vec3d wo;
        if (!directions(i, &wi, &wo)) {
            continue;
        }
        if (wi.z() < cos_max_i) {
            // Shadowed or grazing light: no sample from this pixel.
            continue;
        }
        const std::size_t b = bin(wi, wo);
        if (valid(b)) {
            marks->add(b);
        }
    }
    return marks->take_sorted();
}

}  // namespace gonio::acquisition::detail
