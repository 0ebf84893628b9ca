#pragma once

// Shared pieces of the image-mode tests: the ground-truth model, how far a measured table is
// from it, and a campaign killed with SIGKILL in a child process.

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "embedded_rig.h"
#include "gonio/acquisition/image/image_binning.h"
#include "gonio/acquisition/shared/campaign_request.h"
#include "gonio/brdf/brdf.h"
#include "gonio/brdf/coords.h"
#include "gonio/brdf/model.h"

namespace gonio::tools::image_test {

/// Ground truth: Lambert (albedo `diffuse`) + one GGX lobe, alpha 0.3, height-correlated Smith,
/// no Fresnel, the same `scale` in each channel.
inline brdf::ModelD lambert_ggx(const brdf::Rgbd& diffuse, double scale) {
    brdf::ModelD m;
    m.has_diffuse = true;
    m.diffuse = diffuse;
    brdf::Lobe<double> l;
    l.distribution = brdf::Distribution::kGgx;
    l.alpha_x = l.alpha_y = 0.3;
    l.shadowing = brdf::Shadowing::kSmithCorrelated;
    l.fresnel.type = brdf::FresnelType::kNone;
    l.scale = brdf::Rgbd::Constant(scale);
    m.lobes.push_back(l);
    return m;
}

/// |mean / truth - 1| in channel `c` of every bin with at least `min_count` samples whose mean
/// directions are both more than acos(0.2) = 78 deg from the horizon-grazing limit (cos >= 0.2).
inline std::vector<double> table_relative_errors(const acquisition::BinnedTable& t,
                                                 const brdf::Brdf& truth,
                                                 int c,
                                                 std::size_t min_count = 10) {
    std::vector<double> rel;
    for (std::size_t b = 0; b < t.size(); ++b) {
        if (t.count(b) < min_count) {
            continue;
        }
        const auto [wi, wo] = brdf::from_half_diff(t.mean_position(b));
        if (wi.z() < 0.2 || wo.z() < 0.2) {
            continue;
        }
        rel.push_back(std::abs(t.mean(b)[c] / truth.eval(wi, wo)[c] - 1));
    }
    return rel;
}

/// The median (the upper one for an even count); NaN for none.
inline double median(std::vector<double> v) {
    if (v.empty()) {
        return std::nan("");
    }
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
}

/// Starts the embedded image rig of `rig_options` in a forked child and runs
/// `campaign(rig)` there (it returns whether the campaign succeeded); the child raises SIGKILL at
/// the `kill_exposure`-th exposure the virtual camera renders (0: never). Returns the child's wait
/// status: exit 0 (success), 2 (campaign failed), 3 (rig did not start), or killed by SIGKILL.
template <class Campaign>
int campaign_in_child(const acquisition::ImageRigOptions& rig_options,
                      std::uint64_t kill_exposure,
                      Campaign campaign) {
    const pid_t pid = fork();
    if (pid != 0) {
        int status = 0;
        waitpid(pid, &status, 0);
        return status;
    }
    auto rig = acquisition::start_image_rig(rig_options, embedded_rig_starter());
    if (!rig) {
        std::fprintf(stderr, "child: %s\n", rig.error().message.c_str());
        _exit(3);
    }
    if (kill_exposure > 0) {
        simulator(**rig)->world().set_exposure_hook([kill_exposure](std::uint64_t n) {
            if (n == kill_exposure) {
                ::raise(SIGKILL);
            }
        });
    }
    _exit(campaign(**rig) ? 0 : 2);
}

}  // namespace gonio::tools::image_test
