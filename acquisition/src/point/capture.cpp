#include "gonio/acquisition/point/capture.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace gonio::acquisition {

namespace {

double percentile(std::vector<float>& v, double q) {
    if (v.empty()) {
        return 0;
    }
    const std::size_t k =
        static_cast<std::size_t>(std::floor(q * static_cast<double>(v.size() - 1)));
    std::nth_element(v.begin(), v.begin() + k, v.end());
    return v[k];
}

}  // namespace

Expected<RoiStats> roi_stats(const devices::Frame& f,
                             const cv::Mat& dark,
                             const PixelRoi& roi,
                             const NoiseModel& noise) {
    const cv::Mat& img = f.image;
    const int ch = img.channels();
    if (img.empty() || (img.depth() != CV_16U && img.depth() != CV_32F) || (ch != 1 && ch != 3)) {
        return make_error("frame " + std::to_string(f.frame_id) +
                          ": unsupported image (need 1 or 3 channels of 16-bit or float)");
    }
    if (roi.width <= 0 || roi.height <= 0 || roi.x < 0 || roi.y < 0 ||
        roi.x + roi.width > img.cols || roi.y + roi.height > img.rows) {
        return make_error("ROI " + std::to_string(roi.width) + "x" + std::to_string(roi.height) +
                          "+" + std::to_string(roi.x) + "+" + std::to_string(roi.y) +
                          " outside the " + std::to_string(img.cols) + "x" +
                          std::to_string(img.rows) + " frame");
    }
    if (!dark.empty() && (dark.size() != img.size() || dark.type() != CV_MAKETYPE(CV_32F, ch))) {
        return make_error("dark frame does not match the frame's size and channels");
    }
    if (!(f.saturation_level > f.black_level)) {
        return make_error("frame " + std::to_string(f.frame_id) +
                          ": saturation level not above the black level");
    }
    const double range = f.saturation_level - f.black_level;
    RoiStats st;
    std::vector<float> fractions;
    fractions.reserve(static_cast<std::size_t>(roi.width) * roi.height * ch);
    double sum[3] = {0, 0, 0};
    double sum2[3] = {0, 0, 0};
    for (int y = roi.y; y < roi.y + roi.height; ++y) {
        for (int x = roi.x; x < roi.x + roi.width; ++x) {
            bool sat = false;
            double v[3] = {0, 0, 0};
            for (int c = 0; c < ch; ++c) {
                const double raw = img.depth() == CV_16U
                                       ? static_cast<double>(img.ptr<std::uint16_t>(y)[x * ch + c])
                                       : static_cast<double>(img.ptr<float>(y)[x * ch + c]);
                if (!std::isfinite(raw)) {
                    return make_error("frame " + std::to_string(f.frame_id) +
                                      ": non-finite pixel at (" + std::to_string(x) + ", " +
                                      std::to_string(y) + ")");
                }
                if (raw >= f.saturation_level) {
                    sat = true;
                }
                const double d = dark.empty() ? f.black_level
                                              : static_cast<double>(dark.ptr<float>(y)[x * ch + c]);
                v[c] = raw - d;
                fractions.push_back(static_cast<float>((raw - f.black_level) / range));
            }
            if (sat) {
                // A clipped pixel only bounds the signal from below: excluded from the mean.
                ++st.saturated;
                continue;
            }
            ++st.valid;
            for (int c = 0; c < ch; ++c) {
                sum[c] += v[c];
                sum2[c] += v[c] * v[c];
            }
        }
    }
    st.high_fraction = percentile(fractions, 0.99);
    st.low_fraction = percentile(fractions, 0.01);
    if (st.valid == 0) {
        // Every pixel clipped: no value, only the fact (callers shorten the exposure).
        st.high_fraction = std::max(st.high_fraction, 1.0);
        return st;
    }
    const double n = static_cast<double>(st.valid);
    for (int c = 0; c < 3; ++c) {
        const int src = ch == 1 ? 0 : c;
        const double mean = sum[src] / n;
        const double var_pix = n > 1 ? std::max(0.0, (sum2[src] - n * mean * mean) / (n - 1)) : 0;
        double var_model = 2 * noise.read_noise_counts * noise.read_noise_counts;
        if (noise.e_per_count > 0) {
            // Shot noise: N_e = m * e_per_count / gain electrons, variance N_e in electrons^2, i.e.
            // m * gain / e_per_count in counts^2.
            var_model += std::max(mean, 0.0) * f.gain / noise.e_per_count;
        }
        st.mean[c] = mean;
        st.sigma[c] = std::sqrt(std::max(var_pix, var_model) / n);
    }
    return st;
}

