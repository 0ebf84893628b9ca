// CampaignRequest: which options each mode honours, and the set-up of point and image campaigns.

#include "gonio/acquisition/shared/campaign_request.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <utility>
#include <vector>

#include "gonio/base/atomic_file.h"
#include "gonio/base/data_path.h"
#include "gonio/base/limits.h"
#include "gonio/base/strict_json.h"
#include "gonio/devices/axis_profile.h"

namespace gonio::acquisition {

namespace fs = std::filesystem;

std::string option_key(const std::string& field) {
    static const std::pair<const char*, const char*> renamed[] = {
        {"resume_dir", "resume"},
        {"campaign_file", "campaign"},
        {"operator_name", "operator"},
        {"brdf_path", "brdf"},
        {"rig_path", "rig"},
        {"out_dir", "out"},
        {"plan_kind", "plan"},
        {"fly_smear_deg", "fly-smear"},
    };
    for (const auto& [from, to] : renamed) {
        if (field == from) {
            return to;
        }
    }
    std::string key = field;
    std::replace(key.begin(), key.end(), '_', '-');
    return key;
}

namespace {

/// The fields a request gives, by key, in the order of the struct.
std::vector<std::string> given_fields(const CampaignRequest& r) {
    std::vector<std::string> out;
    auto add = [&](bool given, const char* field) {
        if (given) {
            out.emplace_back(field);
        }
    };
    add(!r.campaign_file.empty(), "campaign_file");
    add(!r.rig_path.empty(), "rig_path");
    add(!r.out_dir.empty(), "out_dir");
    add(!r.resume_dir.empty(), "resume_dir");
    add(!r.campaigns_dir.empty(), "campaigns_dir");
    add(!r.material.empty(), "material");
    add(!r.brdf_path.empty(), "brdf_path");
    add(!r.scene.empty(), "scene");
    add(!r.sample.empty(), "sample");
    add(!r.operator_name.empty(), "operator_name");
    add(!r.plan_kind.empty(), "plan_kind");
    add(r.n_theta > 0, "n_theta");
    add(r.n_dphi > 0, "n_dphi");
    add(r.adaptive >= 0, "adaptive");
    add(r.anisotropic, "anisotropic");
    add(!r.symmetry.empty(), "symmetry");
    add(r.vndf_theta_i > 0, "vndf_theta_i");
    add(r.vndf_resolution > 0, "vndf_resolution");
    add(r.vndf_phi_i > 0, "vndf_phi_i");
    add(r.time_scale > 0, "time_scale");
    add(r.accept_drift, "accept_drift");
    add(r.plan_only, "plan_only");
    add(r.coverage_target > 0, "coverage_target");
    add(r.max_frames > 0, "max_frames");
    add(r.grid.n_theta_h > 0 || r.grid.n_theta_d > 0 || r.grid.n_phi_d > 0, "grid");
    add(r.camera_px > 0, "camera_px");
    add(r.max_theta_deg > 0, "max_theta_deg");
    add(r.no_zoom, "no_zoom");
    add(!r.serve.empty(), "serve");
    add(!r.until.empty(), "until");
    add(r.fly, "fly");
    add(r.fly_smear_deg > 0, "fly_smear_deg");
    return out;
}

bool among(const std::string& field, std::initializer_list<const char*> fields) {
    for (const char* f : fields) {
        if (field == f) {
            return true;
        }
    }
    return false;
}

/// An option of the other mode, or one the image campaign's kind does not take.
std::optional<RequestConflict> mode_conflict(const CampaignRequest& r,
                                             const std::vector<std::string>& given) {
    const bool image = r.mode == CampaignMode::kImage;
    for (const std::string& f : given) {
        if (!image && among(f,
                            {"coverage_target",
                             "max_frames",
                             "grid",
                             "camera_px",
                             "max_theta_deg",
                             "no_zoom"})) {
            return RequestConflict{f, "mode", "an image-mode option (give --mode image)"};
        }
        if (image && r.anisotropic && f == "no_zoom") {
            return RequestConflict{f,
                                   "anisotropic",
                                   "an anisotropic image campaign takes every frame in the wide "
                                   "view already"};
        }
        if (image && f == "symmetry") {
            return RequestConflict{f,
                                   "mode",
                                   "an anisotropic image campaign bins phi_h over the whole turn "
                                   "and folds no symmetry"};
        }
        if (image && r.anisotropic && f == "grid") {
            return RequestConflict{f,
                                   "anisotropic",
                                   "the grid is the isotropic half/difference table; an "
                                   "anisotropic image campaign bins into its own 4-D table"};
        }
        if (image && among(f, {"fly", "fly_smear_deg"})) {
            return RequestConflict{f,
                                   "mode",
                                   "fly scans are point mode's: an image campaign's frames each "
                                   "need the light and the sphere standing"};
        }
        if (image && among(f,
                           {"campaign_file",
                            "scene",
                            "plan_kind",
                            "n_theta",
                            "n_dphi",
                            "adaptive",
                            "vndf_theta_i",
                            "vndf_resolution",
                            "vndf_phi_i",
                            "accept_drift",
                            "until"})) {
            return RequestConflict{f,
                                   "mode",
                                   "a point-mode option: image mode plans its light positions "
                                   "from the coverage of the table and checks no lamp drift"};
        }
    }
    return std::nullopt;
}

/// What a plan-only request or a campaign description leaves no place for, and the two ground
/// truths.
std::optional<RequestConflict> job_conflict(const CampaignRequest& r,
                                            const std::vector<std::string>& given) {
    if (r.plan_only) {
        for (const std::string& f : given) {
            if (among(f,
                      {"out_dir",
                       "campaigns_dir",
                       "material",
                       "brdf_path",
                       "time_scale",
                       "sample",
                       "operator_name",
                       "accept_drift",
                       "serve",
                       "until",
                       "fly",
                       "fly_smear_deg"})) {
                return RequestConflict{
                    f, "plan_only", "only the plan is printed; nothing is measured or written"};
            }
        }
    }
    if (!r.campaign_file.empty()) {
        for (const std::string& f : given) {
            if (among(f, {"material", "brdf_path", "time_scale"})) {
                return RequestConflict{f,
                                       "campaign_file",
                                       "an option of the embedded virtual rig; a campaign "
                                       "description names its own rig"};
            }
        }
    }
    if (!r.material.empty() && !r.brdf_path.empty()) {
        return RequestConflict{"material", "brdf_path", "give one ground truth"};
    }
    return std::nullopt;
}

/// The point-mode plan's options that its kind (uniform, anisotropic, vndf) does not take.
std::optional<RequestConflict> plan_conflict(const CampaignRequest& r,
                                             const std::vector<std::string>& given) {
    if (!r.symmetry.empty() && !r.anisotropic) {
        return RequestConflict{"symmetry",
                               "isotropic_plan",
                               "the symmetry folds the anisotropic plan (give --anisotropic)"};
    }
    if (r.anisotropic && !r.plan_kind.empty() && r.plan_kind != "vndf" && r.plan_kind != "fit") {
        return RequestConflict{"plan_kind",
                               "anisotropic",
                               "the anisotropic plan is its own grid over (theta_i, phi_i, "
                               "theta_o, phi_o); with --plan vndf it is the anisotropic vndf plan"};
    }
    for (const std::string& f : given) {
        if (among(f, {"vndf_theta_i", "vndf_resolution", "vndf_phi_i"}) && r.plan_kind != "vndf") {
            return RequestConflict{
                f, "plan_kind", "an option of the vndf plan's RGL file (give --plan vndf)"};
        }
    }
    if (r.vndf_phi_i > 0 && !r.anisotropic) {
        return RequestConflict{"vndf_phi_i",
                               "isotropic_plan",
                               "the incident azimuths of the anisotropic vndf plan (give "
                               "--anisotropic; an isotropic file has one)"};
    }
    if (r.plan_kind == "vndf" && !r.symmetry.empty()) {
        return RequestConflict{"symmetry",
                               "plan_kind",
                               "the vndf plan measures every incident azimuth of its RGL file "
                               "(the format's readers evaluate only unreduced files)"};
    }
    if (r.anisotropic && r.adaptive > 0) {
        return RequestConflict{"adaptive",
                               "anisotropic",
                               "adaptive refinement works in the isotropic (theta_i, theta_r, "
                               "delta_phi) space"};
    }
    if (r.fly_smear_deg > 0 && !r.fly) {
        return RequestConflict{
            "fly_smear_deg", "fly", "bounds the smear of fly scans (give --fly)"};
    }
    if (r.plan_kind == "fit") {
        for (const std::string& f : given) {
            if (among(f, {"n_theta", "n_dphi"}) || (f == "adaptive" && r.adaptive > 0)) {
                return RequestConflict{f,
                                       "plan_kind",
                                       "the fit plan chooses every batch after the first from "
                                       "the fit, among its own pool of configurations"};
            }
        }
        return std::nullopt;
    }
    if (r.plan_kind == "half-diff") {
        for (const std::string& f : given) {
            if (among(f, {"n_theta", "n_dphi"})) {
                return RequestConflict{f,
                                       "plan_kind",
                                       "an option of the uniform plan; the half-diff plan's grid "
                                       "is its campaign file's plan.n_theta_h, n_theta_d and "
                                       "n_phi_d"};
            }
        }
        return std::nullopt;
    }
    if (r.plan_kind != "vndf") {
        return std::nullopt;
    }
    for (const std::string& f : given) {
        if (among(f, {"n_theta", "n_dphi"})) {
            return RequestConflict{f,
                                   "plan_kind",
                                   "an option of the uniform plan; the vndf plan places its "
                                   "nodes by the measured microfacet distribution"};
        }
        if (f == "adaptive" && r.adaptive > 0) {
            return RequestConflict{f,
                                   "plan_kind",
                                   "the vndf plan places its own second pass from the "
                                   "retro-reflection measurements"};
        }
        if (f == "scene" || f == "until") {
            return RequestConflict{
                f, "plan_kind", "the vndf plan measures every node of its RGL file"};
        }
    }
    return std::nullopt;
}

}  // namespace

std::optional<RequestConflict> find_conflict(const CampaignRequest& r) {
    const std::vector<std::string> given = given_fields(r);
    if (auto c = mode_conflict(r, given)) {
        return c;
    }
    if (!r.resume_dir.empty()) {
        for (const std::string& f : given) {
            if (f != "resume_dir" && f != "accept_drift" && f != "serve") {
                return RequestConflict{f,
                                       "resume_dir",
                                       r.mode == CampaignMode::kImage
                                           ? "an image campaign continues with the settings in "
                                             "its folder's image_campaign.json"
                                           : "a resume takes the description, rig and plan "
                                             "from the campaign folder"};
            }
        }
        return std::nullopt;
    }
    if (auto c = job_conflict(r, given)) {
        return c;
    }
    return plan_conflict(r, given);
}

// ---- point mode ----------------------------------------------------------------------------

namespace {

/// The rig description marks campaigns that ran on the embedded virtual rig, so a resume restarts
/// it.
bool is_embedded(const std::string& rig_json) {
    const nlohmann::json j = nlohmann::json::parse(rig_json, nullptr, false);
    return !j.is_discarded() && j.is_object() && j.value("embedded_virtual_rig", false);
}

/// "ground_truth.json" for a model file, "ground_truth.gtab" for a table; empty for a library
/// material ("material:NAME"), which is no file.
std::string ground_truth_name(const std::string& brdf) {
    if (brdf.rfind("material:", 0) == 0) {
        return {};
    }
    return "ground_truth" + fs::path(brdf).extension().string();
}

/// The campaign description of a new campaign with the request's overrides, its paths resolved.
/// `embedded` tells whether the embedded virtual rig serves it (no description given).
namespace {

/// The description a new campaign starts from: its campaign file (paths beside it), or the
/// default one named after the virtual rig's material. `embedded` says which.
Expected<CampaignSpec> base_campaign_spec(const CampaignRequest& r, bool* embedded) {
    CampaignSpec spec;
    *embedded = r.campaign_file.empty();
    if (!r.campaign_file.empty()) {
        auto s = read_campaign_spec(r.campaign_file);
        if (!s) {
            return s;
        }
        spec = *s;
        const fs::path base = fs::path(r.campaign_file).parent_path();
        if (!spec.rig.empty() && fs::path(spec.rig).is_relative()) {
            spec.rig = (base / spec.rig).string();
        }
        if (!spec.scene.empty() && fs::path(spec.scene).is_relative()) {
            spec.scene = (base / spec.scene).string();
        }
    } else {
        spec = default_campaign_spec(!r.brdf_path.empty()  ? fs::path(r.brdf_path).stem().string()
                                     : !r.material.empty() ? r.material
                                                           : "red-plastic");
    }
    return spec;
}

/// The rig, scene, names and plan kind the request gives.
Expected<void> apply_names(const CampaignRequest& r, CampaignSpec* spec) {
    if (!r.rig_path.empty()) {
        spec->rig = r.rig_path;
    }
    if (spec->rig.empty()) {
        auto p = find_data_file("rigs/sim4.json");
        if (!p) {
            return tl::unexpected(p.error());
        }
        spec->rig = *p;
    }
    if (!r.scene.empty()) {
        spec->scene = r.scene;
    }
    if (!r.sample.empty()) {
        spec->sample = r.sample;
    }
    if (!r.operator_name.empty()) {
        spec->operator_name = r.operator_name;
    }
    if (!r.plan_kind.empty()) {
        spec->plan_kind = r.plan_kind;
        if (r.plan_kind == "vndf" || r.plan_kind == "fit") {
            // The vndf plan's second pass is the VNDF-warped domain, the fit plan's batches are
            // chosen by the fit: no adaptive pass.
            spec->adaptive = false;
        }
    }
    return {};
}

/// The vndf plan's settings the request gives (azimuths over the full turn when anisotropic).
Expected<void> apply_vndf(const CampaignRequest& r, CampaignSpec* spec) {
    if (r.anisotropic && spec->plan_kind == "vndf") {
        // The anisotropic vndf plan: azimuths over the full turn, a coarser NDF grid unless the
        // description gives one (its power iteration costs ndf_resolution^4 per step).
        if (spec->vndf.phi_i_count < 2) {
            spec->vndf.phi_i_count = kVndfAnisotropicPhiCount;
            spec->vndf.ndf_resolution =
                std::min(spec->vndf.ndf_resolution, kVndfAnisotropicNdfResolution);
        }
    }
    if (r.vndf_theta_i > 0) {
        spec->vndf.theta_i_count = r.vndf_theta_i;
    }
    if (r.vndf_resolution > 0) {
        spec->vndf.resolution = r.vndf_resolution;
    }
    if (r.vndf_phi_i > 0) {
        spec->vndf.phi_i_count = r.vndf_phi_i;
    }
    if (spec->plan_kind == "vndf") {
        if (auto ok = check_vndf_spec(spec->vndf); !ok) {
            return tl::unexpected(ok.error());
        }
    }
    return {};
}

/// Anisotropy: the fit plan's pool over every azimuth, or the anisotropic plan at the uniform
/// grid's step; the grid's counts and the declared symmetry.
Expected<void> apply_anisotropy(const CampaignRequest& r, CampaignSpec* spec) {
    if (spec->plan_kind == "fit" && (r.anisotropic || !r.symmetry.empty())) {
        spec->fit.anisotropic = spec->fit.anisotropic || r.anisotropic;
        if (!r.symmetry.empty()) {
            auto sym = parse_symmetry(r.symmetry);
            if (!sym) {
                return tl::unexpected(sym.error());
            }
            spec->fit.symmetry = *sym;
        }
    }
    if (r.anisotropic && spec->plan_kind != "anisotropic" && spec->plan_kind != "vndf" &&
        spec->plan_kind != "fit") {
        // The anisotropic plan at the step of the description's uniform grid.
        spec->plan_kind = "anisotropic";
        spec->anisotropic.n_theta = spec->uniform.n_theta;
        spec->anisotropic.n_dphi = spec->uniform.n_dphi;
        spec->anisotropic.theta_max = spec->uniform.theta_max;
    }
    const bool aniso = spec->plan_kind == "anisotropic";
    if (r.n_theta > 0) {
        (aniso ? spec->anisotropic.n_theta : spec->uniform.n_theta) = r.n_theta;
    }
    if (r.n_dphi > 0) {
        (aniso ? spec->anisotropic.n_dphi : spec->uniform.n_dphi) = r.n_dphi;
    }
    if (!r.symmetry.empty()) {
        auto sym = parse_symmetry(r.symmetry);
        if (!sym) {
            return tl::unexpected(sym.error());
        }
        spec->anisotropic.symmetry = *sym;
    }
    if (aniso) {
        // Adaptive refinement links neighbours in the isotropic canonical space.
        spec->adaptive = false;
    }
    return {};
}

/// What the run follows: adaptive passes, the stop rule, fly scans.
Expected<void> apply_run_options(const CampaignRequest& r, CampaignSpec* spec) {
    if (r.adaptive >= 0) {
        spec->adaptive = r.adaptive > 0;
        spec->adaptive_passes = r.adaptive;
    }
    if (!r.until.empty()) {
        auto rule = parse_stop_rule(r.until);
        if (!rule) {
            return tl::unexpected(rule.error());
        }
        spec->until = format_stop_rule(*rule);
    }
    if (r.fly) {
        spec->fly.enabled = true;
        if (r.fly_smear_deg > 0) {
            spec->fly.max_smear_deg = r.fly_smear_deg;
        }
        if (auto bad = fly_spec_problem(spec->fly); !bad.empty()) {
            return make_error("--fly-smear: " + bad);
        }
    }
    return {};
}

}  // namespace

Expected<CampaignSpec> new_campaign_spec(const CampaignRequest& r, bool* embedded) {
    auto spec = base_campaign_spec(r, embedded);
    if (!spec) {
        return spec;
    }
    for (auto* stage : {apply_names, apply_vndf, apply_anisotropy, apply_run_options}) {
        if (auto ok = stage(r, &*spec); !ok) {
            return tl::unexpected(ok.error());
        }
    }
    return spec;
}

Expected<void> refuse_conflict(const CampaignRequest& r) {
    if (auto c = find_conflict(r)) {
        return make_error(option_key(c->option) + " cannot be combined with " +
                          option_key(c->with) + ": " + c->rule);
    }
    return {};
}

}  // namespace

Expected<Plan> plan_point_campaign(const CampaignRequest& r, CampaignSpec* spec_out) {
    if (auto c = refuse_conflict(r); !c) {
        return tl::unexpected(c.error());
    }
    bool embedded = false;
    auto spec = new_campaign_spec(r, &embedded);
    if (!spec) {
        return tl::unexpected(spec.error());
    }
    auto rig = read_rig_config(spec->rig);
    if (!rig) {
        return tl::unexpected(rig.error());
    }
    if (spec_out != nullptr) {
        *spec_out = *spec;
    }
    return build_plan(*spec, *rig);
}

namespace {

/// What starting a point campaign gathers before anything is written: the embedded rig's options,
/// and for a new campaign its description and the name of the ground truth's copy in the folder.
struct PointStart {
    bool embedded = false;
    EmbeddedRigOptions rig_options;
    CampaignSpec new_spec;
    std::string ground_truth_copy;
};

/// A resumed campaign: the rig as recorded in its folder; the virtual rig's ground truth, when a
/// file, is read from the campaign folder only.
Expected<void> resume_point_rig(PointCampaign* out, PointStart* st) {
    out->resumed = true;
    auto rig = read_rig_config((fs::path(out->dir) / "rig.json").string());
    if (!rig) {
        return tl::unexpected(rig.error());
    }
    out->rig = *rig;
    st->embedded = is_embedded(out->rig.json);
    if (!st->embedded) {
        return {};
    }
    const nlohmann::json j = nlohmann::json::parse(out->rig.json, nullptr, false);
    const std::string b = j.is_object() && j.contains("sim") && j["sim"].is_object()
                              ? j["sim"].value("brdf", std::string())
                              : std::string();
    if (b.empty() || b.rfind("material:", 0) == 0) {
        return {};
    }
    const fs::path bp(b);
    bool outside = bp.is_absolute();
    for (const auto& part : bp) {
        outside = outside || part == "..";
    }
    if (outside) {
        return make_error(out->dir + "/rig.json: sim.brdf = \"" + b +
                          "\" lies outside the campaign folder; a resume reads only the folder "
                          "(copy the file into it and name it relative to it)");
    }
    st->rig_options.brdf_path = (fs::path(out->dir) / bp).string();
    return {};
}

/// Record that the virtual rig served this campaign, and its ground truth, so that a resume
/// restarts the same world.
Expected<void> record_virtual_rig(const CampaignRequest& r,
                                  const CampaignSpec& spec,
                                  PointCampaign* out,
                                  PointStart* st) {
    nlohmann::json j = nlohmann::json::parse(out->rig.json, nullptr, false);
    if (!j.is_object()) {
        return make_error(spec.rig + ": not a JSON object");
    }
    j["embedded_virtual_rig"] = true;
    if (!r.brdf_path.empty()) {
        // The ground truth is copied into the folder (ground_truth.<ext>) so that a resume
        // reads nothing outside it; the simulator starts from the given file.
        st->ground_truth_copy = ground_truth_name(r.brdf_path);
        j["sim"]["brdf"] = st->ground_truth_copy.empty() ? r.brdf_path : st->ground_truth_copy;
        st->rig_options.brdf_path = r.brdf_path;
        j["sim"].erase("material");
    } else if (!r.material.empty()) {
        j["sim"]["material"] = r.material;
        j["sim"].erase("brdf");
    }
    if (r.time_scale > 0) {
        j["sim"]["time_scale"] = r.time_scale;
    }
    auto rr = parse_rig_config(j.dump(2), spec.rig);
    if (!rr) {
        return tl::unexpected(rr.error());
    }
    out->rig = *rr;
    return {};
}

/// A new campaign: its description, rig and plan checked, its folder named (and not holding a
/// campaign already).
Expected<void> new_point_campaign(const CampaignRequest& r, PointCampaign* out, PointStart* st) {
    auto spec = new_campaign_spec(r, &st->embedded);
    if (!spec) {
        return tl::unexpected(spec.error());
    }
    auto rig = read_rig_config(spec->rig);
    if (!rig) {
        return tl::unexpected(rig.error());
    }
    out->rig = *rig;
    if (auto plan = build_plan(*spec, out->rig); !plan) {
        return tl::unexpected(plan.error());
    }
    out->dir = !r.out_dir.empty()
                   ? r.out_dir
                   : auto_campaign_dir(r.campaigns_dir.empty() ? "campaigns" : r.campaigns_dir,
                                       spec->sample);
    if (st->embedded) {
        if (auto v = record_virtual_rig(r, *spec, out, st); !v) {
            return v;
        }
    }
    std::error_code ec;
    if (fs::exists(fs::path(out->dir) / "journal.log", ec) ||
        fs::exists(fs::path(out->dir) / "campaign.json", ec)) {
        return make_error(out->dir + ": already holds a campaign (use --resume " + out->dir + ")");
    }
    if (fs::exists(out->dir, ec) && !fs::is_directory(out->dir, ec)) {
        return make_error(out->dir + ": exists and is not a folder");
    }
    st->new_spec = *spec;
    return {};
}

/// The embedded virtual rig started, and the rig description pointed at its addresses.
Expected<void> start_virtual_rig(const EmbeddedRigStarter& start_rig,
                                 const PointStart& st,
                                 std::FILE* log,
                                 PointCampaign* out) {
    if (!start_rig) {
        return make_error(out->dir +
                          ": the campaign runs on the embedded virtual rig, which this front end "
                          "cannot start");
    }
    auto s = start_rig(out->rig.json, st.rig_options);
    if (!s) {
        return tl::unexpected(s.error());
    }
    out->embedded = std::move(*s);
    if (log != nullptr) {
        std::fprintf(log,
                     "virtual rig: %s; motors %s, camera %s\n",
                     out->embedded->describe().c_str(),
                     out->embedded->motor_address().c_str(),
                     out->embedded->camera_address().c_str());
        if (st.new_spec.plan_kind == "vndf" && st.new_spec.vndf.phi_i_count < 2 &&
            !out->embedded->isotropic_sample()) {
            std::fprintf(log,
                         "note: the virtual sample is anisotropic; the vndf plan measures with "
                         "the light at phi_i = 0 and writes an isotropic RGL file "
                         "(--anisotropic measures every azimuth)\n");
        }
    }
    out->rig =
        with_addresses(out->rig, out->embedded->motor_address(), out->embedded->camera_address());
    return {};
}

/// The new campaign's folder written, with the copy of the ground truth.
Expected<void> write_point_campaign(const CampaignRequest& r,
                                    const PointStart& st,
                                    const PointCampaign& out) {
    if (auto c = create_campaign_dir(out.dir, st.new_spec, out.rig); !c) {
        return tl::unexpected(c.error());
    }
    if (st.ground_truth_copy.empty()) {
        return {};
    }
    auto bytes = read_input_file(r.brdf_path, max_memory_bytes());
    if (!bytes) {
        return tl::unexpected(bytes.error());
    }
    const std::string to = (fs::path(out.dir) / st.ground_truth_copy).string();
    return write_file_atomic(to, *bytes);
}

}  // namespace

Expected<std::unique_ptr<PointCampaign>> start_point_campaign(const CampaignRequest& r,
                                                              const EmbeddedRigStarter& start_rig,
                                                              std::FILE* log) {
    if (auto c = refuse_conflict(r); !c) {
        return tl::unexpected(c.error());
    }
    auto out = std::make_unique<PointCampaign>();
    // A new campaign's folder is created only once everything is checked: description, plan,
    // scene, rig, ground truth and devices reachable. Until then nothing is written.
    PointStart st;
    if (!r.resume_dir.empty()) {
        out->dir = r.resume_dir;
        if (auto s = resume_point_rig(out.get(), &st); !s) {
            return tl::unexpected(s.error());
        }
    } else if (auto s = new_point_campaign(r, out.get(), &st); !s) {
        return tl::unexpected(s.error());
    }
    if (st.embedded) {
        if (auto s = start_virtual_rig(start_rig, st, log, out.get()); !s) {
            return tl::unexpected(s.error());
        }
    }
    if (log != nullptr) {
        std::fprintf(log, "campaign folder: %s\n", out->dir.c_str());
        std::fflush(log);
    }
    auto dev = open_rig(out->rig);
    if (!dev) {
        return tl::unexpected(dev.error());
    }
    out->devices = std::move(*dev);
    if (!out->resumed) {
        if (auto w = write_point_campaign(r, st, *out); !w) {
            return tl::unexpected(w.error());
        }
    }
    return out;
}

// ---- image mode ----------------------------------------------------------------------------

Expected<std::pair<RigConfig, CameraModel>> image_rig_description(const ImageRigOptions& o,
                                                                  bool* embedded) {
    std::string rig_path = o.rig_path;
    if (rig_path.empty()) {
        auto p = find_data_file("rigs/sim-image.json");
        if (!p) {
            return tl::unexpected(p.error());
        }
        rig_path = *p;
    }
    auto rig = read_rig_config(rig_path);
    if (!rig) {
        return tl::unexpected(rig.error());
    }
    const nlohmann::json j = nlohmann::json::parse(rig->json, nullptr, false);
    *embedded = j.is_object() && j.contains("sim");
    CameraModel camera;
    if (j.is_object() && j.contains("camera_model")) {
        if (o.camera_px_given) {
            return make_error(rig_path +
                              ": camera-px sizes the virtual rig's default camera; this rig's "
                              "calibrated camera_model is the camera");
        }
        auto c = read_camera_model(rig_path);
        if (!c) {
            return tl::unexpected(c.error());
        }
        camera = *c;
    } else if (*embedded) {
        camera = default_image_camera(o.image_size, o.perspective, rig->sphere_radius_m);
    } else {
        return make_error(rig_path +
                          ": camera_model: missing (image mode on a rig needs the calibrated "
                          "camera; see docs/image-acquisition.md)");
    }
    return std::make_pair(*rig, camera);
}

Expected<std::unique_ptr<ImageRig>> start_image_rig(const ImageRigOptions& o,
                                                    const EmbeddedRigStarter& start_rig) {
    bool embedded = false;
    auto described = image_rig_description(o, &embedded);
    if (!described) {
        return tl::unexpected(described.error());
    }
    auto out = std::make_unique<ImageRig>();
    out->rig = described->first;
    out->camera = described->second;
    if (embedded) {
        if (o.supersample < 1) {
            return make_error("supersample " + std::to_string(o.supersample) + ": must be >= 1");
        }
        if (!start_rig) {
            return make_error(out->rig.name +
                              ": the rig is the embedded virtual rig, which this front end "
                              "cannot start");
        }
        EmbeddedRigOptions so;
        so.material = o.material;
        so.brdf_path = o.brdf_path;
        so.time_scale = o.time_scale;
        so.seed = o.seed;
        so.sphere_camera = out->camera;
        so.sphere_radius_m = out->rig.sphere_radius_m;
        so.supersample = o.supersample;
        auto s = start_rig(out->rig.json, so);
        if (!s) {
            return tl::unexpected(s.error());
        }
        out->embedded = std::move(*s);
        out->rig = with_addresses(
            out->rig, out->embedded->motor_address(), out->embedded->camera_address());
    }
    auto dev = open_rig(out->rig);
    if (!dev) {
        return tl::unexpected(dev.error());
    }
    out->dev = std::move(*dev);
    devices::Camera& cam = *out->dev.camera;
    if (auto r = cam.set_pixel_format(devices::PixelFormat::kMono16); !r) {
        return tl::unexpected(r.error());
    }
    if (auto r = cam.set_roi(devices::Roi{}); !r) {
        return tl::unexpected(r.error());
    }
    if (auto r = cam.set_gain(out->rig.capture.gain); !r) {
        return tl::unexpected(r.error());
    }
    return out;
}

CaptureFn image_rig_capture(ImageRig& rig, double detector_arm_rad, bool spin) {
    RigDevices& d = rig.dev;
    std::function<Expected<void>(int)> select_filter;
    if (d.filter_wheel) {
        devices::FilterWheel* fw = d.filter_wheel.get();
        select_filter = [fw](int c) { return fw->set_filter(c); };
    }
    std::function<Expected<void>(bool)> swap_target;
    if (d.reference_changer) {
        devices::Light* changer = d.reference_changer.get();
        swap_target = [changer](bool white) { return changer->set_shutter_open(white); };
    }
    DeviceCaptureOptions opt;
    opt.move_timeout = std::chrono::milliseconds(rig.rig.move_timeout_ms);
    const auto& light_axis = rig.rig.axes[static_cast<int>(AxisRole::kLight)];
    const auto& detector_axis = rig.rig.axes[static_cast<int>(AxisRole::kDetector)];
    opt.settle = std::chrono::milliseconds(static_cast<std::int64_t>(
        std::ceil(std::max(light_axis.motion.settle_ms, detector_axis.motion.settle_ms))));
    opt.detector_arm = d.axes[static_cast<int>(AxisRole::kDetector)].get();
    opt.detector_arm_rad = detector_arm_rad;
    if (spin) {
        opt.spin = d.axes[static_cast<int>(AxisRole::kSpin)].get();
    }
    opt.log = &rig.pose_log;
    if (!d.placements.empty()) {
        // One coil per zoomed placement: the chosen one on, every other off (all off: the wide
        // view). Off first, so that two placements are never switched in together.
        std::vector<devices::Light*> coils;
        for (auto& c : d.placements) {
            coils.push_back(c.get());
        }
        opt.select_placement = [coils](int placement) -> Expected<void> {
            if (placement < 0 || placement > static_cast<int>(coils.size())) {
                return make_error("camera placement " + std::to_string(placement) +
                                  ": the rig has " + std::to_string(coils.size()) +
                                  " zoomed placements");
            }
            for (std::size_t k = 0; k < coils.size(); ++k) {
                if (static_cast<int>(k) + 1 != placement) {
                    if (auto r = coils[k]->set_shutter_open(false); !r) {
                        return r;
                    }
                }
            }
            if (placement > 0) {
                return coils[static_cast<std::size_t>(placement - 1)]->set_shutter_open(true);
            }
            return {};
        };
    }
    opt.capture_timeout = std::chrono::milliseconds(rig.rig.capture.timeout_ms);
    opt.capture_retries = rig.rig.retries;
    return make_device_capture(*d.camera,
                               *d.shutter,
                               *d.axes[static_cast<int>(AxisRole::kLight)],
                               std::move(select_filter),
                               std::move(swap_target),
                               opt);
}

namespace {

ImageRigOptions image_rig_options(const CampaignRequest& r) {
    ImageRigOptions io;
    io.rig_path = r.rig_path;
    if (!r.material.empty()) {
        io.material = r.material;
    }
    io.brdf_path = r.brdf_path;
    io.time_scale = r.time_scale;
    io.image_size = r.camera_px > 0 ? r.camera_px : r.image_size;
    io.camera_px_given = r.camera_px > 0;
    io.perspective = r.perspective;
    io.supersample = r.supersample;
    io.seed = r.seed;
    return io;
}

Expected<ImageCampaignConfig> image_config(const CampaignRequest& r,
                                           const RigConfig& rig,
                                           const CameraModel& camera) {
    const double target = r.coverage_target > 0 ? r.coverage_target : 0.55;
    const int frames = r.max_frames > 0 ? r.max_frames : 200;
    ImageCampaignConfig cfg =
        (r.grid.n_theta_h > 0 || r.grid.n_theta_d > 0 || r.grid.n_phi_d > 0)
            ? image_campaign_config(rig, camera, r.grid, target, frames)
            : image_campaign_config(rig, camera, r.table_factor, target, frames);
    if (r.max_theta_deg > 0) {
        if (!(r.max_theta_deg <= rig.max_theta_deg) || !(r.max_theta_deg < 90)) {
            return make_error("max-theta-deg " + show_number(r.max_theta_deg) +
                              " deg: beyond the rig's geometry.max_theta_deg (" +
                              show_number(rig.max_theta_deg) + " deg, " + rig.name + ")");
        }
        cfg.rules.max_theta_i = cfg.rules.max_theta_o = r.max_theta_deg * brdf::kPi / 180;
    }
    if (r.no_zoom) {
        cfg.placements.clear();
    }
    if (r.anisotropic) {
        if (!r.aniso_layout.sane()) {
            return make_error("4-D table " + r.aniso_layout.describe() +
                              ": each count must be in [1, 720]");
        }
        make_anisotropic(&cfg, rig, r.aniso_layout);
    }
    return cfg;
}

}  // namespace

Expected<void> check_table_factor(const CampaignRequest& r) {
    const TableLayout& g = r.grid;
    if (g.n_theta_h > 0 || g.n_theta_d > 0 || g.n_phi_d > 0) {
        if (g.n_theta_h < 1 || g.n_theta_d < 1 || g.n_phi_d < 1 || g.n_theta_h > 360 ||
            g.n_theta_d > 360 || g.n_phi_d > 720) {
            return make_error("grid " + std::to_string(g.n_theta_h) + "x" +
                              std::to_string(g.n_theta_d) + "x" + std::to_string(g.n_phi_d) +
                              ": each count must be >= 1 (at most 360 x 360 x 720)");
        }
        return {};
    }
    if (r.table_factor < 1 || 90 % r.table_factor != 0) {
        return make_error("table factor " + std::to_string(r.table_factor) +
                          ": must divide 90 (1 = MERL resolution, 3 = 30 x 30 x 60 bins)");
    }
    return {};
}

namespace {

/// Fly scans on `rig`: an arm that claims a position compare its drive lacks, or a colour filter
/// changer with an arm that triggers by polling (its colours would each be exposed on a path of
/// their own).
std::optional<RequestConflict> fly_rig_conflict(const RigConfig& rig) {
    for (AxisRole arm : {AxisRole::kLight, AxisRole::kDetector}) {
        const AxisConfig& ax = rig.axes[static_cast<int>(arm)];
        auto profile = devices::load_axis_profile(ax.profile);
        const bool has = profile && profile->compare.present();
        if (ax.position_compare.value_or(false) && !has) {
            return RequestConflict{"fly",
                                   "rig_path",
                                   "rig " + rig.name + ": axis \"" + ax.name +
                                       "\" says \"position_compare\": true, but its profile " +
                                       ax.profile + " has no position compare registers"};
        }
        if (rig.filter_wheel && !ax.position_compare.value_or(has)) {
            return RequestConflict{"fly",
                                   "rig_path",
                                   "fly scans behind rig " + rig.name +
                                       "'s colour filter changer (\"filter_wheel\") need the "
                                       "arms' position compare, and axis \"" +
                                       ax.name +
                                       "\" triggers by polling (\"position_compare\": false): "
                                       "each colour would be exposed on a path of its own"};
        }
    }
    return std::nullopt;
}

}  // namespace

std::optional<RequestConflict> find_rig_conflict(const CampaignRequest& r) {
    if (r.mode == CampaignMode::kPoint) {
        // Fly scans (asked for here or in the campaign's description) on the rig it runs on.
        bool embedded = false;
        auto spec = r.resume_dir.empty() && (r.fly || !r.campaign_file.empty())
                        ? new_campaign_spec(r, &embedded)
                        : Expected<CampaignSpec>(make_error("no fly scans asked for"));
        if (!spec || !spec->fly.enabled) {
            return std::nullopt;
        }
        auto rig = read_rig_config(spec->rig);
        return rig ? fly_rig_conflict(*rig) : std::nullopt;
    }
    if (r.mode != CampaignMode::kImage || !r.resume_dir.empty() ||
        (r.camera_px <= 0 && r.max_theta_deg <= 0 && !r.no_zoom)) {
        return std::nullopt;
    }
    ImageRigOptions o = image_rig_options(r);
    o.camera_px_given = false;  // read the description whatever its camera
    bool embedded = false;
    auto described = image_rig_description(o, &embedded);
    if (!described) {
        return std::nullopt;
    }
    const RigConfig& rig = described->first;
    const std::string name = rig.name.empty() ? std::string("the rig") : "rig " + rig.name;
    if (r.camera_px > 0 && !embedded) {
        return RequestConflict{
            "camera_px",
            "rig_path",
            "sizes the virtual rig's default camera; " + name + " is not a virtual rig"};
    }
    if (r.camera_px > 0) {
        const nlohmann::json j = nlohmann::json::parse(rig.json, nullptr, false);
        if (j.is_object() && j.contains("camera_model")) {
            return RequestConflict{"camera_px",
                                   "rig_path",
                                   "sizes the virtual rig's default camera; " + name +
                                       " has a calibrated camera_model, which is the camera"};
        }
    }
    if (r.no_zoom && rig.placements.empty()) {
        return RequestConflict{
            "no_zoom",
            "rig_path",
            name + " has no zoomed camera placements (\"placements\"): every frame is wide"};
    }
    if (r.max_theta_deg > rig.max_theta_deg) {
        return RequestConflict{"max_theta_deg",
                               "rig_path",
                               show_number(r.max_theta_deg) + " deg is beyond " + name +
                                   "'s geometry.max_theta_deg (" + show_number(rig.max_theta_deg) +
                                   " deg)"};
    }
    return std::nullopt;
}

Expected<ImagePlan> plan_image_campaign(const CampaignRequest& r) {
    if (auto c = refuse_conflict(r); !c) {
        return tl::unexpected(c.error());
    }
    if (auto t = check_table_factor(r); !t) {
        return tl::unexpected(t.error());
    }
    ImagePlan plan;
    auto described = image_rig_description(image_rig_options(r), &plan.embedded);
    if (!described) {
        return tl::unexpected(described.error());
    }
    plan.rig_name = described->first.name;
    auto cfg = image_config(r, described->first, described->second);
    if (!cfg) {
        return tl::unexpected(cfg.error());
    }
    plan.config = *cfg;
    return plan;
}

namespace {

constexpr const char* kImageSettingsFile = "image_campaign.json";
constexpr const char* kImageJournalFile = "frames.journal";

/// The settings a resume needs, as stored in the campaign folder (image_campaign.json). `brdf` is
/// the ground truth's copy in the folder ("" for a named material).
std::string image_settings_json(const CampaignRequest& r, const std::string& brdf_in_dir) {
    nlohmann::ordered_json j;
    j["material"] = r.material.empty() ? std::string("red-plastic") : r.material;
    j["brdf"] = brdf_in_dir;
    j["rig"] = r.rig_path;
    j["table_factor"] = r.table_factor;
    j["grid"] = {r.grid.n_theta_h, r.grid.n_theta_d, r.grid.n_phi_d};
    j["coverage_target"] = r.coverage_target > 0 ? r.coverage_target : 0.55;
    j["max_frames"] = r.max_frames > 0 ? r.max_frames : 200;
    j["image_size"] = r.camera_px > 0 ? r.camera_px : r.image_size;
    j["max_theta_deg"] = r.max_theta_deg;
    j["no_zoom"] = r.no_zoom;
    j["anisotropic"] = r.anisotropic;
    j["aniso_table"] = {r.aniso_layout.n_theta_h,
                        r.aniso_layout.n_phi_h,
                        r.aniso_layout.n_theta_d,
                        r.aniso_layout.n_phi_d};
    j["perspective"] = r.perspective;
    j["supersample"] = r.supersample;
    j["time_scale"] = r.time_scale;
    j["seed"] = r.seed;
    j["sample"] = r.sample;
    j["operator"] = r.operator_name;
    return j.dump(2) + "\n";
}

/// The request of the campaign in `dir` (image_settings_json), its ground truth resolved in the
/// folder; read with the strict reader (every key known, every value typed and in range).
Expected<CampaignRequest> read_image_settings(const std::string& dir) {
    const std::string path = (fs::path(dir) / kImageSettingsFile).string();
    auto text = read_input_file(path, 1 << 20);
    if (!text) {
        return make_error(dir + ": not an image-mode campaign folder (" + text.error().message +
                          ")");
    }
    return read_strict_json(path, [&] {
        const nlohmann::json j = parse_json_checked(*text, path);
        JsonObject o(j, "");
        CampaignRequest r;
        r.mode = CampaignMode::kImage;
        r.material = o.string("material", "", 256);
        const std::string brdf = o.string("brdf", "", 4096);
        r.brdf_path = brdf.empty() ? std::string() : (fs::path(dir) / brdf).string();
        r.rig_path = o.string("rig", "", 4096);
        r.table_factor = o.integer("table_factor", 3, 1, 90);
        if (const nlohmann::json* g = o.find("grid")) {
            if (!g->is_array() || g->size() != 3) {
                json_fail("grid: expected [n_theta_h, n_theta_d, n_phi_d]");
            }
            int n[3];
            for (int k = 0; k < 3; ++k) {
                const std::string at = "grid[" + std::to_string(k) + "]";
                const double v = json_number_at((*g)[k], at);
                if (v != std::floor(v) || v < 0 || v > 720) {
                    json_fail(at + " = " + show_number(v) + ": must be a whole number in [0, 720]");
                }
                n[k] = static_cast<int>(v);
            }
            r.grid = {n[0], n[1], n[2]};
        }
        r.coverage_target = o.number("coverage_target", 0.55, 0.001, 1);
        r.max_frames = o.integer("max_frames", 200, 1, 1000000);
        r.image_size = o.integer("image_size", 256, 16, 2048);
        r.max_theta_deg = o.number("max_theta_deg", 0, 0, 89.9);
        r.no_zoom = o.boolean("no_zoom", false);
        r.anisotropic = o.boolean("anisotropic", false);
        if (const nlohmann::json* g = o.find("aniso_table")) {
            if (!g->is_array() || g->size() != 4) {
                json_fail("aniso_table: expected [n_theta_h, n_phi_h, n_theta_d, n_phi_d]");
            }
            int n[4];
            for (int k = 0; k < 4; ++k) {
                const std::string at = "aniso_table[" + std::to_string(k) + "]";
                const double v = json_number_at((*g)[k], at);
                if (v != std::floor(v) || v < 1 || v > 720) {
                    json_fail(at + " = " + show_number(v) + ": must be a whole number in [1, 720]");
                }
                n[k] = static_cast<int>(v);
            }
            r.aniso_layout = {n[0], n[1], n[2], n[3]};
        }
        r.perspective = o.boolean("perspective", false);
        r.supersample = o.integer("supersample", 2, 1, 64);
        r.time_scale = o.number("time_scale", 0, 0, 1e6);
        const double seed = o.number("seed", 1, 0, 9007199254740992.0);
        if (seed != std::floor(seed)) {
            json_fail("seed = " + show_number(seed) + ": must be a whole number");
        }
        r.seed = static_cast<std::uint64_t>(seed);
        r.sample = o.string("sample", "", 256);
        r.operator_name = o.string("operator", "", 256);
        o.finish();
        r.out_dir = dir;
        r.resume_dir = dir;
        return r;
    });
}

/// A new image campaign's folder (refused when it holds one already) with its settings and the
/// ground truth's file copied into it, so that a resume reads only the folder.
Expected<void> create_image_campaign_dir(const CampaignRequest& r, const ImageCampaignRun& run) {
    std::error_code ec;
    if (fs::exists(run.journal, ec)) {
        return make_error(run.dir +
                          ": already holds an image campaign (continue it with --resume " +
                          run.dir + ")");
    }
    fs::create_directories(run.dir, ec);
    if (ec) {
        return make_error(run.dir + ": cannot create: " + ec.message());
    }
    std::string brdf_in_dir;
    if (!r.brdf_path.empty()) {
        brdf_in_dir = "ground_truth" + fs::path(r.brdf_path).extension().string();
        auto bytes = read_input_file(r.brdf_path, max_memory_bytes());
        if (!bytes) {
            return tl::unexpected(bytes.error());
        }
        if (auto w = write_file_atomic((fs::path(run.dir) / brdf_in_dir).string(), *bytes); !w) {
            return w;
        }
    }
    return write_file_atomic((fs::path(run.dir) / kImageSettingsFile).string(),
                             image_settings_json(r, brdf_in_dir));
}

/// What dataset.json says of the run beside the campaign's own metadata: the sample, operator,
/// rig, ground truth and the pose checks.
std::string image_run_metadata(const CampaignRequest& r,
                               const ImageCampaignRun& run,
                               const ImageRig& rig) {
    nlohmann::json extra;
    extra["sample"] = run.sample;
    if (!r.operator_name.empty()) {
        extra["operator"] = r.operator_name;
    }
    if (run.embedded) {
        extra["ground_truth"] = rig.embedded->ground_truth();
    }
    extra["rig"] = r.rig_path.empty() ? "embedded virtual rig (sim-image)" : r.rig_path;
    extra["embedded_virtual_rig"] = run.embedded;
    extra["camera_address"] = run.camera_address;
    extra["seed"] = r.seed;
    extra["pose_repeats"] = run.poses.repeats;
    extra["pose_corrections"] = run.poses.corrections;
    extra["capture_retries"] = run.poses.capture_retries;
    extra["pose_notes"] = run.poses.notes;
    return extra.dump();
}

}  // namespace

Expected<ImageMemoryEstimate> estimate_image_request_memory(const CampaignRequest& given) {
    CampaignRequest r = given;
    double journal_bytes = 0;
    if (!given.resume_dir.empty()) {
        auto settings = read_image_settings(given.resume_dir);
        if (!settings) {
            return tl::unexpected(settings.error());
        }
        r = *settings;
        std::error_code ec;
        const auto size = fs::file_size(fs::path(given.resume_dir) / kImageJournalFile, ec);
        journal_bytes = ec ? 0.0 : static_cast<double>(size);
    }
    if (auto t = check_table_factor(r); !t) {
        return tl::unexpected(t.error());
    }
    bool embedded = false;
    auto described = image_rig_description(image_rig_options(r), &embedded);
    if (!described) {
        return tl::unexpected(described.error());
    }
    auto cfg = image_config(r, described->first, described->second);
    if (!cfg) {
        return tl::unexpected(cfg.error());
    }
    auto e =
        estimate_image_memory(*cfg, given.plan_only, embedded ? std::max(1, r.supersample) : 0);
    if (e) {
        // A resume reads its journal's frames back before it merges them.
        e->table_bytes += journal_bytes;
    }
    return e;
}

Expected<void> check_image_request_memory(const CampaignRequest& request) {
    auto e = estimate_image_request_memory(request);
    if (!e) {
        return {};
    }
    return check_memory(e->total(),
                        std::string(request.plan_only ? "the image plan" : "the image campaign") +
                            " (" + e->describe() + ")");
}

bool is_image_campaign_dir(const std::string& dir) {
    std::error_code ec;
    return !dir.empty() && fs::exists(fs::path(dir) / kImageSettingsFile, ec);
}

Expected<ImageCampaignRun> run_image_request(const CampaignRequest& given,
                                             const EmbeddedRigStarter& start_rig,
                                             const ImageRunHooks& hooks) {
    if (auto c = refuse_conflict(given); !c) {
        return tl::unexpected(c.error());
    }
    CampaignRequest r = given;
    if (!given.resume_dir.empty()) {
        auto settings = read_image_settings(given.resume_dir);
        if (!settings) {
            return tl::unexpected(settings.error());
        }
        r = *settings;
        r.serve = given.serve;
    }
    if (auto t = check_table_factor(r); !t) {
        return tl::unexpected(t.error());
    }
    auto rig = start_image_rig(image_rig_options(r), start_rig);
    if (!rig) {
        return tl::unexpected(rig.error());
    }
    ImageCampaignRun run;
    run.resumed = !given.resume_dir.empty();
    run.embedded = (*rig)->embedded != nullptr;
    run.rig_name = (*rig)->rig.name;
    std::string truth_name = "sample";
    if (run.embedded) {
        truth_name = r.brdf_path.empty() ? (r.material.empty() ? "red-plastic" : r.material)
                                         : fs::path(r.brdf_path).stem().string();
        if (!r.anisotropic && !(*rig)->embedded->isotropic_sample()) {
            return make_error("image mode bins into an isotropic half/difference table; " +
                              (*rig)->embedded->ground_truth() +
                              " is anisotropic (measure it with --anisotropic)");
        }
    }
    run.sample = r.sample.empty() ? truth_name : r.sample;
    run.motor_address = (*rig)->rig.axes[static_cast<int>(AxisRole::kLight)].address;
    run.camera_address = (*rig)->rig.camera_address;
    auto cfg = image_config(r, (*rig)->rig, (*rig)->camera);
    if (!cfg) {
        return tl::unexpected(cfg.error());
    }
    run.config = *cfg;
    if (auto m = check_image_request_memory(given); !m) {
        return tl::unexpected(m.error());
    }
    run.dir = run.resumed ? r.resume_dir : image_campaign_dir(r, run.sample);
    run.journal = (fs::path(run.dir) / kImageJournalFile).string();
    if (hooks.started) {
        if (auto s = hooks.started(run); !s) {
            return tl::unexpected(s.error());
        }
    }
    if (!run.resumed) {
        if (auto d = create_image_campaign_dir(r, run); !d) {
            return tl::unexpected(d.error());
        }
    }
    if (r.anisotropic && !(*rig)->dev.axes[static_cast<int>(AxisRole::kSpin)]) {
        return make_error(run.rig_name +
                          ": an anisotropic image campaign turns the sample with the spin axis; "
                          "the rig has none");
    }
    CaptureFn capture =
        image_rig_capture(**rig, run.config.detector_arm_rad, run.config.anisotropic);
    if (hooks.wrap_capture) {
        capture = hooks.wrap_capture(std::move(capture));
    }
    auto result = run_image_campaign(capture, run.config, hooks.progress, run.journal, hooks.state);
    run.poses = (*rig)->pose_log;
    if (!result) {
        return tl::unexpected(result.error());
    }
    const std::string extra = image_run_metadata(r, run, **rig);
    if (auto w = write_image_campaign(run.dir, *result, run.config, extra); !w) {
        return tl::unexpected(w.error());
    }
    run.result.emplace(std::move(*result));
    return run;
}

Expected<ImageCampaignRun> run_image_request(
    const CampaignRequest& request,
    const EmbeddedRigStarter& start_rig,
    const std::function<void(const ImageCampaignRun&)>& started,
    const ImageProgressFn& progress) {
    ImageRunHooks hooks;
    if (started) {
        hooks.started = [&started](const ImageCampaignRun& run) -> Expected<void> {
            started(run);
            return {};
        };
    }
    hooks.progress = progress;
    return run_image_request(request, start_rig, hooks);
}

std::string image_campaign_dir(const CampaignRequest& r, const std::string& name) {
    if (!r.out_dir.empty()) {
        return r.out_dir;
    }
    const fs::path parent = r.campaigns_dir.empty() ? fs::path() : fs::path(r.campaigns_dir);
    for (int n = 1;; ++n) {
        const fs::path d = parent / ("image-" + name + "-" + std::to_string(n));
        std::error_code ec;
        if (!fs::exists(d, ec)) {
            return d.string();
        }
    }
}

}  // namespace gonio::acquisition
