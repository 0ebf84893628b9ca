#include "gonio/acquisition/point/campaign.h"

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <thread>

#include "gonio/acquisition/point/capture_session.h"
#include "gonio/acquisition/point/fit_sweeps.h"
#include "gonio/acquisition/point/fly_sweep.h"
#include "gonio/acquisition/point/journal.h"
#include "gonio/acquisition/point/progress.h"
#include "gonio/acquisition/point/stated_uncertainty.h"
#include "gonio/base/atomic_file.h"
#include "gonio/base/limits.h"
#include "gonio/base/strict_json.h"
#include "gonio/base/strings.h"
#include "gonio/brdf/dataset.h"
#include "gonio/version.h"

namespace gonio::acquisition {

using brdf::kPi;
using brdf::RigPosed;
using brdf::Vec3d;
using nlohmann::json;
namespace fs = std::filesystem;

namespace {

constexpr double kDeg = kPi / 180.0;

double now_s() {
    return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch())
        .count();
}

std::string iso_time(double t, bool for_path) {
    const std::time_t tt = static_cast<std::time_t>(t);
    std::tm tm{};
    gmtime_r(&tt, &tm);
    char buf[40];
    std::strftime(buf, sizeof buf, for_path ? "%Y-%m-%dT%H-%M-%S" : "%Y-%m-%dT%H:%M:%SZ", &tm);
    return buf;
}

Expected<std::string> read_text(const std::string& path) {
    return read_input_file(path, kMaxJsonBytes);
}

Expected<void> write_text_atomic(const std::string& path, const std::string& text) {
    return write_file_atomic(path, text);
}

/// Paths inside a campaign description name files beside it: relative, without "..". Files
/// elsewhere are given on the command line (--rig, --scene). Empty string: acceptable.
std::string contained_path_problem(const std::string& p) {
    if (p.empty()) {
        return {};
    }
    if (p[0] == '/') {
        return "absolute paths are not followed; give a path relative to the campaign file, or "
               "use --rig/--scene";
    }
    for (const auto& part : fs::path(p)) {
        if (part == "..") {
            return "\"..\" is not followed; give a path inside the campaign file's folder, or "
                   "use --rig/--scene";
        }
    }
    return {};
}

double luminance(const brdf::Rgbd& v) {
    return (v[0] + v[1] + v[2]) / 3;
}

std::array<double, 4> pose_deg(const RigPosed& p) {
    return {p.light / kDeg, p.detector / kDeg, p.tilt / kDeg, p.spin / kDeg};
}

/// campaign.json "plan" of kind "fit" (plan_fit.h).
void parse_fit_plan(JsonObject& p, FitPlanSpec* f) {
    f->first = p.integer("first", f->first, 1, kMaxPlanConfigs);
    f->batch = p.integer("batch", f->batch, 1, kMaxPlanConfigs);
    f->budget = p.integer("budget", f->budget, 1, kMaxPlanConfigs);
    f->space_share = p.number("space_share", f->space_share, 0, 1);
    f->theta_max = p.number("theta_max_deg", f->theta_max / kDeg, 1, 89, "deg") * kDeg;
    f->anisotropic = p.boolean("anisotropic", f->anisotropic);
    const std::string sym = p.string("symmetry", to_string(f->symmetry), 16);
    auto parsed = parse_symmetry(sym);
    if (!parsed) {
        json_fail("plan.symmetry = \"" + excerpt(sym) +
                  "\": must be \"none\", \"mirror\" or \"2-fold\"");
    }
    f->symmetry = *parsed;
    if (auto ok = check_fit_plan_spec(*f); !ok) {
        json_fail("plan: " + ok.error().message);
    }
}

/// Why fly scans refuse a rig with a colour filter changer.
constexpr const char* kFlyColourRule =
    "fly scans need a monochrome detector: behind a colour filter changer each colour would be "
    "exposed on a path of its own, and a dataset row holds one path (use a rig without "
    "\"filter_wheel\", e.g. data/rigs/sim4-mono.json, or measure standing)";

/// campaign.json "fly" (fly_plan.h).
void parse_fly(const json& raw, FlySpec* f) {
    JsonObject o(raw, "fly");
    f->enabled = o.boolean("enabled", true);
    f->max_smear_deg = o.number("max_smear_deg", f->max_smear_deg, 1e-3, 10, "deg");
    f->speed_deg_per_s = o.number("speed_deg_per_s", f->speed_deg_per_s, 0, 1000, "deg/s");
    o.finish();
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Campaign description

bool isotropic_plan(const CampaignSpec& spec) {
    return spec.plan_kind != "anisotropic" && !(spec.plan_kind == "fit" && spec.fit.anisotropic);
}

Expected<CampaignSpec> parse_campaign_spec(const std::string& text, const std::string& source) {
    CampaignSpec s;
    s.json = text;
    try {
        const json j = parse_json_checked(text, source);
        JsonObject top(j, "");
        s.sample = top.string("sample", s.sample, kMaxNameLength);
        s.operator_name = top.string("operator", s.operator_name, kMaxNameLength);
        s.notes = top.string("notes", s.notes, kMaxJsonString);
        s.rig = top.string("rig", s.rig, kMaxPathLength);
        s.scene = top.string("scene", s.scene, kMaxPathLength);
        for (const char* key : {"rig", "scene"}) {
            const std::string& p = key[0] == 'r' ? s.rig : s.scene;
            if (auto bad = contained_path_problem(p); !bad.empty()) {
                json_fail(std::string(key) + " = \"" + excerpt(p) + "\": " + bad);
            }
        }
        if (top.has("plan")) {
            JsonObject p(top.raw("plan"), "plan");
            s.plan_kind = p.string("kind", s.plan_kind, 16);
            if (s.plan_kind == "uniform") {
                s.uniform.n_theta = p.integer("n_theta", s.uniform.n_theta, 2, kMaxPlanAxis);
                s.uniform.n_dphi = p.integer("n_dphi", s.uniform.n_dphi, 2, kMaxPlanAxis);
                s.uniform.theta_max =
                    p.number("theta_max_deg", s.uniform.theta_max / kDeg, 1, 89, "deg") * kDeg;
            } else if (s.plan_kind == "half-diff") {
                s.half_diff.n_theta_h =
                    p.integer("n_theta_h", s.half_diff.n_theta_h, 1, kMaxPlanAxis);
                s.half_diff.n_theta_d =
                    p.integer("n_theta_d", s.half_diff.n_theta_d, 1, kMaxPlanAxis);
                s.half_diff.n_phi_d = p.integer("n_phi_d", s.half_diff.n_phi_d, 1, kMaxPlanAxis);
                s.half_diff.theta_max =
                    p.number("theta_max_deg", s.half_diff.theta_max / kDeg, 1, 89, "deg") * kDeg;
            } else if (s.plan_kind == "vndf") {
                s.vndf.retro_count = p.integer("retro_count", s.vndf.retro_count, 4, 512);
                s.vndf.theta_i_count = p.integer("theta_i_count", s.vndf.theta_i_count, 2, 64);
                s.vndf.resolution = p.integer("resolution", s.vndf.resolution, 4, 128);
                s.vndf.ndf_resolution = p.integer("ndf_resolution", s.vndf.ndf_resolution, 16, 512);
                s.vndf.theta_max =
                    p.number("theta_max_deg", s.vndf.theta_max / kDeg, 10.001, 89, "deg") * kDeg;
                s.vndf.phi_i_count = p.integer("phi_i_count", s.vndf.phi_i_count, 0, 64);
                s.vndf.retro_phi_count =
                    p.integer("retro_phi_count", s.vndf.retro_phi_count, 4, 128);
                if (auto ok = check_vndf_spec(s.vndf); !ok) {
                    json_fail("plan: " + ok.error().message);
                }
            } else if (s.plan_kind == "anisotropic") {
                AnisotropicGridSpec& a = s.anisotropic;
                a.n_theta = p.integer("n_theta", a.n_theta, 2, kMaxPlanAxis);
                a.n_dphi = p.integer("n_dphi", a.n_dphi, 2, kMaxPlanAxis);
                a.theta_max = p.number("theta_max_deg", a.theta_max / kDeg, 1, 89, "deg") * kDeg;
                const std::string sym = p.string("symmetry", to_string(a.symmetry), 16);
                auto parsed = parse_symmetry(sym);
                if (!parsed) {
                    json_fail("plan.symmetry = \"" + excerpt(sym) +
                              "\": must be \"none\", \"mirror\" or \"2-fold\"");
                }
                a.symmetry = *parsed;
            } else if (s.plan_kind == "fit") {
                parse_fit_plan(p, &s.fit);
            } else {
                json_fail("plan.kind = \"" + s.plan_kind +
                          "\": must be \"uniform\", \"half-diff\", \"vndf\", \"anisotropic\" "
                          "or \"fit\"");
            }
            p.finish();
        }
        if (top.has("adaptive")) {
            JsonObject a(top.raw("adaptive"), "adaptive");
            s.adaptive = a.boolean("enabled", true);
            s.adaptive_passes = a.integer("passes", s.adaptive_passes, 0, 100);
            s.refine.budget = a.integer("budget", s.refine.budget, 0, kMaxPlanConfigs);
            s.refine.threshold = a.number("threshold", s.refine.threshold, 0, 10);
            s.refine.min_spacing =
                a.number("min_spacing_deg", s.refine.min_spacing / kDeg, 0, 90, "deg") * kDeg;
            a.finish();
        }
        if (top.has("drift")) {
            JsonObject d(top.raw("drift"), "drift");
            s.drift_every = d.integer("every", s.drift_every, 0, kMaxPlanConfigs);
            s.drift_threshold = d.number("threshold", s.drift_threshold, 1e-6, 10);
            s.drift_theta_i_deg = d.number("theta_i_deg", s.drift_theta_i_deg, 0, 89, "deg");
            s.drift_theta_r_deg = d.number("theta_r_deg", s.drift_theta_r_deg, 0, 89, "deg");
            s.drift_delta_phi_deg = d.number("delta_phi_deg", s.drift_delta_phi_deg, 0, 180, "deg");
            d.finish();
        }
        s.schedule_budget_s = top.number("schedule_budget_s", s.schedule_budget_s, 0, 3600, "s");
        if (top.has("fly")) {
            parse_fly(top.raw("fly"), &s.fly);
        }
        s.until = top.string("until", s.until, 256);
        if (!s.until.empty()) {
            auto rule = parse_stop_rule(s.until);
            if (!rule) {
                json_fail(rule.error().message);
            }
            if (s.plan_kind == "vndf") {
                json_fail(
                    "until: the vndf plan writes its RGL file from every node (remove "
                    "\"until\" or use another plan)");
            }
        }
        top.finish();
        if (s.plan_kind == "anisotropic" && s.adaptive && s.adaptive_passes > 0) {
            // The refinement links neighbours in the isotropic canonical space.
            json_fail(
                "adaptive: refinement works in the isotropic (theta_i, theta_r, delta_phi) "
                "space and cannot follow plan.kind \"anisotropic\" (set \"enabled\": "
                "false)");
        }
        if (s.plan_kind == "fit" && s.adaptive && s.adaptive_passes > 0) {
            json_fail(
                "adaptive: the fit plan chooses every batch after the first from the fit "
                "(set \"enabled\": false)");
        }
        if (s.fly.enabled && s.plan_kind == "fit" && s.fit.anisotropic) {
            json_fail(
                "fly: the fit plan's sweeps run along an isotropic sample's lines; an anisotropic "
                "fit plan measures standing (remove \"fly\")");
        }
        if (s.plan_kind == "vndf" && s.adaptive) {
            json_fail(
                "adaptive: the vndf plan places its own second pass from the retro-reflection "
                "measurements (remove \"adaptive\" or use another plan)");
        }
        if (s.plan_kind == "vndf" && !s.scene.empty()) {
            json_fail(
                "scene: the vndf plan measures every node of its RGL file (remove "
                "\"scene\" or use another plan)");
        }
    } catch (const JsonFailure& f) {
        const bool named = f.message.compare(0, source.size(), source) == 0;
        return make_error(named ? f.message : source + ": " + f.message);
    }
    return s;
}

CampaignSpec default_campaign_spec(const std::string& sample) {
    CampaignSpec s;
    s.sample = sample;
    s.plan_kind = "uniform";
    s.uniform.n_theta = 7;
    s.uniform.n_dphi = 5;
    s.uniform.theta_max = 75 * kDeg;
    s.adaptive = true;
    s.adaptive_passes = 1;
    s.refine.budget = 30;
    s.drift_every = 40;
    s.json = campaign_spec_json(s);
    return s;
}

Expected<CampaignSpec> read_campaign_spec(const std::string& path) {
    auto text = read_text(path);
    if (!text) {
        return tl::unexpected(text.error());
    }
    return parse_campaign_spec(*text, path);
}

std::string campaign_spec_json(const CampaignSpec& s) {
    json j;
    j["sample"] = s.sample;
    j["operator"] = s.operator_name;
    j["notes"] = s.notes;
    j["rig"] = s.rig;
    if (!s.scene.empty()) {
        j["scene"] = s.scene;
    }
    if (s.plan_kind == "uniform") {
        j["plan"] = {{"kind", "uniform"},
                     {"n_theta", s.uniform.n_theta},
                     {"n_dphi", s.uniform.n_dphi},
                     {"theta_max_deg", s.uniform.theta_max / kDeg}};
    } else if (s.plan_kind == "vndf") {
        j["plan"] = {{"kind", "vndf"},
                     {"retro_count", s.vndf.retro_count},
                     {"theta_i_count", s.vndf.theta_i_count},
                     {"resolution", s.vndf.resolution},
                     {"ndf_resolution", s.vndf.ndf_resolution},
                     {"theta_max_deg", s.vndf.theta_max / kDeg},
                     {"phi_i_count", s.vndf.phi_i_count},
                     {"retro_phi_count", s.vndf.retro_phi_count}};
    } else if (s.plan_kind == "fit") {
        j["plan"] = {{"kind", "fit"},
                     {"first", s.fit.first},
                     {"batch", s.fit.batch},
                     {"budget", s.fit.budget},
                     {"space_share", s.fit.space_share},
                     {"theta_max_deg", s.fit.theta_max / kDeg},
                     {"anisotropic", s.fit.anisotropic},
                     {"symmetry", to_string(s.fit.symmetry)}};
    } else if (s.plan_kind == "anisotropic") {
        j["plan"] = {{"kind", "anisotropic"},
                     {"n_theta", s.anisotropic.n_theta},
                     {"n_dphi", s.anisotropic.n_dphi},
                     {"theta_max_deg", s.anisotropic.theta_max / kDeg},
                     {"symmetry", to_string(s.anisotropic.symmetry)}};
    } else {
        j["plan"] = {{"kind", "half-diff"},
                     {"n_theta_h", s.half_diff.n_theta_h},
                     {"n_theta_d", s.half_diff.n_theta_d},
                     {"n_phi_d", s.half_diff.n_phi_d},
                     {"theta_max_deg", s.half_diff.theta_max / kDeg}};
    }
    if (s.adaptive) {
        j["adaptive"] = {{"enabled", true},
                         {"passes", s.adaptive_passes},
                         {"budget", s.refine.budget},
                         {"threshold", s.refine.threshold},
                         {"min_spacing_deg", s.refine.min_spacing / kDeg}};
    }
    j["drift"] = {{"every", s.drift_every},
                  {"threshold", s.drift_threshold},
                  {"theta_i_deg", s.drift_theta_i_deg},
                  {"theta_r_deg", s.drift_theta_r_deg},
                  {"delta_phi_deg", s.drift_delta_phi_deg}};
    j["schedule_budget_s"] = s.schedule_budget_s;
    if (s.fly.enabled) {
        j["fly"] = {{"enabled", true},
                    {"max_smear_deg", s.fly.max_smear_deg},
                    {"speed_deg_per_s", s.fly.speed_deg_per_s}};
    }
    if (!s.until.empty()) {
        j["until"] = s.until;
    }
    return j.dump(2) + "\n";
}

Expected<Plan> build_plan(const CampaignSpec& spec, const RigConfig& rig) {
    if (spec.plan_kind == "vndf") {
        if (spec.adaptive) {
            return make_error(
                "vndf plan: adaptive passes asked for; the vndf plan places its own second pass "
                "from the retro-reflection measurements");
        }
        if (!spec.scene.empty()) {
            return make_error("vndf plan: a scene (" + spec.scene +
                              ") asked for; the vndf plan measures every node of its RGL file");
        }
        return plan_vndf_retro(spec.vndf, rig_limits(rig));
    }
    if (spec.plan_kind == "fit") {
        if (spec.adaptive && spec.adaptive_passes > 0) {
            return make_error(
                "fit plan: adaptive passes asked for; the fit plan chooses its own batches");
        }
        if (spec.fly.enabled) {
            auto lines = fit_sweep_pool(spec.fit, spec.fly, spec.scene, rig);
            if (!lines) {
                return tl::unexpected(lines.error());
            }
            return fit_first_sweeps(*lines, spec.fit);
        }
        auto pool = fit_pool_for_rig(spec.fit, spec.scene, rig_limits(rig));
        if (!pool) {
            return pool;
        }
        return fit_first_batch(*pool, spec.fit);
    }
    Expected<Plan> plan = spec.plan_kind == "half-diff"     ? plan_half_diff(spec.half_diff)
                          : spec.plan_kind == "anisotropic" ? plan_anisotropic(spec.anisotropic)
                                                            : plan_uniform(spec.uniform);
    if (!plan) {
        return plan;
    }
    if (!spec.scene.empty()) {
        auto scene = read_scene(spec.scene);
        if (!scene) {
            return tl::unexpected(scene.error());
        }
        apply_roi(*scene, &*plan);
    }
    remove_unreachable(rig_limits(rig), &*plan);
    return plan;
}

std::string auto_campaign_dir(const std::string& parent, const std::string& sample) {
    std::string clean;
    for (char c : sample) {
        clean.push_back(std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' ? c
                                                                                            : '-');
    }
    const std::string base = (fs::path(parent) / (iso_time(now_s(), true) + "_" + clean)).string();
    std::string dir = base;
    for (int k = 2; fs::exists(dir); ++k) {
        dir = base + "-" + std::to_string(k);
    }
    return dir;
}

Expected<void> create_campaign_dir(const std::string& dir,
                                   const CampaignSpec& spec,
                                   const RigConfig& rig) {
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec) {
        return make_error(dir + ": cannot create: " + ec.message());
    }
    if (fs::exists(fs::path(dir) / "journal.log") || fs::exists(fs::path(dir) / "campaign.json")) {
        return make_error(dir + ": already holds a campaign (use --resume " + dir + ")");
    }
    // The scene is copied in as well: a resume must not depend on files outside the folder.
    CampaignSpec stored = spec;
    stored.rig = "rig.json";
    if (!spec.scene.empty()) {
        auto text = read_text(spec.scene);
        if (!text) {
            return tl::unexpected(text.error());
        }
        if (auto w = write_text_atomic((fs::path(dir) / "scene.json").string(), *text); !w) {
            return w;
        }
        stored.scene = "scene.json";
    }
    if (auto w = write_text_atomic((fs::path(dir) / "rig.json").string(), rig.json); !w) {
        return w;
    }
    return write_text_atomic((fs::path(dir) / "campaign.json").string(),
                             campaign_spec_json(stored));
}

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
        brdf::Sample s;
        const auto si = brdf::cartesian_to_spherical(r.wi);
        const auto so = brdf::cartesian_to_spherical(r.wo);
        s.theta_i = si.theta;
        s.phi_i = si.phi;
        s.theta_o = so.theta;
        s.phi_o = so.phi;
        s.value = r.value;
        s.sigma = r.sigma;
        s.weight = r.weight;
        s.flags = r.flags;
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

namespace {

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

}  // namespace

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

// ---------------------------------------------------------------------------------------------
// Runner

namespace {

class Runner {
  public:
    Runner(std::string dir, RigDevices& dev, const RunHooks& hooks)
        : dir_(std::move(dir)), dev_(dev), hooks_(hooks) {}

