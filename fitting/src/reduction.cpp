// Stratified reduction in the half/difference domain.

#include "gonio/fitting/reduction.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>

#include "gonio/base/check.h"
#include "gonio/base/huge_pages.h"
#include "gonio/base/instruction_set.h"
#include "gonio/base/thread_pool.h"
#include "stratum_kernel.h"

namespace gonio::fitting {

namespace detail {
// One copy per instruction set: isa/stratum.cpp.
GONIO_ISA_DECLARE(void stratum(const StratumArrays& a, std::size_t n);)
}  // namespace detail

namespace {

/// The stratum coordinates of one sample (stratum_kernel.h, the double instantiation).
StratumCoords stratum_coords_of(const brdf::Sample& s) {
    StratumCoords c;
    detail::stratum_coords_body(s.theta_i, s.phi_i, s.theta_o, s.phi_o, c[0], c[1], c[2]);
    return c;
}

using StratumPackets = void (*)(const detail::StratumArrays&, std::size_t);

/// The copy of the packet kernel for gonio::packet_isa(), nullptr for the scalar path.
StratumPackets stratum_packets() {
    static const StratumPackets f =
        isa_kernel<StratumPackets>(nullptr, GONIO_ISA_KERNELS(detail, stratum));
    return f;
}

/// The coordinates of samples [b, e) into out[b, e).
void stratum_range(const std::vector<brdf::Sample>& samples,
                   std::size_t b,
                   std::size_t e,
                   StratumCoords* out) {
    const StratumPackets packets = stratum_packets();
    if (packets == nullptr) {
        for (std::size_t i = b; i < e; ++i) {
            out[i] = stratum_coords_of(samples[i]);
        }
        return;
    }
    // Runs of samples gathered into arrays for the packets.
    constexpr std::size_t kRun = 256;
    double in[4][kRun];
    double res[3][kRun];
    for (std::size_t r = b; r < e; r += kRun) {
        const std::size_t m = std::min(kRun, e - r);
        for (std::size_t j = 0; j < m; ++j) {
            const brdf::Sample& s = samples[r + j];
            in[0][j] = s.theta_i;
            in[1][j] = s.phi_i;
            in[2][j] = s.theta_o;
            in[3][j] = s.phi_o;
        }
        const detail::StratumArrays a{in[0], in[1], in[2], in[3], res[0], res[1], res[2]};
        packets(a, m);
        for (std::size_t j = 0; j < m; ++j) {
            out[r + j] = {res[0][j], res[1][j], res[2][j]};
        }
    }
}

}  // namespace

std::vector<StratumCoords> stratum_coordinates(const std::vector<brdf::Sample>& samples) {
    std::vector<StratumCoords> out;
    resize_huge(out, samples.size());
    // Independent items: the pool's chunks, up to 8192 on the calling thread (the transform
    // costs about 30 ns a sample on packets, a hand-off a few microseconds).
    gonio::parallel_for(samples.size(), 8192, 0, [&](std::size_t, std::size_t b, std::size_t e) {
        stratum_range(samples, b, e, out.data());
    });
    return out;
}

std::vector<brdf::Sample> stratified_reduce(const std::vector<brdf::Sample>& samples,
                                            std::size_t budget,
                                            std::uint64_t seed) {
    if (budget == 0 || budget >= samples.size()) {
        return samples;
    }
    return stratified_reduce(samples, budget, seed, stratum_coordinates(samples));
}

std::vector<brdf::Sample> stratified_reduce(const std::vector<brdf::Sample>& samples,
                                            std::size_t budget,
                                            std::uint64_t seed,
                                            const std::vector<StratumCoords>& coords,
                                            std::vector<std::size_t>* kept) {
    if (kept != nullptr) {
        kept->clear();
    }
    if (budget == 0 || budget >= samples.size()) {
        if (kept != nullptr) {
            kept->resize(samples.size());
            std::iota(kept->begin(), kept->end(), std::size_t{0});
        }
        return samples;
    }
    GONIO_CHECK(coords.size() == samples.size());
    // Cells: theta_h on a square-root scale (as the MERL table: fine near the specular peak),
    // theta_d and phi_d (folded to [0, pi) by the reciprocity of the pair) uniform. The cell
    // count grows with the budget so that each cell keeps a few samples.
    const double cells_wanted = std::max(1.0, static_cast<double>(budget) / 4.0);
    const int n_h = std::max(2, static_cast<int>(std::round(std::cbrt(cells_wanted) * 1.6)));
    const int n_d = std::max(2, static_cast<int>(std::round(std::cbrt(cells_wanted) * 0.9)));
    const int n_p = std::max(1, static_cast<int>(std::round(cells_wanted / (n_h * n_d))));
    // Stratum of every sample, then a counting sort: the members of each stratum in increasing
    // index order.
    const std::size_t n = samples.size();
    std::vector<std::uint32_t> cell_of;
    resize_huge(cell_of, n);
    for (std::size_t i = 0; i < n; ++i) {
        const long ih = std::min(n_h - 1, static_cast<int>(coords[i][0] * n_h));
        const long id = std::min(n_d - 1, static_cast<int>(coords[i][1] * n_d));
        const long ip = std::min(n_p - 1, static_cast<int>(coords[i][2] * n_p));
        cell_of[i] = static_cast<std::uint32_t>((ih * n_d + id) * n_p + ip);
    }
    const std::size_t n_cells = static_cast<std::size_t>(n_h) * n_d * n_p;
    std::vector<std::size_t> start(n_cells + 1, 0);
    for (std::uint32_t c : cell_of) {
        ++start[c + 1];
    }
    for (std::size_t c = 0; c < n_cells; ++c) {
        start[c + 1] += start[c];
    }
    std::vector<std::size_t> members;
    resize_huge(members, n);
    {
        std::vector<std::size_t> fill(start.begin(), start.end() - 1);
        for (std::size_t i = 0; i < n; ++i) {
            members[fill[cell_of[i]]++] = i;
        }
    }
    // Deterministic order of the non-empty strata (by size, then cell index), then water-filling
    // of the budget: small strata keep all their samples, the rest share what remains equally.
    struct Cell {
        long key;
        std::size_t begin, size;
    };
    std::vector<Cell> cells;
    for (std::size_t c = 0; c < n_cells; ++c) {
        if (start[c + 1] > start[c]) {
            cells.push_back({static_cast<long>(c), start[c], start[c + 1] - start[c]});
        }
    }
    std::sort(cells.begin(), cells.end(), [](const Cell& a, const Cell& b) {
        return a.size < b.size || (a.size == b.size && a.key < b.key);
    });
    std::vector<std::size_t> keep(cells.size(), 0);
    std::size_t remaining = budget;
    for (std::size_t k = 0; k < cells.size(); ++k) {
        const std::size_t share = std::max<std::size_t>(1, remaining / (cells.size() - k));
        keep[k] = std::min(cells[k].size, share);
        remaining -= std::min(remaining, keep[k]);
    }
    std::mt19937_64 rng(seed);
    std::vector<brdf::Sample> out;
    out.reserve(budget + cells.size());
    for (std::size_t k = 0; k < cells.size(); ++k) {
        std::size_t* idx = members.data() + cells[k].begin;
        const std::size_t size = cells[k].size;
        const std::size_t m = keep[k];
        // Partial Fisher-Yates: the first m of a seeded permutation.
        for (std::size_t j = 0; j < m; ++j) {
            std::uniform_int_distribution<std::size_t> pick(j, size - 1);
            std::swap(idx[j], idx[pick(rng)]);
        }
        std::sort(idx, idx + m);
        const double w = static_cast<double>(size) / static_cast<double>(m);
        for (std::size_t j = 0; j < m; ++j) {
            brdf::Sample s = samples[idx[j]];
            s.weight *= w;
            out.push_back(s);
            if (kept != nullptr) {
                kept->push_back(idx[j]);
            }
        }
    }
    return out;
}

}  // namespace gonio::fitting
