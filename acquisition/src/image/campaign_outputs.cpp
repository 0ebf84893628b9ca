#include <filesystem>
#include <nlohmann/json.hpp>

#include "gonio/acquisition/image/bin_uncertainty.h"
#include "gonio/acquisition/image/image_campaign.h"
#include "gonio/base/atomic_file.h"
#include "gonio/base/strict_json.h"
#include "gonio/brdf/merl.h"

namespace gonio::acquisition {
namespace {

/// dataset.csv (bin_uncertainty.h: the rows' sigmas state the rig's error budget), the table file (isotropic campaigns: table.binary for the MERL layout, else
/// table.gtab) and coverage.png; returns the table file's name ("" when none is written: the
/// half/difference table has no place for phi_h, so an anisotropic campaign writes its 4-D bins
/// as the dataset only).
Expected<std::string> write_data_files(const std::string& base,
                                       const ImageCampaignResult& result,
                                       const ImageCampaignConfig& config) {
    const bool aniso = result.aniso_table.has_value() && result.aniso_coverage.has_value();
    const brdf::Dataset data = image_campaign_dataset(result, config);
    if (auto r = brdf::write_dataset_csv(base + "dataset.csv", data); !r) {
        return tl::unexpected(r.error());
    }
    const TableLayout& l = aniso ? result.aniso_table->layout().iso() : config.layout;
    const bool merl = l.n_theta_h == 90 && l.n_theta_d == 90 && l.n_phi_d == 180;
    const std::string table_name = aniso ? "" : merl ? "table.binary" : "table.gtab";
    if (!aniso) {
        if (auto r = brdf::write_merl(
                base + table_name,
                to_tabulated(result.table, config.min_count, "image-mode campaign"));
            !r) {
            return tl::unexpected(r.error());
        }
    }
    if (auto r = write_coverage_png(
            base + "coverage.png",
            aniso ? result.aniso_coverage->cells() : coverage_cells(result.table, config.min_count),
            l);
        !r) {
        return tl::unexpected(r.error());
    }
    return table_name;
}

/// The camera, sphere, calibration and table of dataset.json.
void describe_setup(const ImageCampaignResult& result,
                    const ImageCampaignConfig& config,
                    const std::string& table_name,
                    nlohmann::json* out) {
    nlohmann::json& j = *out;
    const bool aniso = result.aniso_table.has_value() && result.aniso_coverage.has_value();
    j["mode"] = "image";
    j["camera_model"] = nlohmann::json::parse(camera_model_to_json(config.camera));
    j["sphere"] = {
        {"centre_m",
         {result.sphere.centre.x(), result.sphere.centre.y(), result.sphere.centre.z()}},
        {"radius_m", result.sphere.radius_m},
        {"silhouette_px",
         {result.sphere.silhouette.cx, result.sphere.silhouette.cy, result.sphere.silhouette.r}},
        {"fit_rms_px", result.sphere.rms_residual_px}};
    j["calibration_counts_per_us_per_inv_sr"] = result.calibration;
    j["reference_albedo"] = config.reference_albedo;
    if (aniso) {
        const AnisoLayout& a = result.aniso_table->layout();
        j["anisotropic"] = true;
        j["sample_shape"] =
            "turned sphere: tangent along the circles of latitude about the lathe axis, mounted "
            "along the holder's y axis";
        j["table"] = {{"n_theta_h", a.n_theta_h},
                      {"n_phi_h", a.n_phi_h},
                      {"n_theta_d", a.n_theta_d},
                      {"n_phi_d", a.n_phi_d},
                      {"frame", "material (normal and tangent)"},
                      {"file", nullptr}};
        j["pole_cap_deg"] = config.pole_rad * 180 / brdf::kPi;
    } else {
        const TableLayout& l = config.layout;
        j["table"] = {{"n_theta_h", l.n_theta_h},
                      {"n_theta_d", l.n_theta_d},
                      {"n_phi_d", l.n_phi_d},
                      {"file", table_name}};
    }
}

/// The coverage, pixel counts, frames, placements and holes of dataset.json.
void describe_frames(const ImageCampaignResult& result,
                     const ImageCampaignConfig& config,
                     nlohmann::json* out) {
    nlohmann::json& j = *out;
    const bool aniso = result.aniso_table.has_value() && result.aniso_coverage.has_value();
    j["coverage"] = {{"target", config.coverage_target},
                     {"achieved", result.coverage_fraction()},
                     {"target_met", result.target_met},
                     {"stop_reason", result.stop_reason},
                     {"valid_bins", result.valid_bins()},
                     {"covered_bins", result.covered_bins()},
                     {"reachable_bins", result.reachable_bins}};
    const PixelCounts& c = result.counts;
    j["pixels"] = {{"on_sphere", c.on_sphere},
                   {"edge", c.edge},
                   {"grazing_view", c.grazing_view},
                   {"shadow", c.shadow},
                   {"grazing_light", c.grazing_light},
                   {"saturated", c.saturated},
                   {"nonfinite", c.nonfinite},
                   {"pole", c.pole},
                   {"used", c.used}};
    nlohmann::json frames = nlohmann::json::array();
    for (const FrameRecord& f : result.frames) {
        nlohmann::json fj = {{"light_arm_deg", f.light_arm_rad * 180 / brdf::kPi},
                             {"used_pixels", f.counts.used},
                             {"saturated_pixels", f.counts.saturated},
                             {"exposures", f.exposures},
                             {"coverage_after", f.coverage_after}};
        if (aniso) {
            fj["spin_deg"] = f.spin_rad * 180 / brdf::kPi;
        }
        if (f.placement > 0) {
            fj["placement"] = config.placements[static_cast<std::size_t>(f.placement - 1)].name;
        }
        frames.push_back(fj);
    }
    j["frames"] = frames;
    if (!config.placements.empty()) {
        nlohmann::json placements = nlohmann::json::array();
        for (const Placement& p : config.placements) {
            placements.push_back({{"name", p.name},
                                  {"magnification", p.magnification},
                                  {"offset_m", {p.offset_m[0], p.offset_m[1]}}});
        }
        j["placements"] = placements;
    }
    nlohmann::json holes = nlohmann::json::array();
    for (const CoverageHole& h : result.holes) {
        holes.push_back(
            {{"theta_d_deg", {h.theta_d_min * 180 / brdf::kPi, h.theta_d_max * 180 / brdf::kPi}},
             {"theta_h_deg", {h.theta_h_min * 180 / brdf::kPi, h.theta_h_max * 180 / brdf::kPi}},
             {"bins", h.bins},
             {"reason", h.reason}});
    }
    j["holes"] = holes;
    j["captures"] = result.captures;
    j["exposure_time_s"] = result.exposure_time_s;
    // What the rows' sigmas state beside the bins' standard errors (bin_uncertainty.h).
    j["stated_uncertainty"] = {{"error_budget", config.error_budget.profile},
                               {"rig_hours_since_white", image_rig_hours(result, config)}};
}

}  // namespace

Expected<void> write_image_campaign(const std::string& dir,
                                    const ImageCampaignResult& result,
                                    const ImageCampaignConfig& config,
                                    const std::string& extra_json) {
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    if (ec) {
        return make_error(dir + ": cannot create directory: " + ec.message());
    }
    const std::string base = (std::filesystem::path(dir) / "").string();
    auto table_name = write_data_files(base, result, config);
    if (!table_name) {
        return tl::unexpected(table_name.error());
    }
    nlohmann::json j;
    describe_setup(result, config, *table_name, &j);
    describe_frames(result, config, &j);
    try {
        const nlohmann::json extra = nlohmann::json::parse(extra_json);
        if (extra.is_object()) {
            j.update(extra);
        }
    } catch (const nlohmann::json::exception& e) {
        return make_error(std::string("dataset.json extra metadata: ") + json_error_text(e.what()));
    }
    const std::string path = base + "dataset.json";
    return write_file_atomic(path, j.dump(2) + "\n");
}

}  // namespace gonio::acquisition