    Expected<RunResult> run();

  private:
    std::string path(const char* name) const { return (fs::path(dir_) / name).string(); }
    void say(const std::string& s) const {
        if (hooks_.out) {
            std::fprintf(hooks_.out, "%s\n", s.c_str());
            std::fflush(hooks_.out);
        }
    }
    bool stop_requested() const { return hooks_.stop && hooks_.stop->load(); }

    Expected<RigPosed> read_pose();
    Expected<void> move_to(const RigPosed& p);
    Expected<void> home_if_needed();
    /// Moves and measures with bounded retries; a drive alarm pauses at once.
    struct Shot {
        RigPosed pose;  ///< As read back from the axes.
        Vec3d wi, wo;
        SignalRate rate;
    };
    Expected<Shot> attempt(const RigPosed& target, const std::string& what, std::string* pause);
    Expected<Shot> measure_once(const RigPosed& target, const std::string& what);
    Expected<SignalRate> expose();
    /// The axes whose positions differ between `a` and `b` by more than the pose tolerance, in
    /// words ("sample spin 12.000 -> 15.500 deg"); empty when none.
    std::string pose_change(const RigPosed& a, const RigPosed& b) const;
    void note(const std::string& text);
    /// Waits (probing with back-off) until every axis answers again; an error when stopped on
    /// request or when the outage lasts longer than hooks_.max_outage_s.
    Expected<void> wait_for_devices(const std::string& what, const std::string& cause);
    Expected<void> white_calibration(std::string* pause);
    /// Measures the drift reference; sets *pause on drift beyond the threshold.
    Expected<void> drift_check(bool baseline, std::string* pause);
    JournalRecord record_of(RecordType type, const Shot& s, const BrdfValue& v) const;
    Expected<void> write_metadata(const std::string& state, const Plan& plan);
    /// This run's rig time, its stop reason and the stop rule's state into the metadata.
    void record_run(json& meta, json& run, bool running);
    Expected<RunResult> finish(Outcome o, const std::string& msg, const Plan& plan);
    /// This run's rig time so far: the clock's moves, the session's exposures and readouts.
    RigTime rig_time() const;
    /// Rig hours of the whole campaign so far (earlier runs and this one).
    double campaign_rig_hours() const { return (prior_rig_time_s_ + rig_time().total_s()) / 3600; }
    /// Fits the values so far against the stop rule; true when it holds.
    Expected<bool> check_stop_rule(const Plan& plan);

