#include <filesystem>

#include "gonio/base/limits.h"
#include "gonio/report/plot.h"

namespace gonio::report {

brdf::Dataset without_reference_rows(const brdf::Dataset& data) {
    brdf::Dataset out = data;
    out.samples.clear();
    for (const brdf::Sample& s : data.samples) {
        if ((s.flags & brdf::kFlagReference) == 0) {
            out.samples.push_back(s);
        }
    }
    return out;
}

Expected<PlotSet> write_plots(const brdf::Dataset& data,
                              const brdf::Brdf* fit,
                              const PlotOptions& options,
                              const std::string& out_dir) {
    if (data.samples.empty()) {
        std::string why = data.source + ": empty dataset: no sample to plot";
        if (!data.rejected.empty()) {
            why += " (" + std::to_string(data.rejected.size()) + " rows rejected, first at line " +
                   std::to_string(data.rejected.front().line) + ": " +
                   data.rejected.front().reason + ")";
        }
        return make_error(why);
    }
    std::error_code ec;
    std::filesystem::create_directories(out_dir, ec);
    if (ec) {
        return make_error(out_dir + ": cannot create folder: " + ec.message());
    }
    struct Job {
        const char* file;
        const char* caption;
        Expected<Image> image;
    };
    std::vector<Job> jobs;
    PolarLayout in_plane;
    jobs.push_back({"in_plane.png",
                    "In-plane slices: BRDF against theta_o in the plane of incidence",
                    plot_in_plane(data, fit, options, &in_plane)});
    jobs.push_back({"delta_phi.png",
                    "Azimuthal slices: BRDF against delta_phi at fixed theta_i, theta_o",
                    plot_delta_phi(data, fit, options)});
    if (fit != nullptr) {
        jobs.push_back({"residuals.png",
                        "Residuals over (theta_h, theta_d)",
                        plot_residual_map(data, *fit, options)});
    }
    PlotSet out;
    if (jobs.front().image && in_plane.points_drawn == 0) {
        out.warnings.push_back(
            "in_plane.png: none of the " + std::to_string(data.samples.size()) +
            " samples lies in the plane of incidence of a slice drawn (within " +
            show_number(options.angle_tolerance_deg) +
            " deg): every slice shows 0 points, only the fit; the samples are scattered (see "
            "delta_phi.png and residuals.png)");
    }
    for (Job& j : jobs) {
        if (!j.image) {
            out.skipped.push_back(std::string(j.file) + ": " + j.image.error().message);
            continue;
        }
        const std::string path = (std::filesystem::path(out_dir) / j.file).string();
        if (auto w = write_png(path, *j.image); !w) {
            return make_error(w.error().message);
        }
        out.written.push_back({path, j.caption});
    }
    if (out.written.empty()) {
        std::string why = data.source + ": nothing to plot";
        for (const std::string& s : out.skipped) {
            why += "; " + s;
        }
        return make_error(why);
    }
    return out;
}

}  // namespace gonio::report
