// The dataset and the vndf plan's files from a campaign's journal (campaign.h).

#include "campaign_runner.h"
#include "gonio/acquisition/point/fit_pass.h"

namespace gonio::acquisition {

namespace campaign_internal {

Expected<VndfLayout> vndf_pass_from_records(const std::vector<JournalRecord>& records,
                                            const CampaignSpec& spec,
                                            const RigConfig& rig,
                                            VndfNdf* ndf_out) {
    // Pass 0 in plan order, so that the NDF does not depend on the order of measurement.
    std::vector<std::pair<std::uint32_t, RetroMeasurement>> retro;
    for (const JournalRecord& r : records) {
        if (r.type == RecordType::kMeasurement && r.pass == 0) {
            // The luminance of the RGL format (0.2126 R + 0.7152 G + 0.0722 B), as its writer uses.
            const double lum = 0.2126 * r.value[0] + 0.7152 * r.value[1] + 0.0722 * r.value[2];
            retro.push_back({r.index, RetroMeasurement{r.wi, r.wo, lum}});
        }
    }
    std::sort(
        retro.begin(), retro.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    std::vector<RetroMeasurement> m;
    for (const auto& r : retro) {
        m.push_back(r.second);
    }
    auto ndf = vndf_ndf_from_retro(m, spec.vndf);
    if (!ndf) {
        return make_error("vndf plan, second pass: " + ndf.error().message);
    }
    if (ndf_out != nullptr) {
        *ndf_out = *ndf;
    }
    return plan_vndf_layout(ndf->ndf, spec.vndf, rig_limits(rig));
}

}  // namespace campaign_internal

using namespace campaign_internal;

namespace {

/// A fly-scan measurement's exposure path: the directions of the poses latched at its start and
/// end (forward kinematics, as the record's own directions).
void set_exposure_path(const JournalRecord& r, brdf::Sample* s) {
    for (int end = 0; end < 2; ++end) {
        const std::array<double, 4>& d = end ? r.path_end_deg : r.path_start_deg;
        const auto [wi, wo] =
            brdf::rig_forward(RigPosed{d[0] * kDeg, d[1] * kDeg, d[2] * kDeg, d[3] * kDeg});
        const auto si = brdf::cartesian_to_spherical(wi);
        const auto so = brdf::cartesian_to_spherical(wo);
        (end ? s->path_end : s->path_start) = {si.theta, si.phi, so.theta, so.phi};
    }
    s->has_path = true;
}

}  // namespace

Expected<std::vector<brdf::Sample>> campaign_samples(const std::string& dir,
                                                     bool references,
                                                     double rig_hours) {
    auto jn = Journal::open((fs::path(dir) / "journal.log").string());
    if (!jn) {
        return tl::unexpected(jn.error());
    }
    auto rig = read_rig_config((fs::path(dir) / "rig.json").string());
    if (!rig) {
        return tl::unexpected(rig.error());
    }
    auto spec = read_campaign_spec((fs::path(dir) / "campaign.json").string());
    if (!spec) {
        return tl::unexpected(spec.error());
    }
    std::vector<brdf::Sample> samples;
    for (const JournalRecord& r : jn->records()) {
        const bool wanted =
            r.type == RecordType::kMeasurement || (references && r.type == RecordType::kReference);
        if (!wanted) {
            continue;
        }
        brdf::Sample s = sample_of_record(r);
        if (r.has_path) {
            set_exposure_path(r, &s);
        }
        samples.push_back(s);
    }
    add_error_budget(rig->error_budget, rig_hours, isotropic_plan(*spec), &samples);
    return samples;
}

Expected<std::size_t> write_campaign_dataset(const std::string& dir, double rig_hours) {
    auto samples = campaign_samples(dir, true, rig_hours);
    if (!samples) {
        return tl::unexpected(samples.error());
    }
    brdf::Dataset ds;
    ds.source = dir;
    ds.has_sigma = ds.has_weight = ds.has_flags = true;
    ds.samples = std::move(*samples);
    for (const brdf::Sample& smp : ds.samples) {
        ds.has_path = ds.has_path || smp.has_path;
    }
    if (auto w = brdf::write_dataset_csv((fs::path(dir) / "dataset.csv").string(), ds); !w) {
        return tl::unexpected(w.error());
    }
    return ds.samples.size();
}

// ---------------------------------------------------------------------------------------------
// The vndf plan's second pass and its RGL file

Expected<VndfLayout> vndf_second_pass(const std::string& dir,
                                      const CampaignSpec& spec,
                                      const RigConfig& rig,
                                      VndfNdf* ndf) {
    auto jn = Journal::open((fs::path(dir) / "journal.log").string());
    if (!jn) {
        return tl::unexpected(jn.error());
    }
    return vndf_pass_from_records(jn->records(), spec, rig, ndf);
}

Expected<VndfFileReport> write_vndf_bsdf(const std::string& dir) {
    auto spec = read_campaign_spec((fs::path(dir) / "campaign.json").string());
    if (!spec) {
        return tl::unexpected(spec.error());
    }
    auto rig = read_rig_config((fs::path(dir) / "rig.json").string());
    if (!rig) {
        return tl::unexpected(rig.error());
    }
    auto jn = Journal::open((fs::path(dir) / "journal.log").string());
    if (!jn) {
        return tl::unexpected(jn.error());
    }
    auto layout = vndf_pass_from_records(jn->records(), *spec, *rig, nullptr);
    if (!layout) {
        return tl::unexpected(layout.error());
    }
    // Pass 1 measurements by configuration; a configuration measured twice (a repeat after a
    // torn journal record) is averaged.
    const std::size_t n = layout->plan.configs.size();
    std::vector<brdf::Rgbd> sum(n, brdf::Rgbd::Zero());
    std::vector<int> count(n, 0);
    for (const JournalRecord& r : jn->records()) {
        if (r.type == RecordType::kMeasurement && r.pass == 1 && r.index < n) {
            sum[r.index] += r.value;
            ++count[r.index];
        }
    }
    std::vector<brdf::Rgbd> f_r(n);
    for (std::size_t k = 0; k < n; ++k) {
        f_r[k] = count[k] > 0 ? brdf::Rgbd(sum[k] / count[k])
                              : brdf::Rgbd::Constant(std::numeric_limits<double>::quiet_NaN());
    }
    VndfFileReport report;
    auto file = vndf_tensor(*layout, f_r, &report);
    if (!file) {
        return make_error(dir + ": " + file.error().message);
    }
    if (auto w = write_file_atomic((fs::path(dir) / kVndfBsdfName).string(),
                                   brdf::encode_tensor_file(*file));
        !w) {
        return tl::unexpected(w.error());
    }
    return report;
}

}  // namespace gonio::acquisition