    // The stages of run(), in order.
    /// The campaign's description, rig and plan from its folder; the journal opened and the run
    /// listed in metadata.json.
    Expected<Plan> load_campaign();
    /// The state the journal holds: measurements done, the white reference, the drift baseline.
    /// Returns whether the white reference was measured.
    bool replay_journal();
    void say_plan(const Plan& plan) const;
    /// Homing, the pose read back, the camera prepared, the white reference and the drift
    /// baseline when needed; an error is the reason to pause.
    Expected<void> prepare_devices(bool have_white, std::string* pause);
    /// The configurations of a pass: 0 the plan, then the vndf plan's second pass or an adaptive
    /// refinement (everything derived from the journal, so a resume rebuilds the same passes).
    Expected<Plan> pass_plan(int pass, const Plan& plan);
    Plan adaptive_pass(int pass) const;
    /// The fit-driven plan's batch `pass` (>= 1) from the journal; empty at the budget.
    Plan fit_batch(int pass);
    /// The pass's configurations not yet measured, solved in plan order for continuity.
    void pending_poses(int pass,
                       const Plan& pp,
                       std::vector<const PlannedConfig*>* pending,
                       std::vector<RigPosed>* poses) const;
    /// Measures a pass in scheduled order; a value when the run ends within it (stopped,
    /// paused, or a journal that cannot be written).
    std::optional<Expected<RunResult>> measure_pass(int pass,
                                                    const Plan& pp,
                                                    const Plan& plan,
                                                    std::string* pause);
    /// After each measurement: the stop rule checked every check_every_ measurements; a value
    /// when it holds or its check fails.
    std::optional<Expected<RunResult>> after_measurement(const Plan& plan, Progress* progress);
    /// Before the passes (a resume) or after them: the stop rule on what the journal holds.
    std::optional<Expected<RunResult>> rule_on_journal(const Plan& plan);
    /// One configuration measured and journaled.
    Expected<JournalRecord> measure_config(int pass,
                                           const PlannedConfig& c,
                                           const RigPosed& pose,
                                           std::string* pause,
                                           bool* journal_failed);
    void publish_measurement(const JournalRecord& r) const;
    std::string completion_summary() const;
    /// Before each measurement (or sweep): a stop on request, the drift check when due; a value
    /// when the run ends there.
    std::optional<Expected<RunResult>> before_measurement(const Plan& plan,
                                                          std::string* pause,
                                                          Progress* progress);
    /// One configuration measured standing with the pass's bookkeeping (progress, live page,
    /// stop rule); a value when the run ends there.
    std::optional<Expected<RunResult>> measure_standing(int pass,
                                                        const PlannedConfig& c,
                                                        const RigPosed& pose,
                                                        const Plan& plan,
                                                        std::string* pause,
                                                        Progress* progress);

    // Fly scans (fly_plan.h, fly_sweep.h).
    FlyLimits fly_limits() const;
    /// A pass measured in sweeps, then in one scheduled tour what no sweep measured (no sweep
    /// partner, a saturated frame, a missed trigger); a value when the run ends within it.
    std::optional<Expected<RunResult>> measure_fly_pass(int pass,
                                                        const std::vector<const PlannedConfig*>& c,
                                                        const std::vector<RigPosed>& poses,
                                                        const Plan& plan,
                                                        std::string* pause);
    /// Runs one sweep and journals its values; `standing` receives the members (indices into
    /// the pass's pending list) left to measure standing. A value when the run ends within it.
    std::optional<Expected<RunResult>> fly_sweep(int pass,
                                                 const Sweep& sw,
                                                 const std::vector<const PlannedConfig*>& c,
                                                 const std::vector<RigPosed>& poses,
                                                 const Plan& plan,
                                                 Progress* progress,
                                                 std::vector<std::size_t>* standing);
    /// The sweep's start in the journal (its configurations' plan indices listed), then the arm
    /// at its lead-in; the pose read back there.
    Expected<RigPosed> start_sweep(int pass,
                                   const Sweep& sw,
                                   const std::vector<const PlannedConfig*>& pending);
    /// The journal record of a frame taken during a sweep from pose `stood` (the arm's angle
    /// replaced by its latched path); an error when the frame is no value (saturated, a latch
    /// outside the sweep).
    Expected<JournalRecord> fly_record(int pass,
                                       const PlannedConfig& c,
                                       const Sweep& sw,
                                       const RigPosed& stood,
                                       const FlyFrame& f);

