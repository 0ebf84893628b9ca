// Fuzz target for the campaign description reader (acquisition::parse_campaign_spec) and the plan
// it describes. Properties: a failure names the source and leaks no internals; a success holds
// counts within the documented plan limits, paths that stay beside the campaign file, and a plan
// that builds (or is refused with a message) without exceeding the limits.

#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_support.h"
#include "gonio/acquisition/plans/plan.h"
#include "gonio/acquisition/point/campaign.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    namespace acq = gonio::acquisition;
    const std::string text(reinterpret_cast<const char*>(data), size);
    gonio::Expected<acq::CampaignSpec> s = acq::parse_campaign_spec(text, "campaign.json");
    if (!s) {
        gonio::fuzz::check_message("campaign_json", s.error().message, "campaign.json", data, size);
        return 0;
    }
    gonio::fuzz::require(s->uniform.n_theta <= acq::kMaxPlanAxis &&
                             s->uniform.n_dphi <= acq::kMaxPlanAxis &&
                             s->half_diff.n_theta_h <= acq::kMaxPlanAxis &&
                             s->half_diff.n_theta_d <= acq::kMaxPlanAxis &&
                             s->half_diff.n_phi_d <= acq::kMaxPlanAxis,
                         "campaign_json",
                         "plan counts within limits");
    gonio::fuzz::require(s->rig.empty() || s->rig[0] != '/', "campaign_json", "rig relative");
    gonio::fuzz::require(s->scene.empty() || s->scene[0] != '/', "campaign_json", "scene relative");
    // The plan itself (no scene: its file is not part of this input).
    acq::CampaignSpec spec = *s;
    spec.scene.clear();
    const double configs =
        spec.plan_kind == "uniform"
            ? 0.5 * spec.uniform.n_theta * (spec.uniform.n_theta + 1.0) * spec.uniform.n_dphi
            : 1.0 * spec.half_diff.n_theta_h * spec.half_diff.n_theta_d * spec.half_diff.n_phi_d;
    if (configs > 20000) {
        // Large plans within the limits are valid; building them is too slow for each input.
        return 0;
    }
    gonio::Expected<acq::Plan> plan = spec.plan_kind == "uniform"
                                          ? acq::plan_uniform(spec.uniform)
                                          : acq::plan_half_diff(spec.half_diff);
    if (plan) {
        gonio::fuzz::require(plan->configs.size() <= static_cast<std::size_t>(acq::kMaxPlanConfigs),
                             "campaign_json",
                             "plan size within the limit");
    } else {
        gonio::fuzz::check_message("campaign_json", plan.error().message, "plan", data, size);
    }
    return 0;
}