namespace {

/// The frames, their dark frames and the ROI fit together (sizes, types, exposures).
Expected<void> check_hdr_inputs(const std::vector<devices::Frame>& frames,
                                const std::vector<cv::Mat>& darks,
                                const PixelRoi& roi) {
    if (frames.empty() || frames.size() != darks.size()) {
        return make_error("HDR merge: " + std::to_string(frames.size()) + " frames and " +
                          std::to_string(darks.size()) + " dark frames");
    }
    const cv::Mat& first = frames[0].image;
    const int ch = first.channels();
    for (std::size_t k = 0; k < frames.size(); ++k) {
        const cv::Mat& im = frames[k].image;
        if (im.empty() || im.size() != first.size() || im.channels() != ch ||
            (im.depth() != CV_16U && im.depth() != CV_32F) || (ch != 1 && ch != 3)) {
            return make_error("HDR merge: frame " + std::to_string(k) +
                              " has another size or an unsupported type");
        }
        if (darks[k].size() != im.size() || darks[k].type() != CV_MAKETYPE(CV_32F, ch)) {
            return make_error("HDR merge: dark frame " + std::to_string(k) +
                              " does not match its frame");
        }
        if (!(frames[k].exposure_us > 0) || !(frames[k].gain > 0)) {
            return make_error("HDR merge: frame " + std::to_string(k) + " has no exposure or gain");
        }
    }
    if (roi.width <= 0 || roi.height <= 0 || roi.x < 0 || roi.y < 0 ||
        roi.x + roi.width > first.cols || roi.y + roi.height > first.rows) {
        return make_error("HDR merge: ROI outside the frame");
    }
    return {};
}

/// The frames of the longest and the shortest exposure x gain.
void extreme_exposures(const std::vector<devices::Frame>& frames,
                       std::size_t* longest_out,
                       std::size_t* shortest_out) {
    std::size_t longest = 0;
    std::size_t shortest = 0;
    for (std::size_t k = 0; k < frames.size(); ++k) {
        const double tg = frames[k].exposure_us * frames[k].gain;
        if (tg > frames[longest].exposure_us * frames[longest].gain) {
            longest = k;
        }
        if (tg < frames[shortest].exposure_us * frames[shortest].gain) {
            shortest = k;
        }
    }
    *longest_out = longest;
    *shortest_out = shortest;
}

/// One pixel's channel c merged over the frames: the exposure-weighted mean of the rates of the
/// frames where it is not clipped; clipped in every frame, the shortest frame's lower bound
/// (counted in *clipped).
Expected<double> merged_rate(const std::vector<devices::Frame>& frames,
                             const std::vector<cv::Mat>& darks,
                             int x,
                             int y,
                             int c,
                             std::size_t shortest,
                             std::size_t* clipped) {
    const int ch = frames[0].image.channels();
    double wsum = 0;
    double acc = 0;
    double fallback = 0;
    for (std::size_t k = 0; k < frames.size(); ++k) {
        const cv::Mat& im = frames[k].image;
        const double raw = im.depth() == CV_16U
                               ? static_cast<double>(im.ptr<std::uint16_t>(y)[x * ch + c])
                               : static_cast<double>(im.ptr<float>(y)[x * ch + c]);
        if (!std::isfinite(raw)) {
            return make_error("HDR merge: non-finite pixel at (" + std::to_string(x) + ", " +
                              std::to_string(y) + ")");
        }
        const double tg = frames[k].exposure_us * frames[k].gain;
        const double r = (raw - darks[k].ptr<float>(y)[x * ch + c]) / tg;
        if (k == shortest) {
            fallback = r;
        }
        if (raw >= frames[k].saturation_level) {
            // Clipped in this frame: no information beyond a lower bound.
            continue;
        }
        wsum += tg;
        acc += tg * r;
    }
    if (wsum > 0) {
        return acc / wsum;
    }
    // Clipped at every exposure: keep the shortest frame's lower bound.
    ++*clipped;
    return fallback;
}

/// The ROI's mean rate per channel and its standard error: the larger of the pixels' scatter and
/// the noise model of the longest frame.
void rate_statistics(const double* sum,
                     const double* sum2,
                     std::size_t n,
                     int ch,
                     const devices::Frame& fl,
                     const NoiseModel& noise,
                     SignalRate* out_rate) {
    SignalRate& out = *out_rate;
    const double dn = static_cast<double>(n);
    const double tg_long = fl.exposure_us * fl.gain;
    for (int c = 0; c < 3; ++c) {
        const int src = ch == 1 ? 0 : c;
        const double mean = sum[src] / dn;
        const double var_pix = n > 1 ? std::max(0.0, (sum2[src] - dn * mean * mean) / (dn - 1)) : 0;
        // Noise model for the longest frame, in counts^2, then in rate units.
        double var_model = 2 * noise.read_noise_counts * noise.read_noise_counts;
        if (noise.e_per_count > 0) {
            var_model += std::max(mean * tg_long, 0.0) * fl.gain / noise.e_per_count;
        }
        var_model /= tg_long * tg_long;
        out.rate[c] = mean;
        out.sigma[c] = std::sqrt(std::max(var_pix, var_model) / dn);
    }
}

}  // namespace

