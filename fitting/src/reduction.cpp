// Stratified reduction in the half/difference domain.

#include "gonio/fitting/reduction.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <unordered_map>

namespace gonio::fitting {

std::vector<brdf::Sample> stratified_reduce(const std::vector<brdf::Sample>& samples,
                                            std::size_t budget,
                                            std::uint64_t seed) {
    if (budget == 0 || budget >= samples.size()) {
        return samples;
    }
    // Cells: theta_h on a square-root scale (as the MERL table: fine near the specular peak),
    // theta_d and phi_d (folded to [0, pi) by the reciprocity of the pair) uniform. The cell
    // count grows with the budget so that each cell keeps a few samples.
    const double cells_wanted = std::max(1.0, static_cast<double>(budget) / 4.0);
    const int n_h = std::max(2, static_cast<int>(std::round(std::cbrt(cells_wanted) * 1.6)));
    const int n_d = std::max(2, static_cast<int>(std::round(std::cbrt(cells_wanted) * 0.9)));
    const int n_p = std::max(1, static_cast<int>(std::round(cells_wanted / (n_h * n_d))));
    std::unordered_map<long, std::vector<std::size_t>> strata;
    for (std::size_t i = 0; i < samples.size(); ++i) {
        const brdf::HalfDiff<double> hd = brdf::to_half_diff(samples[i].wi(), samples[i].wo());
        const double u_h = std::sqrt(std::clamp(hd.theta_h / (brdf::kPi / 2), 0.0, 1.0));
        const double u_d = std::clamp(hd.theta_d / (brdf::kPi / 2), 0.0, 1.0);
        double phi_d = std::fmod(hd.phi_d, brdf::kPi);
        if (phi_d < 0) {
            phi_d += brdf::kPi;
        }
        const double u_p = phi_d / brdf::kPi;
        const long ih = std::min(n_h - 1, static_cast<int>(u_h * n_h));
        const long id = std::min(n_d - 1, static_cast<int>(u_d * n_d));
        const long ip = std::min(n_p - 1, static_cast<int>(u_p * n_p));
        strata[(ih * n_d + id) * n_p + ip].push_back(i);
    }
    // Deterministic order of the strata, then water-filling of the budget: small strata keep all
    // their samples, the rest share what remains equally.
    std::vector<std::pair<long, std::vector<std::size_t>*>> cells;
    for (auto& kv : strata) {
        cells.emplace_back(kv.first, &kv.second);
    }
    std::sort(cells.begin(), cells.end(), [](const auto& a, const auto& b) {
        return a.second->size() < b.second->size() ||
               (a.second->size() == b.second->size() && a.first < b.first);
    });
    std::vector<std::size_t> keep(cells.size(), 0);
    std::size_t remaining = budget;
    for (std::size_t k = 0; k < cells.size(); ++k) {
        const std::size_t share = std::max<std::size_t>(1, remaining / (cells.size() - k));
        keep[k] = std::min(cells[k].second->size(), share);
        remaining -= std::min(remaining, keep[k]);
    }
    std::mt19937_64 rng(seed);
    std::vector<brdf::Sample> out;
    out.reserve(budget + cells.size());
    for (std::size_t k = 0; k < cells.size(); ++k) {
        std::vector<std::size_t>& idx = *cells[k].second;
        const std::size_t m = keep[k];
        // Partial Fisher-Yates: the first m of a seeded permutation.
        for (std::size_t j = 0; j < m; ++j) {
            std::uniform_int_distribution<std::size_t> pick(j, idx.size() - 1);
            std::swap(idx[j], idx[pick(rng)]);
        }
        std::sort(idx.begin(), idx.begin() + static_cast<long>(m));
        const double w = static_cast<double>(idx.size()) / static_cast<double>(m);
        for (std::size_t j = 0; j < m; ++j) {
            brdf::Sample s = samples[idx[j]];
            s.weight *= w;
            out.push_back(s);
        }
    }
    return out;
}

}  // namespace gonio::fitting