    std::string dir_;
    RigDevices& dev_;
    RunHooks hooks_;
    CampaignSpec spec_;
    RigConfig rig_;
    RigLimits lim_;
    std::array<AxisDynamics, kNumAxes> dyn_;
    std::optional<Journal> journal_;
    std::optional<CaptureSession> session_;
    WhiteCalibration white_;
    RigPosed current_;
    std::size_t since_reference_ = 0;
    std::optional<JournalRecord> baseline_;
    RunResult result_;
    double started_ = 0;
    /// The vndf plan's second pass once placed (metadata.json lists it).
    std::optional<VndfLayout> vndf_pass_;
    VndfNdf vndf_ndf_;
    std::optional<RigClock> clock_;
    /// Rig seconds of the campaign's earlier runs (metadata.json).
    double prior_rig_time_s_ = 0;
    StopRule rule_;
    std::size_t since_check_ = 0;
    std::size_t check_every_ = 0;
    /// The stop rule's last check, for metadata.json (null before the first).
    json until_ = nullptr;
    /// The fit-driven plan's pool (reachable, within the scene) and its batches for metadata.json
    /// (by pass: when chosen, from what, why).
    Plan fit_pool_;
    /// With fly scans, the fit plan's pool is its sweep lines' frames (fit_sweeps.h).
    std::optional<FitSweepPool> fit_lines_;
    json fit_batches_ = json::object();
    /// (pass, index) of every measurement in the journal.
    std::set<std::pair<int, std::uint32_t>> done_;
    std::size_t planned_total_ = 0;
    /// Fly scans: the auto exposure carried from frame to frame (microseconds; 0 before the
    /// first), and frames that gave no value (the arm passed the trigger, or saturated).
    double fly_exposure_us_ = 0;
    std::size_t fly_missed_ = 0;
    std::size_t fly_saturated_ = 0;
};

Expected<RigPosed> Runner::read_pose() {
    double v[kNumAxes];
    for (int k = 0; k < kNumAxes; ++k) {
        auto p = dev_.axes[k]->position_deg();
        if (!p) {
            return tl::unexpected(p.error());
        }
        v[k] = *p * kDeg;
    }
    return RigPosed{v[0], v[1], v[2], v[3]};
}

Expected<void> Runner::home_if_needed() {
    for (int k = 0; k < kNumAxes; ++k) {
        auto st = dev_.axes[k]->status();
        if (!st) {
            return tl::unexpected(st.error());
        }
        if (st->state == devices::AxisState::kAlarm) {
            return make_error("axis \"" + dev_.axes[k]->name() + "\" in alarm (code " +
                              std::to_string(st->alarm_code) +
                              "): clear the cause, then reset the drive");
        }
        if (!st->homed) {
            say("homing axis \"" + dev_.axes[k]->name() + "\"");
            if (auto at = dev_.axes[k]->position_deg(); at) {
                clock_->home(k, *at * kDeg);
            }
            if (auto h = dev_.axes[k]->home(std::chrono::milliseconds(rig_.move_timeout_ms)); !h) {
                return h;
            }
        }
    }
    return {};
}

Expected<void> Runner::move_to(const RigPosed& p) {
    const double target[kNumAxes] = {p.light, p.detector, p.tilt, p.spin};
    const double cur[kNumAxes] = {current_.light, current_.detector, current_.tilt, current_.spin};
    bool moved[kNumAxes] = {false, false, false, false};
    for (int k = 0; k < kNumAxes; ++k) {
        if (std::abs(target[k] - cur[k]) < 1e-7) {
            continue;
        }
        if (auto r = dev_.axes[k]->start_move(target[k] / kDeg); !r) {
            return r;
        }
        moved[k] = true;
    }
    double settle_ms = 0;
    for (int k = 0; k < kNumAxes; ++k) {
        if (!moved[k]) {
            continue;
        }
        if (auto r = dev_.axes[k]->wait_done(std::chrono::milliseconds(rig_.move_timeout_ms)); !r) {
            return r;
        }
        settle_ms = std::max(settle_ms, rig_.axes[k].motion.settle_ms);
    }
    // Mechanical settling after the drives report in position (a physical time, not a wait for
    // a state that could be polled).
    if (settle_ms > 0) {
        std::this_thread::sleep_for(std::chrono::duration<double, std::milli>(settle_ms));
    }
    clock_->move(current_, p);
    current_ = p;
    return {};
}

/// Largest difference between two position read-backs of a standing axis that is not a move:
/// ten steps of the finest shipped profile (1000 steps/deg), well above the rounding of a target
/// to a step.
constexpr double kPoseToleranceDeg = 0.01;
/// A pose that keeps moving during exposures this many times in a row pauses the campaign.
constexpr int kMaxPoseRepeats = 5;

std::string Runner::pose_change(const RigPosed& a, const RigPosed& b) const {
    const auto da = pose_deg(a);
    const auto db = pose_deg(b);
    std::string out;
    for (int k = 0; k < kNumAxes; ++k) {
        if (std::abs(db[k] - da[k]) > kPoseToleranceDeg) {
            char buf[160];
            std::snprintf(buf,
                          sizeof buf,
                          "%s%s %.4f -> %.4f deg",
                          out.empty() ? "" : ", ",
                          dev_.axes[k]->name().c_str(),
                          da[k],
                          db[k]);
            out += buf;
        }
    }
    return out;
}

void Runner::note(const std::string& text) {
    say(text);
    JournalRecord n;
    n.type = RecordType::kNote;
    n.text = text;
    n.time_s = now_s();
    (void)journal_->append(n);
}

Expected<SignalRate> Runner::expose() {
    if (!dev_.filter_wheel) {
        // Monochrome detector: one unfiltered measurement, the same value in r, g and b.
        return session_->measure();
    }
    // Colour through the filter changer: one full (auto-exposed, HDR, dark-subtracted)
    // measurement per filter; channel c of the result is the rate behind filter c.
    SignalRate out;
    for (int c = 0; c < 3; ++c) {
        if (auto f = dev_.filter_wheel->set_filter(c); !f) {
            return tl::unexpected(f.error());
        }
        auto rate = session_->measure();
        if (!rate) {
            return tl::unexpected(rate.error());
        }
        out.rate[c] = rate->rate[c];
        out.sigma[c] = rate->sigma[c];
        out.saturated = out.saturated || rate->saturated;
        out.hdr = out.hdr || rate->hdr;
        out.exposure_us = std::max(out.exposure_us, rate->exposure_us);
        out.pixels = c == 0 ? rate->pixels : std::min(out.pixels, rate->pixels);
    }
    return out;
}

Expected<Runner::Shot> Runner::measure_once(const RigPosed& target, const std::string& what) {
    // Pose integrity: the positions are read back before and after each exposure. An axis found
    // away from its target is moved back first; one that moved during the exposure (another
    // client, a stall, a lost step) makes the measurement repeat. Both are journalled and counted;
    // neither reaches the dataset.
    for (int repeat = 0;; ++repeat) {
        if (auto m = move_to(target); !m) {
            return tl::unexpected(m.error());
        }
        auto before = read_pose();
        if (!before) {
            return tl::unexpected(before.error());
        }
        if (const std::string off = pose_change(target, *before); !off.empty()) {
            ++result_.pose_corrections;
            note("pose check: before the exposure of " + what + " the axes were off target (" +
                 off + "); moved back");
            current_ = *before;  // So that move_to commands every axis that is off.
            if (repeat >= kMaxPoseRepeats) {
                return make_error("pose check: the axes do not stay on target for " + what + " (" +
                                  off + ")");
            }
            continue;
        }
        auto rate = expose();
        if (!rate) {
            return tl::unexpected(rate.error());
        }
        auto after = read_pose();
        if (!after) {
            return tl::unexpected(after.error());
        }
        if (const std::string moved = pose_change(*before, *after); !moved.empty()) {
            ++result_.pose_repeats;
            note("pose check: an axis moved during the exposure of " + what + " (" + moved +
                 "); the measurement is repeated");
            current_ = *after;
            if (repeat >= kMaxPoseRepeats) {
                return make_error("pose check: axes keep moving during the exposures of " + what +
                                  " (" + moved + ")");
            }
            continue;
        }
        Shot s;
        s.rate = *rate;
        s.pose = *before;
        const auto [wi, wo] = brdf::rig_forward(*before);
        s.wi = wi;
        s.wo = wo;
        return s;
    }
}

Expected<void> Runner::wait_for_devices(const std::string& what, const std::string& cause) {
    ++result_.outages;
    note("devices unreachable during " + what + " (" + cause +
         "): the campaign is paused and resumes on its own when they answer again (Ctrl-C "
         "stops it with its state saved)");
    const double t0 = now_s();
    double wait_s = hooks_.outage_probe_s;
    while (!stop_requested()) {
        std::this_thread::sleep_for(std::chrono::duration<double>(wait_s));  // Probe pacing.
        bool all = true;
        for (int k = 0; k < kNumAxes && all; ++k) {
            all = static_cast<bool>(dev_.axes[k]->status());
        }
        const double down_s = now_s() - t0;
        if (all) {
            char buf[120];
            std::snprintf(buf, sizeof buf, "devices answer again after %.1f s: resuming", down_s);
            note(buf);
            return {};
        }
        if (down_s > hooks_.max_outage_s) {
            return make_error("devices unreachable for more than " +
                              std::to_string(static_cast<long>(hooks_.max_outage_s)) +
                              " s during " + what + " (" + cause +
                              "); the campaign is paused with its state saved");
        }
        wait_s = std::min(2 * wait_s, 8 * hooks_.outage_probe_s);
    }
    return make_error("stopped on request while the devices were unreachable during " + what);
}

Expected<Runner::Shot> Runner::attempt(const RigPosed& target,
                                       const std::string& what,
                                       std::string* pause) {
    std::string last;
    for (int a = 0; a <= rig_.retries; ++a) {
        auto s = measure_once(target, what);
        if (s) {
            return s;
        }
        last = s.error().message;
        // A drive alarm is a safety stop: never retried automatically. A device that does not
        // answer (an outage longer than the bus's reconnect window) is waited for.
        bool unreachable = false;
        for (int k = 0; k < kNumAxes && !unreachable; ++k) {
            auto st = dev_.axes[k]->status();
            unreachable = !st;
            if (st && st->state == devices::AxisState::kAlarm) {
                *pause = "axis \"" + dev_.axes[k]->name() + "\" raised alarm code " +
                         std::to_string(st->alarm_code) + " during " + what + " (" + last +
                         "); the campaign is paused with its state saved: clear the cause, reset "
                         "the drive, then resume";
                return make_error(*pause);
            }
        }
        if (unreachable) {
            if (auto w = wait_for_devices(what, last); !w) {
                *pause = w.error().message;
                return tl::unexpected(w.error());
            }
            if (auto p = read_pose(); p) {
                current_ = *p;
            }
            session_->clear_dark_cache();
            --a;  // The outage is not a failed attempt.
            continue;
        }
        say("device error during " + what + " (attempt " + std::to_string(a + 1) + "/" +
            std::to_string(rig_.retries + 1) + "): " + last);
        // The position is unknown after a failed move: read it back before the next attempt.
        if (auto p = read_pose(); p) {
            current_ = *p;
        }
        session_->clear_dark_cache();
    }
    *pause = "device fault during " + what + " after " + std::to_string(rig_.retries + 1) +
             " attempts: " + last + "; the campaign is paused with its state saved";
    return make_error(*pause);
}

JournalRecord Runner::record_of(RecordType type, const Shot& s, const BrdfValue& v) const {
    JournalRecord r;
    r.type = type;
    r.wi = s.wi;
    r.wo = s.wo;
    r.pose_deg = pose_deg(s.pose);
    r.value = v.value;
    r.sigma = v.sigma;
    r.rate = s.rate.rate;
    r.rate_sigma = s.rate.sigma;
    r.exposure_us = s.rate.exposure_us;
    r.time_s = now_s();
    if (s.rate.saturated) {
        r.flags |= brdf::kFlagSaturated;
    }
    if (s.rate.hdr) {
        r.flags |= brdf::kFlagHdr;
    }
    return r;
}

Expected<void> Runner::white_calibration(std::string* pause) {
    char reflectance[32];
    std::snprintf(reflectance, sizeof reflectance, "%.4g", rig_.white_reflectance);
    say(std::string("white reference: measuring (reflectance ") + reflectance + ")");
    auto mount = [&](bool white) -> Expected<void> {
        if (dev_.reference_changer) {
            return dev_.reference_changer->set_shutter_open(white);
        }
        if (hooks_.mount) {
            return hooks_.mount(white);
        }
        return make_error("the rig has no reference changer and no operator prompt is available");
    };
    if (auto m = mount(true); !m) {
        return m;
    }
    const Vec3d wi = brdf::spherical_to_cartesian(rig_.white_theta_i_deg * kDeg, 0.0);
    const Vec3d wo = brdf::spherical_to_cartesian(rig_.white_theta_o_deg * kDeg, kPi);
    auto sol = solve(Target{wi, wo, true, true}, lim_, dyn_, current_);
    if (!sol) {
        (void)mount(false);
        return make_error("white reference geometry unreachable: " + sol.error().message);
    }
    auto s = attempt(sol->pose, "the white reference", pause);
    if (auto m = mount(false); !m) {
        return m;
    }
    if (!s) {
        return tl::unexpected(s.error());
    }
    WhiteCalibration w;
    w.reflectance = rig_.white_reflectance;
    w.cos_theta_w = s->wi.z();
    w.rate = s->rate.rate;
    w.rate_sigma = s->rate.sigma;
    if (s->rate.saturated) {
        return make_error(
            "white reference saturated at the shortest exposure: lower the lamp "
            "power or the gain");
    }
    if (auto v = validate(w); !v) {
        return v;
    }
    BrdfValue bv;
    bv.value = brdf::Rgbd::Constant(w.reflectance / kPi);
    JournalRecord r = record_of(RecordType::kWhite, *s, bv);
    if (auto a = journal_->append(r); !a) {
        return a;
    }
    white_ = w;
    return {};
}

Expected<void> Runner::drift_check(bool baseline, std::string* pause) {
    const Vec3d wi = brdf::spherical_to_cartesian(spec_.drift_theta_i_deg * kDeg, 0.0);
    const Vec3d wo = brdf::spherical_to_cartesian(spec_.drift_theta_r_deg * kDeg,
                                                  spec_.drift_delta_phi_deg * kDeg);
    // An anisotropic sample reads differently at every spin: its reference is held at one spin,
    // the directions fixed in the sample's frame, so that only the lamp can change the reading.
    const bool isotropic =
        isotropic_plan(spec_) && !(spec_.plan_kind == "vndf" && spec_.vndf.phi_i_count >= 2);
    auto sol = solve(Target{wi, wo, isotropic, true}, lim_, dyn_, current_);
    if (!sol) {
        return make_error("drift reference configuration unreachable: " + sol.error().message);
    }
    auto s = attempt(sol->pose, "the drift reference", pause);
    if (!s) {
        return tl::unexpected(s.error());
    }
    auto v = rate_to_brdf(white_, s->rate.rate, s->rate.sigma, s->wi.z());
    if (!v) {
        return tl::unexpected(v.error());
    }
    JournalRecord r = record_of(RecordType::kReference, *s, *v);
    r.flags |= brdf::kFlagReference;
    r.text = baseline ? "baseline" : "check";
    if (auto a = journal_->append(r); !a) {
        return a;
    }
    since_reference_ = 0;
    if (baseline || !baseline_) {
        baseline_ = r;
        return {};
    }
    const double v0 = luminance(baseline_->value);
    const double v1 = luminance(r.value);
    const double rel = v0 > 0 ? std::abs(v1 / v0 - 1) : 0;
    const double noise = (v0 > 0 && v1 > 0)
                             ? std::hypot(luminance(baseline_->sigma) / v0, luminance(r.sigma) / v1)
                             : 0;
    if (rel > spec_.drift_threshold && rel > 3 * noise) {
        char buf[400];
        std::snprintf(buf,
                      sizeof buf,
                      "lamp drift: the reference configuration (theta_i %.0f, theta_r %.0f, "
                      "delta_phi %.0f deg) reads %.4g 1/sr against %.4g at the baseline (%+.1f%%, "
                      "threshold %.1f%%). The campaign is paused with its state saved: check the "
                      "lamp, then resume (add --accept-drift to take the current level as the new "
                      "baseline)",
                      spec_.drift_theta_i_deg,
                      spec_.drift_theta_r_deg,
                      spec_.drift_delta_phi_deg,
                      v1,
                      v0,
                      100 * (v1 / v0 - 1),
                      100 * spec_.drift_threshold);
        *pause = buf;
        return make_error(*pause);
    }
    return {};
}

Expected<void> Runner::write_metadata(const std::string& state, const Plan& plan) {
    json meta = json::object();
    if (auto old = read_text(path("metadata.json")); old) {
        try {
            meta = parse_json_checked(*old, path("metadata.json"));
        } catch (const JsonFailure& f) {
            say("metadata.json unreadable (" + f.message + "); written anew from the journal");
            meta = json::object();
        }
        if (!meta.is_object()) {
            meta = json::object();
        }
    }
    meta["sample"] = spec_.sample;
    meta["operator"] = spec_.operator_name;
    meta["notes"] = spec_.notes;
    meta["software"] = {{"name", "gonio"}, {"version", GONIO_VERSION_STRING}};
    meta["rig"] = {{"name", rig_.name}, {"description", json::parse(rig_.json)}};
    auto unreachable_of = [](const Plan& p) {
        json list = json::array();
        for (const UnreachableConfig& u : p.unreachable) {
            const auto c = brdf::to_canonical(u.wi, u.wo);
            list.push_back({{"theta_i_deg", c.theta_i / kDeg},
                            {"theta_r_deg", c.theta_r / kDeg},
                            {"delta_phi_deg", c.delta_phi / kDeg},
                            {"reason", u.reason}});
        }
        return list;
    };
    const json unreachable = unreachable_of(plan);
    if (vndf_pass_) {
        // The vndf plan's second pass, placed from the retro-reflection measurements.
        meta["vndf"] = {{"retro_measurements", vndf_ndf_.measured},
                        {"power_iterations", vndf_ndf_.ndf.iterations},
                        {"last_retro_theta_deg", vndf_ndf_.theta_last / kDeg},
                        {"configurations", vndf_pass_->plan.configs.size()},
                        {"file_nodes", vndf_pass_->layout.nodes.size()},
                        {"below_horizon", vndf_pass_->below_horizon},
                        {"unreachable", unreachable_of(vndf_pass_->plan)}};
    }
    meta["plan"] = {{"kind", plan.kind},
                    {"description", json::parse(spec_.json)},
                    {"configurations", plan.configs.size()},
                    {"naive_4d_grid", plan.naive_count},
                    {"outside_roi", plan.outside_roi},
                    {"unreachable", unreachable}};
    meta["calibration"] = {
        {"white_reflectance", white_.reflectance},
        {"white_cos_theta_i", white_.cos_theta_w},
        {"white_rate_counts_per_us", {white_.rate[0], white_.rate[1], white_.rate[2]}},
        {"white_rate_sigma", {white_.rate_sigma[0], white_.rate_sigma[1], white_.rate_sigma[2]}},
        {"method", "docs/calibration.md"},
        {"colour", dev_.filter_wheel ? "filter_wheel" : "mono"}};
    if (!meta.contains("created")) {
        meta["created"] = iso_time(started_, false);
    }
    if (!meta.contains("runs")) {
        meta["runs"] = json::array();
    }
    const bool running = state == "running";
    // A run is told apart by its start time and its process id (two runs may start within one
    // second).
    const long pid = static_cast<long>(::getpid());
    const std::string started = iso_time(started_, false);
    auto is_this_run = [&](const json& r) {
        return r.is_object() && r.value("started", "") == started && r.contains("pid") &&
               r["pid"].is_number_integer() && r["pid"].get<long>() == pid;
    };
    json run = {{"started", started},
                {"pid", pid},
                {"ended", running ? json(nullptr) : json(iso_time(now_s(), false))},
                {"state", state},
                {"measured", result_.measured_now}};
    if (!meta["runs"].is_array()) {
        meta["runs"] = json::array();
    }
    for (json& old : meta["runs"]) {
        // A run still marked "running" that is not this one never wrote its end: the process was
        // killed (kill -9, power cut, crash). Its measurements are in the journal.
        if (old.is_object() && old.value("state", "") == "running" && !is_this_run(old)) {
            old["state"] = "killed";
            old["ended"] =
                "unknown: the process stopped without writing its end (killed or power "
                "cut); its finished measurements are in journal.log";
        }
    }
    record_run(meta, run, running);
    // The run in progress is the last element while it lasts.
    if (!meta["runs"].empty() && is_this_run(meta["runs"].back()) &&
        meta["runs"].back().value("state", "") == "running") {
        meta["runs"].back() = run;
    } else {
        meta["runs"].push_back(run);
    }
    meta["state"] = state;
    meta["measured"] = result_.measured_total;
    meta["pose_repeats"] = result_.pose_repeats;
    meta["pose_corrections"] = result_.pose_corrections;
    meta["device_outages"] = result_.outages;
    meta["planned"] = result_.planned_total;
    // The campaign's rig time: every run's (a killed run's as of its last metadata write).
    double total = 0;
    for (const json& r : meta["runs"]) {
        if (r.is_object() && r.contains("rig_time_s") && r["rig_time_s"].is_number()) {
            total += r["rig_time_s"].get<double>();
        }
    }
    meta["rig_time_s"] = total;
    result_.campaign_rig_time_s = total;
    prior_rig_time_s_ = total - result_.rig_time.total_s();
    if (!until_.is_null()) {
        meta["until"] = until_;
    }
    if (spec_.plan_kind == "fit") {
        // Batches chosen by an earlier run stay as they were recorded.
        json batches = meta.contains("fit_plan") && meta["fit_plan"].is_object() &&
                               meta["fit_plan"].contains("batches") &&
                               meta["fit_plan"]["batches"].is_object()
                           ? meta["fit_plan"]["batches"]
                           : json::object();
        for (auto it = fit_batches_.begin(); it != fit_batches_.end(); ++it) {
            if (!batches.contains(it.key())) {
                batches[it.key()] = it.value();
            }
        }
        meta["fit_plan"] = {{"pool", fit_pool_.configs.size()}, {"batches", batches}};
    }
    return write_text_atomic(path("metadata.json"), meta.dump(2) + "\n");
}

void Runner::record_run(json& meta, json& run, bool running) {
    (void)meta;
    result_.rig_time = rig_time();
    const RigTime& t = result_.rig_time;
    run["rig_time_s"] = t.total_s();
    run["rig_time"] = {{"motion_s", t.motion_s},
                       {"settle_s", t.settle_s},
                       {"exposure_s", t.exposure_s},
                       {"readout_s", t.readout_s}};
    if (!running) {
        run["stopped"] = result_.stopped;
    }
    if (spec_.fly.enabled) {
        run["fly"] = {{"sweeps", result_.sweeps},
                      {"swept", result_.swept},
                      {"standing", result_.standing},
                      {"missed_triggers", fly_missed_},
                      {"saturated_frames", fly_saturated_},
                      {"moving_frames", session_ ? session_->moving_frames() : 0},
                      {"moving_exposure_s", session_ ? session_->moving_exposure_s() : 0.0}};
    }
}

RigTime Runner::rig_time() const {
    RigTime t = clock_ ? clock_->spent() : RigTime{};
    if (session_) {
        t.exposure_s += session_->exposure_s_taken();
        t.readout_s +=
            static_cast<double>(session_->frames_taken()) * rig_.camera_readout_ms / 1000.0;
    }
    return t;
}

Expected<RunResult> Runner::finish(Outcome o, const std::string& msg, const Plan& plan) {
    result_.outcome = o;
    result_.message = msg;
    if (result_.stopped.empty()) {
        result_.stopped = o == Outcome::kCompleted     ? "plan end"
                          : o == Outcome::kInterrupted ? "interrupted"
                                                       : "fault";
    }
    const char* state = o == Outcome::kCompleted     ? "completed"
                        : o == Outcome::kInterrupted ? "interrupted"
                                                     : "paused";
    if (o != Outcome::kCompleted) {
        JournalRecord note;
        note.type = RecordType::kNote;
        note.text = std::string(state) + ": " + msg;
        note.time_s = now_s();
        (void)journal_->append(note);
    }
    auto n = write_campaign_dataset(dir_, campaign_rig_hours());
    if (!n) {
        return tl::unexpected(n.error());
    }
    if (o == Outcome::kCompleted && spec_.plan_kind == "vndf") {
        auto rep = write_vndf_bsdf(dir_);
        if (!rep) {
            return tl::unexpected(rep.error());
        }
        result_.message += "; RGL material file " + (fs::path(dir_) / kVndfBsdfName).string() +
                           ": " + std::to_string(rep->measured) + " of " +
                           std::to_string(rep->nodes) + " nodes measured, " +
                           std::to_string(rep->filled) + " from their nearest measured node, " +
                           std::to_string(rep->below_horizon) + " below the horizon";
    }
    if (auto m = write_metadata(state, plan); !m) {
        return tl::unexpected(m.error());
    }
    return result_;
}

Expected<bool> Runner::check_stop_rule(const Plan& plan) {
    since_check_ = 0;
    auto samples = campaign_samples(dir_, false, campaign_rig_hours());
    if (!samples) {
        return tl::unexpected(samples.error());
    }
    if (samples->size() < kMinCheckSamples) {
        return false;
    }
    std::vector<brdf::Sample> fit, holdout;
    split_holdout(*samples, &fit, &holdout);
    auto check = hooks_.fit_check(fit, holdout, brdf::common_relative_sigma(rig_.error_budget));
    if (!check) {
        // A fit that fails (too few values for the model, say) is no verdict: measure on.
        say("until: no fit at " + std::to_string(samples->size()) +
            " values: " + check.error().message);
        return false;
    }
    std::string why;
    const bool held = rule_holds(rule_, *check, &why);
    const double rig_s = prior_rig_time_s_ + rig_time().total_s();
    char at[160];
    std::snprintf(at, sizeof at, "%zu measurements, rig time %.1f s", samples->size(), rig_s);
    say(std::string("until ") + spec_.until + ": " + (held ? "held" : "not yet") + " at " + at +
        ": " + why);
    until_ = {
        {"rule", format_stop_rule(rule_)},
        {"held", held},
        {"measurements", samples->size()},
        {"planned", plan.configs.size()},
        {"rig_time_s", rig_s},
        {"max_rel_sigma", check->max_rel_sigma},
        {"worst_parameter", check->worst},
        {"holdout_rms_z", check->holdout_rms_z},
        {"fitted", check->fitted},
        {"held_out", check->held_out},
        {"parameters", check->parameters},
        {"message", std::string(held ? "target held at " : "last check at ") + at + ": " + why}};
    if (held) {
        result_.target_reached = true;
        result_.stopped = "target reached";
        result_.until = until_["message"].get<std::string>();
    }
    // The metadata keeps the check (and this run's rig time) even if the process is killed next.
    if (auto m = write_metadata("running", plan); !m) {
        return tl::unexpected(m.error());
    }
    return held;
}

Expected<Plan> Runner::load_campaign() {
    auto spec = read_campaign_spec(path("campaign.json"));
    if (!spec) {
        return tl::unexpected(spec.error());
    }
    spec_ = *spec;
    if (!spec_.scene.empty() && fs::path(spec_.scene).is_relative()) {
        spec_.scene = path(spec_.scene.c_str());
    }
    auto rig = read_rig_config(path("rig.json"));
    if (!rig) {
        return tl::unexpected(rig.error());
    }
    rig_ = *rig;
    lim_ = rig_limits(rig_);
    dyn_ = rig_dynamics(rig_);
    clock_.emplace(dyn_, rig_.camera_readout_ms / 1000.0);
    if (spec_.fly.enabled && dev_.filter_wheel) {
        return make_error(kFlyColourRule);
    }
    if (!spec_.until.empty()) {
        auto rule = parse_stop_rule(spec_.until);
        if (!rule) {
            return tl::unexpected(rule.error());
        }
        rule_ = *rule;
        if (!hooks_.fit_check) {
            return make_error("the campaign stops by its rule (until " + spec_.until +
                              "), which needs a fit between batches; none was given");
        }
    }
    auto plan0 = build_plan(spec_, rig_);
    if (!plan0) {
        return tl::unexpected(plan0.error());
    }
    if (spec_.plan_kind == "fit") {
        if (spec_.fly.enabled) {
            auto lines = fit_sweep_pool(spec_.fit, spec_.fly, spec_.scene, rig_);
            if (!lines) {
                return tl::unexpected(lines.error());
            }
            fit_lines_ = std::move(*lines);
            fit_pool_ = fit_lines_->pool;
        } else {
            auto pool = fit_pool_for_rig(spec_.fit, spec_.scene, lim_);
            if (!pool) {
                return tl::unexpected(pool.error());
            }
            fit_pool_ = std::move(*pool);
        }
        if (!hooks_.plan_fit) {
            say("fit plan: no fit available; every batch fills space");
        }
    }
    auto jn = Journal::open(path("journal.log"));
    if (!jn) {
        return tl::unexpected(jn.error());
    }
    journal_.emplace(std::move(*jn));
    // The run is listed from its start, so a run that is killed still appears in runs[].
    if (auto m = write_metadata("running", *plan0); !m) {
        return tl::unexpected(m.error());
    }
    if (journal_->torn_tail()) {
        say("journal: the last record was cut short by the previous stop; its measurement will "
            "be repeated");
    }
    return plan0;
}

bool Runner::replay_journal() {
    bool have_white = false;
    for (const JournalRecord& r : journal_->records()) {
        switch (r.type) {
            case RecordType::kMeasurement:
                done_.insert({r.pass, r.index});
                ++since_reference_;
                break;
            case RecordType::kWhite:
                have_white = true;
                white_.reflectance = rig_.white_reflectance;
                white_.cos_theta_w = r.wi.z();
                white_.rate = r.rate;
                white_.rate_sigma = r.rate_sigma;
                break;
            case RecordType::kReference:
                since_reference_ = 0;
                if (!baseline_ || r.text == "baseline") {
                    baseline_ = r;
                }
                break;
            case RecordType::kNote:
            case RecordType::kSweep:
                break;
        }
    }
    result_.measured_total = done_.size();
    return have_white;
}

void Runner::say_plan(const Plan& plan) const {
    say("plan: " + plan.kind + ", " + std::to_string(plan.configs.size()) +
        " configurations (naive 4D grid of the same resolution: " +
        std::to_string(plan.naive_count) + ", reduction x" +
        std::to_string(plan.configs.empty() ? 0 : plan.naive_count / plan.configs.size()) + ")" +
        (plan.outside_roi ? ", " + std::to_string(plan.outside_roi) + " outside the scene's ROI"
                          : std::string()) +
        (plan.unreachable.empty() ? std::string()
                                  : ", " + std::to_string(plan.unreachable.size()) +
                                        " unreachable (first: " + plan.unreachable.front().reason +
                                        "; all listed in metadata.json)"));
    if (!done_.empty()) {
        say("resuming: " + std::to_string(done_.size()) + " measurements already in the journal");
    }
}

Expected<void> Runner::prepare_devices(bool have_white, std::string* pause) {
    if (hooks_.home) {
        if (auto h = home_if_needed(); !h) {
            return h;
        }
    }
    auto pose = read_pose();
    if (!pose) {
        return tl::unexpected(pose.error());
    }
    current_ = *pose;
    session_.emplace(dev_.camera.get(), dev_.shutter.get(), rig_.capture, rig_.noise);
    session_->set_frame_observer(hooks_.on_frame);
    if (auto p = session_->prepare(); !p) {
        return make_error("camera: " + p.error().message);
    }
    if (!have_white) {
        if (auto w = white_calibration(pause); !w) {
            return w;
        }
    }
    if (spec_.drift_every > 0) {
        const bool rebase = !baseline_ || hooks_.accept_drift;
        if (auto d = drift_check(rebase, pause); !d) {
            return d;
        }
    }
    return {};
}

Plan Runner::adaptive_pass(int pass) const {
    std::vector<std::pair<std::pair<int, std::uint32_t>, MeasuredPoint>> pts;
    for (const JournalRecord& r : journal_->records()) {
        if (r.type == RecordType::kMeasurement && r.pass < pass) {
            pts.push_back({{r.pass, r.index},
                           MeasuredPoint{brdf::to_canonical(r.wi, r.wo), luminance(r.value)}});
        }
    }
    std::sort(
        pts.begin(), pts.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    std::vector<MeasuredPoint> mp;
    for (const auto& p : pts) {
        mp.push_back(p.second);
    }
    Plan pp = plan_refine(mp, spec_.refine);
    if (!spec_.scene.empty()) {
        auto scene = read_scene(spec_.scene);
        if (scene) {
            apply_roi(*scene, &pp);
        }
    }
    remove_unreachable(lim_, &pp);
    return pp;
}

Plan Runner::fit_batch(int pass) {
    FitBatch b = fit_lines_
                     ? fit_next_sweeps(
                           journal_->records(), pass, *fit_lines_, spec_.fit, rig_, hooks_.plan_fit)
                     : fit_next_batch(
                           journal_->records(), pass, fit_pool_, spec_.fit, rig_, hooks_.plan_fit);
    if (!b.plan.configs.empty()) {
        say("fit plan, batch " + std::to_string(pass) + ": " +
            std::to_string(b.plan.configs.size()) + " configurations; " + b.note);
    }
    const std::string key = std::to_string(pass);
    if (!fit_batches_.contains(key) && !b.plan.configs.empty()) {
        // The batch as first chosen (a resume rebuilds the same one and keeps this record).
        fit_batches_[key] = {{"measured_before", b.measured_before},
                             {"rig_time_s", prior_rig_time_s_ + rig_time().total_s()},
                             {"configurations", b.plan.configs.size()},
                             {"fitted", b.fitted},
                             {"by_variance", b.by_variance},
                             {"by_misfit", b.by_misfit},
                             {"by_space", b.by_space},
                             {"sweeps", b.sweeps},
                             {"note", b.note}};
    }
    return std::move(b.plan);
}

Expected<Plan> Runner::pass_plan(int pass, const Plan& plan) {
    if (pass == 0) {
        return plan;
    }
    if (spec_.plan_kind == "fit") {
        Plan pp = fit_batch(pass);
        planned_total_ += pp.configs.size();
        return pp;
    }
    if (spec_.plan_kind != "vndf") {
        Plan pp = adaptive_pass(pass);
        planned_total_ += pp.configs.size();
        say("adaptive pass " + std::to_string(pass) + ": " + std::to_string(pp.configs.size()) +
            " configurations where the values change fastest");
        return pp;
    }
    VndfNdf ndf;
    auto layout = vndf_pass_from_records(journal_->records(), spec_, rig_, &ndf);
    if (!layout) {
        return tl::unexpected(layout.error());
    }
    vndf_ndf_ = ndf;
    vndf_pass_ = *layout;
    Plan pp = std::move(layout->plan);
    planned_total_ += pp.configs.size();
    say("vndf pass 1: NDF from " + std::to_string(ndf.measured) +
        " retro-reflection measurements (" + std::to_string(ndf.ndf.iterations) +
        " power iterations); " + std::to_string(pp.configs.size()) +
        " configurations in the VNDF-warped domain, " + std::to_string(pp.unreachable.size()) +
        " unreachable, " + std::to_string(layout->below_horizon) + " below the horizon");
    return pp;
}

void Runner::pending_poses(int pass,
                           const Plan& pp,
                           std::vector<const PlannedConfig*>* pending,
                           std::vector<RigPosed>* poses) const {
    RigPosed prev = current_;
    for (const PlannedConfig& c : pp.configs) {
        if (done_.count({pass, c.index})) {
            continue;
        }
        auto sol = solve(Target{c.wi, c.wo, c.isotropic, true}, lim_, dyn_, prev);
        if (!sol) {
            // remove_unreachable() already kept only reachable ones.
            continue;
        }
        pending->push_back(&c);
        poses->push_back(sol->pose);
        prev = sol->pose;
    }
}

Expected<JournalRecord> Runner::measure_config(int pass,
                                               const PlannedConfig& c,
                                               const RigPosed& pose,
                                               std::string* pause,
                                               bool* journal_failed) {
    auto s = attempt(
        pose, "configuration " + std::to_string(pass) + ":" + std::to_string(c.index), pause);
    if (!s) {
        return tl::unexpected(s.error());
    }
    auto v = rate_to_brdf(white_, s->rate.rate, s->rate.sigma, s->wi.z());
    if (!v) {
        return tl::unexpected(v.error());
    }
    JournalRecord r = record_of(RecordType::kMeasurement, *s, *v);
    r.pass = pass;
    r.index = c.index;
    r.flags |= c.flags;
    r.weight = c.weight;
    if (auto a = journal_->append(r); !a) {
        *journal_failed = true;
        return tl::unexpected(a.error());
    }
    done_.insert({pass, c.index});
    ++since_reference_;
    ++result_.measured_now;
    result_.measured_total = done_.size();
    return r;
}

void Runner::publish_measurement(const JournalRecord& r) const {
    if (!hooks_.on_measurement) {
        return;
    }
    brdf::Sample smp;
    const auto si = brdf::cartesian_to_spherical(r.wi);
    const auto so = brdf::cartesian_to_spherical(r.wo);
    smp.theta_i = si.theta;
    smp.phi_i = si.phi;
    smp.theta_o = so.theta;
    smp.phi_o = so.phi;
    smp.value = r.value;
    smp.sigma = r.sigma;
    smp.weight = r.weight;
    smp.flags = r.flags;
    hooks_.on_measurement(smp, done_.size(), planned_total_);
}

std::optional<Expected<RunResult>> Runner::measure_pass(int pass,
                                                        const Plan& pp,
                                                        const Plan& plan,
                                                        std::string* pause) {
    std::vector<const PlannedConfig*> pending;
    std::vector<RigPosed> poses;
    pending_poses(pass, pp, &pending, &poses);
    if (pending.empty()) {
        return std::nullopt;
    }
    if (spec_.fly.enabled) {
        return measure_fly_pass(pass, pending, poses, plan, pause);
    }
    ScheduleOptions so;
    so.budget_s = spec_.schedule_budget_s;
    const Schedule sch = schedule(poses, current_, dyn_, so);
    say("pass " + std::to_string(pass) + ": " + std::to_string(pending.size()) +
        " to measure; motion time planned " + format_duration(sch.planned_s) + ", raster order " +
        format_duration(sch.raster_s) + ", lower bound " + format_duration(sch.lower_bound_s));
    const std::size_t done_before = done_.size();
    Progress progress(hooks_.out, done_before + pending.size(), done_before, sch.planned_s);
    for (std::size_t q = 0; q < sch.order.size(); ++q) {
        if (auto end = before_measurement(plan, pause, &progress)) {
            return end;
        }
        const std::size_t k = sch.order[q];
        if (auto end = measure_standing(pass, *pending[k], poses[k], plan, pause, &progress)) {
            return end;
        }
    }
    progress.finish("pass " + std::to_string(pass) + " complete");
    return std::nullopt;
}

std::optional<Expected<RunResult>> Runner::measure_standing(int pass,
                                                            const PlannedConfig& c,
                                                            const RigPosed& pose,
                                                            const Plan& plan,
                                                            std::string* pause,
                                                            Progress* progress) {
    bool journal_failed = false;
    auto r = measure_config(pass, c, pose, pause, &journal_failed);
    if (!r) {
        if (journal_failed) {
            return Expected<RunResult>(tl::unexpected(r.error()));
        }
        progress->finish("paused");
        return finish(Outcome::kPaused, r.error().message, plan);
    }
    progress->step();
    publish_measurement(*r);
    return after_measurement(plan, progress);
}

FlyLimits Runner::fly_limits() const {
    FlyLimits l;
    l.dyn = dyn_;
    l.range = lim_.range;
    l.readout_s = rig_.camera_readout_ms / 1000.0;
    l.min_exposure_s = rig_.capture.min_exposure_us * 1e-6;
    l.max_exposure_s = rig_.capture.max_exposure_us * 1e-6;
    return l;
}

/// Motion time of the units from `start`: the moves into each, the sweeps' trapezoids.
double fly_motion_s(const std::vector<FlyUnit>& units,
                    const RigPosed& start,
                    const std::array<AxisDynamics, kNumAxes>& dyn) {
    double t = 0;
    RigPosed at = start;
    for (const FlyUnit& u : units) {
        t += move_time(at, u.sweep.stand, dyn);
        at = u.sweep.stand;
        if (!u.standing) {
            t += trapezoid_time(
                std::abs(u.sweep.to - u.sweep.from), u.sweep.speed, dyn[u.sweep.axis].accel);
            set_axis_angle(&at, u.sweep.axis, u.sweep.to);
        }
    }
    return t;
}

std::optional<Expected<RunResult>> Runner::measure_fly_pass(
    int pass,
    const std::vector<const PlannedConfig*>& pending,
    const std::vector<RigPosed>& poses,
    const Plan& plan,
    std::string* pause) {
    const std::vector<FlyUnit> units = plan_fly_units(poses, current_, spec_.fly, fly_limits());
    std::size_t sweeps = 0, swept = 0;
    for (const FlyUnit& u : units) {
        sweeps += !u.standing;
        swept += u.standing ? 0 : u.sweep.members.size();
    }
    const double planned_s = fly_motion_s(units, current_, dyn_);
    say("pass " + std::to_string(pass) + ": " + std::to_string(pending.size()) +
        " to measure; fly scans: " + std::to_string(sweeps) + " sweeps through " +
        std::to_string(swept) + " configurations, " + std::to_string(pending.size() - swept) +
        " standing; motion time planned " + format_duration(planned_s));
    const std::size_t done_before = done_.size();
    Progress progress(hooks_.out, done_before + pending.size(), done_before, planned_s);
    std::vector<std::size_t> standing;
    for (const FlyUnit& u : units) {
        if (u.standing) {
            standing.insert(standing.end(), u.sweep.members.begin(), u.sweep.members.end());
            continue;
        }
        if (auto end = before_measurement(plan, pause, &progress)) {
            return end;
        }
        if (auto end = fly_sweep(pass, u.sweep, pending, poses, plan, &progress, &standing)) {
            return end;
        }
    }
    // What no sweep measured, in one scheduled tour after the sweeps.
    std::vector<RigPosed> stand_poses;
    for (std::size_t k : standing) {
        stand_poses.push_back(poses[k]);
    }
    ScheduleOptions so;
    so.budget_s = spec_.schedule_budget_s;
    const Schedule sch = schedule(stand_poses, current_, dyn_, so);
    for (std::size_t q : sch.order) {
        if (auto end = before_measurement(plan, pause, &progress)) {
            return end;
        }
        const std::size_t k = standing[q];
        ++result_.standing;
        if (auto end = measure_standing(pass, *pending[k], poses[k], plan, pause, &progress)) {
            return end;
        }
    }
    progress.finish("pass " + std::to_string(pass) + " complete");
    return std::nullopt;
}

std::optional<Expected<RunResult>> Runner::before_measurement(const Plan& plan,
                                                              std::string* pause,
                                                              Progress* progress) {
    if (stop_requested()) {
        progress->finish("stopped on request");
        return finish(Outcome::kInterrupted,
                      "stopped on request after " + std::to_string(result_.measured_now) +
                          " measurements; resume with --resume " + dir_,
                      plan);
    }
    if (spec_.drift_every > 0 && since_reference_ >= static_cast<std::size_t>(spec_.drift_every)) {
        if (auto d = drift_check(false, pause); !d) {
            progress->finish("paused");
            return finish(Outcome::kPaused, d.error().message, plan);
        }
    }
    return std::nullopt;
}

Expected<RigPosed> Runner::start_sweep(int pass,
                                       const Sweep& sw,
                                       const std::vector<const PlannedConfig*>& pending) {
    JournalRecord r;
    r.text = "configurations:";
    for (std::size_t k : sw.members) {
        r.text += " " + std::to_string(pending[k]->index);
    }
    r.type = RecordType::kSweep;
    r.pass = pass;
    r.index = static_cast<std::uint32_t>(result_.sweeps);
    RigPosed end = sw.stand;
    set_axis_angle(&end, sw.axis, sw.to);
    r.pose_deg = pose_deg(sw.stand);
    r.has_path = true;
    r.path_start_deg = pose_deg(sw.stand);
    r.path_end_deg = pose_deg(end);
    r.speed_deg_per_s = sw.speed / kDeg;
    r.exposure_us = sw.max_exposure_s * 1e6;
    r.time_s = now_s();
    if (auto a = journal_->append(r); !a) {
        return tl::unexpected(a.error());
    }
    if (auto m = move_to(sw.stand); !m) {
        return tl::unexpected(m.error());
    }
    return read_pose();
}

Expected<JournalRecord> Runner::fly_record(
    int pass, const PlannedConfig& c, const Sweep& sw, const RigPosed& stood, const FlyFrame& f) {
    const double a0 = f.latch_deg[0] * kDeg;
    const double a1 = f.latch_deg[1] * kDeg;
    const double lo = std::min(sw.from, sw.to);
    const double hi = std::max(sw.from, sw.to);
    if (!(std::isfinite(a0) && std::isfinite(a1) && std::min(a0, a1) >= lo - 1e-3 &&
          std::max(a0, a1) <= hi + 1e-3)) {
        return make_error("the drive latched the exposure at " + std::to_string(f.latch_deg[0]) +
                          " .. " + std::to_string(f.latch_deg[1]) +
                          " deg, outside the sweep: measured standing");
    }
    auto rate = session_->rate_of(f.frame);
    if (!rate) {
        return tl::unexpected(rate.error());
    }
    if (rate->saturated) {
        ++fly_saturated_;
        return make_error("saturated at the sweep's exposure: measured standing (HDR)");
    }
    RigPosed p0 = stood, p1 = stood, mid = stood;
    set_axis_angle(&p0, sw.axis, a0);
    set_axis_angle(&p1, sw.axis, a1);
    set_axis_angle(&mid, sw.axis, 0.5 * (a0 + a1));
    Shot s;
    s.pose = mid;
    s.rate = *rate;
    std::tie(s.wi, s.wo) = brdf::rig_forward(mid);
    auto v = rate_to_brdf(white_, rate->rate, rate->sigma, s.wi.z());
    if (!v) {
        return tl::unexpected(v.error());
    }
    JournalRecord r = record_of(RecordType::kMeasurement, s, *v);
    r.pass = pass;
    r.index = c.index;
    r.flags |= c.flags;
    r.weight = c.weight;
    r.has_path = true;
    r.path_start_deg = pose_deg(p0);
    r.path_end_deg = pose_deg(p1);
    return r;
}

std::optional<Expected<RunResult>> Runner::fly_sweep(
    int pass,
    const Sweep& sw,
    const std::vector<const PlannedConfig*>& pending,
    const std::vector<RigPosed>& poses,
    const Plan& plan,
    Progress* progress,
    std::vector<std::size_t>* standing) {
    auto stood = start_sweep(pass, sw, pending);
    std::vector<double> targets_deg;
    for (std::size_t k : sw.members) {
        targets_deg.push_back(axis_angle(poses[k], sw.axis) / kDeg);
    }
    if (fly_exposure_us_ <= 0) {
        fly_exposure_us_ = sw.max_exposure_s * 1e6 / 8;
    }
    Expected<SweepFrames> frames = stood
                                       ? run_sweep(*dev_.axes[sw.axis],
                                                   *session_,
                                                   sw,
                                                   targets_deg,
                                                   &fly_exposure_us_,
                                                   std::chrono::milliseconds(rig_.move_timeout_ms))
                                       : Expected<SweepFrames>(tl::unexpected(stood.error()));
    ++result_.sweeps;
    if (!frames) {
        // The standing measurements that follow retry, wait out outages or pause.
        note("fly sweep " + std::to_string(result_.sweeps) + " failed (" + frames.error().message +
             "): its configurations are measured standing");
        if (auto p = read_pose(); p) {
            current_ = *p;
        }
        *standing = sw.members;
        return std::nullopt;
    }
    clock_->sweep(sw.axis, sw.to - sw.from, sw.speed);
    current_ = *stood;
    set_axis_angle(&current_, sw.axis, sw.to);
    for (std::size_t k : frames->missed) {
        ++fly_missed_;
        standing->push_back(sw.members[k]);
    }
    for (const FlyFrame& f : frames->frames) {
        const std::size_t i = sw.members[f.member];
        auto r = fly_record(pass, *pending[i], sw, *stood, f);
        if (!r) {
            standing->push_back(i);
            continue;
        }
        if (auto a = journal_->append(*r); !a) {
            return Expected<RunResult>(tl::unexpected(a.error()));
        }
        done_.insert({pass, r->index});
        ++since_reference_;
        ++result_.measured_now;
        ++result_.swept;
        result_.measured_total = done_.size();
        progress->step();
        publish_measurement(*r);
        if (auto end = after_measurement(plan, progress)) {
            return end;
        }
    }
    return std::nullopt;
}

std::string Runner::completion_summary() const {
    std::string summary = "completed: " + std::to_string(done_.size()) + " configurations measured";
    if (result_.pose_repeats + result_.pose_corrections > 0) {
        summary += "; pose checks: " + std::to_string(result_.pose_repeats) +
                   " exposures repeated after an axis moved, " +
                   std::to_string(result_.pose_corrections) + " poses corrected before exposing";
    }
    if (result_.outages > 0) {
        summary += "; " + std::to_string(result_.outages) + " device outages waited out";
    }
    return summary;
}

std::optional<Expected<RunResult>> Runner::after_measurement(const Plan& plan, Progress* progress) {
    if (!rule_.active() || ++since_check_ < check_every_) {
        return std::nullopt;
    }
    auto held = check_stop_rule(plan);
    if (!held) {
        progress->finish("paused");
        return finish(Outcome::kPaused, held.error().message, plan);
    }
    if (*held) {
        progress->finish("target reached");
        return finish(Outcome::kCompleted, "target reached: " + result_.until, plan);
    }
    return std::nullopt;
}

std::optional<Expected<RunResult>> Runner::rule_on_journal(const Plan& plan) {
    auto held = check_stop_rule(plan);
    if (!held) {
        return finish(Outcome::kPaused, held.error().message, plan);
    }
    if (*held) {
        return finish(Outcome::kCompleted, "target reached: " + result_.until, plan);
    }
    return std::nullopt;
}

Expected<RunResult> Runner::run() {
    started_ = now_s();
    auto plan0 = load_campaign();
    if (!plan0) {
        return tl::unexpected(plan0.error());
    }
    const Plan& plan = *plan0;
    const bool have_white = replay_journal();
    say_plan(plan);
    std::string pause;
    if (auto d = prepare_devices(have_white, &pause); !d) {
        return finish(Outcome::kPaused, d.error().message, plan);
    }
    check_every_ = rule_.every > 0            ? static_cast<std::size_t>(rule_.every)
                   : spec_.plan_kind == "fit" ? static_cast<std::size_t>(spec_.fit.batch)
                                              : std::max<std::size_t>(8, plan.configs.size() / 10);
    if (rule_.active() && !done_.empty()) {
        // A resume checks the rule on what the journal holds before measuring anything more.
        if (auto end = rule_on_journal(plan)) {
            return std::move(*end);
        }
    }
    // Passes: 0 is the plan; each adaptive pass refines where the values measured so far change
    // fastest.
    planned_total_ = plan.configs.size();
    // The fit plan's passes are its batches, until its budget is measured.
    const int last_pass = spec_.plan_kind == "vndf"  ? 1
                          : spec_.plan_kind == "fit" ? spec_.fit.budget
                          : spec_.adaptive           ? spec_.adaptive_passes
                                                     : 0;
    for (int pass = 0; pass <= last_pass; ++pass) {
        auto pp = pass_plan(pass, plan);
        if (!pp) {
            return finish(Outcome::kPaused, pp.error().message, plan);
        }
        if (spec_.plan_kind == "fit" && pp->configs.empty()) {
            break;
        }
        result_.planned_total = planned_total_;
        if (auto end = measure_pass(pass, *pp, plan, &pause)) {
            return std::move(*end);
        }
    }
    result_.measured_total = done_.size();
    std::string summary = completion_summary();
    if (rule_.active()) {
        // The plan ended first: the last check says how far the targets were.
        auto held = check_stop_rule(plan);
        if (held && *held) {
            return finish(Outcome::kCompleted, "target reached: " + result_.until, plan);
        }
        summary += "; until " + spec_.until + ": target never reached, the plan ended (" +
                   (until_.is_null() ? std::string("no check could fit")
                                     : until_["message"].get<std::string>()) +
                   ")";
        if (!until_.is_null()) {
            until_["message"] =
                "target never reached: the plan ended; " + until_["message"].get<std::string>();
        }
    }
    return finish(Outcome::kCompleted, summary, plan);
}

}  // namespace

Expected<RunResult> run_campaign(const std::string& dir, RigDevices& dev, const RunHooks& hooks) {
    Runner r(dir, dev, hooks);
    Expected<RunResult> res = r.run();
    if (!res) {
        // Nothing measured is lost (journal.log); say how to continue once the cause is fixed.
        return make_error(res.error().message + "\nThe campaign folder " + dir +
                          " is kept; after fixing the cause (e.g. free disk space), continue with: "
                          "gonio acquire --resume " +
                          dir);
    }
    return res;
}

}  // namespace gonio::acquisition
