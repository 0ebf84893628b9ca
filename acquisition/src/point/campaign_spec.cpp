// A campaign's description (campaign.json), its first plan and its folder (campaign.h).

#include "campaign_runner.h"

namespace gonio::acquisition {

using namespace campaign_internal;

namespace {

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

/// campaign.json "fly" (fly_plan.h).
void parse_fly(const json& raw, FlySpec* f) {
    JsonObject o(raw, "fly");
    f->enabled = o.boolean("enabled", true);
    f->max_smear_deg = o.number("max_smear_deg", f->max_smear_deg, 1e-3, 10, "deg");
    f->speed_deg_per_s = o.number("speed_deg_per_s", f->speed_deg_per_s, 0, 1000, "deg/s");
    o.finish();
}

/// campaign.json's names and paths (the paths relative, inside the campaign file's folder).
void parse_names(JsonObject& top, CampaignSpec* out) {
    CampaignSpec& s = *out;
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
}

/// campaign.json "plan": its kind and that kind's settings.
void parse_plan(JsonObject& p, CampaignSpec* out) {
    CampaignSpec& s = *out;
    s.plan_kind = p.string("kind", s.plan_kind, 16);
    if (s.plan_kind == "uniform") {
        s.uniform.n_theta = p.integer("n_theta", s.uniform.n_theta, 2, kMaxPlanAxis);
        s.uniform.n_dphi = p.integer("n_dphi", s.uniform.n_dphi, 2, kMaxPlanAxis);
        s.uniform.theta_max =
            p.number("theta_max_deg", s.uniform.theta_max / kDeg, 1, 89, "deg") * kDeg;
    } else if (s.plan_kind == "half-diff") {
        s.half_diff.n_theta_h = p.integer("n_theta_h", s.half_diff.n_theta_h, 1, kMaxPlanAxis);
        s.half_diff.n_theta_d = p.integer("n_theta_d", s.half_diff.n_theta_d, 1, kMaxPlanAxis);
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
        s.vndf.retro_phi_count = p.integer("retro_phi_count", s.vndf.retro_phi_count, 4, 128);
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
}

/// campaign.json "adaptive" (the refinement passes).
void parse_adaptive(const json& raw, CampaignSpec* out) {
    CampaignSpec& s = *out;
    JsonObject a(raw, "adaptive");
    s.adaptive = a.boolean("enabled", true);
    s.adaptive_passes = a.integer("passes", s.adaptive_passes, 0, 100);
    s.refine.budget = a.integer("budget", s.refine.budget, 0, kMaxPlanConfigs);
    s.refine.threshold = a.number("threshold", s.refine.threshold, 0, 10);
    s.refine.min_spacing =
        a.number("min_spacing_deg", s.refine.min_spacing / kDeg, 0, 90, "deg") * kDeg;
    a.finish();
}

/// campaign.json "drift" (the drift reference and its checks).
void parse_drift(const json& raw, CampaignSpec* out) {
    CampaignSpec& s = *out;
    JsonObject d(raw, "drift");
    s.drift_every = d.integer("every", s.drift_every, 0, kMaxPlanConfigs);
    s.drift_threshold = d.number("threshold", s.drift_threshold, 1e-6, 10);
    s.drift_theta_i_deg = d.number("theta_i_deg", s.drift_theta_i_deg, 0, 89, "deg");
    s.drift_theta_r_deg = d.number("theta_r_deg", s.drift_theta_r_deg, 0, 89, "deg");
    s.drift_delta_phi_deg = d.number("delta_phi_deg", s.drift_delta_phi_deg, 0, 180, "deg");
    d.finish();
}

/// campaign.json "until" (the stop rule), which the vndf plan refuses.
void parse_until(JsonObject& top, CampaignSpec* out) {
    CampaignSpec& s = *out;
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
}

/// The rules between the description's parts (options one plan cannot follow).
void check_combinations(const CampaignSpec& s) {
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
}

}  // namespace

bool isotropic_plan(const CampaignSpec& spec) {
    return spec.plan_kind != "anisotropic" && !(spec.plan_kind == "fit" && spec.fit.anisotropic);
}

Expected<CampaignSpec> parse_campaign_spec(const std::string& text, const std::string& source) {
    CampaignSpec s;
    s.json = text;
    try {
        const json j = parse_json_checked(text, source);
        JsonObject top(j, "");
        parse_names(top, &s);
        if (top.has("plan")) {
            JsonObject p(top.raw("plan"), "plan");
            parse_plan(p, &s);
            p.finish();
        }
        if (top.has("adaptive")) {
            parse_adaptive(top.raw("adaptive"), &s);
        }
        if (top.has("drift")) {
            parse_drift(top.raw("drift"), &s);
        }
        s.schedule_budget_s = top.number("schedule_budget_s", s.schedule_budget_s, 0, 3600, "s");
        if (top.has("fly")) {
            parse_fly(top.raw("fly"), &s.fly);
        }
        parse_until(top, &s);
        top.finish();
        check_combinations(s);
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

}  // namespace gonio::acquisition