Expected<SignalRate> merge_hdr(const std::vector<devices::Frame>& frames,
                               const std::vector<cv::Mat>& darks,
                               const PixelRoi& roi,
                               const NoiseModel& noise) {
    if (auto ok = check_hdr_inputs(frames, darks, roi); !ok) {
        return tl::unexpected(ok.error());
    }
    const int ch = frames[0].image.channels();
    SignalRate out;
    out.hdr = frames.size() > 1;
    std::size_t longest = 0, shortest = 0;
    extreme_exposures(frames, &longest, &shortest);
    double sum[3] = {0, 0, 0};
    double sum2[3] = {0, 0, 0};
    std::size_t n = 0;
    std::size_t clipped = 0;
    for (int y = roi.y; y < roi.y + roi.height; ++y) {
        for (int x = roi.x; x < roi.x + roi.width; ++x) {
            for (int c = 0; c < ch; ++c) {
                auto r = merged_rate(frames, darks, x, y, c, shortest, &clipped);
                if (!r) {
                    return tl::unexpected(r.error());
                }
                sum[c] += *r;
                sum2[c] += *r * *r;
            }
            ++n;
        }
    }
    const devices::Frame& fl = frames[longest];
    rate_statistics(sum, sum2, n, ch, fl, noise, &out);
    out.saturated = clipped > 0;
    out.exposure_us = fl.exposure_us;
    out.pixels = n;
    return out;
}

double next_exposure_us(
    double exposure_us, double high_fraction, double target, double min_us, double max_us) {
    double next = exposure_us;
    if (high_fraction >= 1.0) {
        // Clipped: the true level is unknown, step down hard.
        next = exposure_us / 8;
    } else if (high_fraction <= 1e-6) {
        // No measurable signal: step up hard.
        next = exposure_us * 8;
    } else {
        next = exposure_us * target / high_fraction;
    }
    return std::clamp(next, min_us, max_us);
}

}  // namespace gonio::acquisition
